"""The safety–effort frontier: ``dpiil-frontier`` (or ``make frontier``).

Recipe: for each geometry (``experiments``) and method, read the method's own knob from its YAML, then
train every (knob value, seed) as a lockstep multirun of ``dpiil-train``; finished runs are skipped
and stopped ones resume, so running it again finishes what is missing. ``make report RUNS=runs/frontier``
then draws the frontier and the matched-effort table.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

from dpiil_rl.training.frontier_sweep import frontier_commands
from dpiil_rl.utils.cli import report_user_errors

ROOT = Path(__file__).resolve().parents[1]  # the package: its configs/ and cli/


@hydra.main(config_path="../configs", config_name="frontier", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> None:
    commands = frontier_commands(
        ROOT / "configs",
        list(cfg.methods),
        list(cfg.experiments),
        int(cfg.seeds),
        str(cfg.study),
        int(cfg.jobs),
        list(cfg.args),
    )
    for i, cmd in enumerate(commands, 1):
        print(f"[frontier] {i}/{len(commands)}: dpiil-train {' '.join(cmd)}", flush=True)
        if not cfg.dry_run:
            subprocess.run([sys.executable, "-m", "dpiil_rl.cli.train", *cmd], check=True)


def main() -> None:
    """The ``dpiil-frontier`` command."""
    run()


if __name__ == "__main__":
    main()
