"""What a run writes to its directory (docs/design.md, "The run directory")."""
