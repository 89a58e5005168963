"""dpiil_rl's Hydra launchers (Hydra finds plugins only in the ``hydra_plugins`` namespace package)."""
