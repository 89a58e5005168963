"""Replay buffer of expert-labelled frames."""
