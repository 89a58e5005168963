"""The command line: one module per installed command (``dpiil-train``, ``dpiil-report``, ...), each a thin
Hydra entry that calls the package; ``python -m dpiil_rl.cli.<name>`` runs the same."""
