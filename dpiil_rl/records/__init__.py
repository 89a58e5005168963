"""What a run writes to its directory (DESIGN section 5)."""
