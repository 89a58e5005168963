"""Figures of a run (PNG next to the run, logged to the dashboard)."""
