"""The interactive training loop and the factories that assemble it from a config."""
