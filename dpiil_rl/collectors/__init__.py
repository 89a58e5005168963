"""Collectors: one intervention collector for demos, interaction and evaluation."""
