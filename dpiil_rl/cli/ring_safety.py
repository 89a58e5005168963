"""Why a gate was less safe while learning the ring, from the runs' records.

``dpiil-ring-safety [out=ring_safety.md]`` reads the studies of ``configs/ring_safety.yaml`` (``studies``: a
list of ``{label, runs}``, ``runs`` a directory of finished ring runs), computes per study and method where
the interactive failures and contacts were, the expert-mode share, the risk relative to χ and the robot's
speed by stage (:mod:`dpiil_rl.study.ring_safety`), and prints the markdown
(:mod:`dpiil_rl.study.ring_safety_report`); with ``out`` it writes it and the hand-over figure beside it
(``.png``, :mod:`dpiil_rl.study.ring_safety_figure`).
"""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dpiil_rl.study.ring_safety import method_safety, run_safety
from dpiil_rl.study.ring_safety_figure import handover_figure
from dpiil_rl.study.ring_safety_report import ring_safety_markdown, runs_line
from dpiil_rl.study.study_runs import load_study
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="ring_safety", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> str:
    if not cfg.studies:
        raise ValueError("studies: empty; expected a list of {label, runs} (see configs/ring_safety.yaml)")
    runs = []
    for entry in cfg.studies:
        if "label" not in entry or "runs" not in entry:
            raise ValueError(f"studies: {entry}: expected {{label: <name>, runs: <directory of finished ring runs>}}")
        label, root = str(entry.label), str(entry.runs)
        study = [r for r in load_study(Path(str(root))) if not r.is_sensitivity]
        other = sorted({r.env for r in study if r.env != "ring"})
        if other:
            raise ValueError(f"studies: {label} = {root}: runs of env {other} (expected ring runs only)")
        if not study:
            raise ValueError(f"studies: {label} = {root}: no finished run below it")
        runs += [run_safety(r, str(label)) for r in study]
    groups = method_safety(runs)
    overrides = " ".join(HydraConfig.get().overrides.task) if HydraConfig.initialized() else ""
    text = ring_safety_markdown(groups, str(cfg.reference), f"dpiil-ring-safety {overrides}".strip())
    print(text)
    print(f"runs read: {runs_line(runs)}")
    if cfg.out is not None:
        out = Path(str(cfg.out))
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        shown = [g for g in groups if g.method in set(cfg.figure_methods)]
        figure = handover_figure(shown, out.with_suffix(".png"))
        print(f"wrote {out} and {figure}")
    return text


def main() -> None:
    """The ``dpiil-ring-safety`` command."""
    run()


if __name__ == "__main__":
    main()
