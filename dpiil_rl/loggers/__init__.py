"""Experiment loggers chosen by configs/logger/ (wandb offline, CSV, none)."""
