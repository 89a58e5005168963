"""What the gates read along the task: ``dpiil-gate-trace runs=<study> [out=<file.md>]``.

For every finished run of ``methods`` below ``runs`` that has a checkpoint and no saved trace yet, the final
policy is run alone for ``episodes`` episodes with the gate's components written down at every step
(:mod:`dpiil_rl.training.gate_trace`, into ``<run>/evaluations/``); then the traces of all the runs (also
committed ones, which keep their traces and no checkpoints) are tabulated
(:mod:`dpiil_rl.study.gate_trace_table`) and printed, and with ``out`` written.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig
from tqdm import tqdm

from dpiil_rl.records.checkpoints import latest_checkpoint
from dpiil_rl.study.gate_trace_table import gate_trace_markdown, load_traces, trace_name
from dpiil_rl.study.study_runs import load_study
from dpiil_rl.training.gate_trace import trace_gate
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="gate_trace", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> str:
    methods = set(cfg.methods)
    roots = str(cfg.runs) if isinstance(cfg.runs, str) else [str(x) for x in cfg.runs]  # one study or several
    runs = [r for r in load_study(roots) if not r.is_sensitivity and r.method in methods]
    if not runs:
        raise ValueError(f"runs = {cfg.runs!r}: no finished run of methods {sorted(methods)} below it")
    stage_names: list[str] = []
    todo = [
        r
        for r in runs
        if not any(
            (Path(r.run_dir) / "evaluations" / f"{trace_name(cfg.episodes)}{ext}").exists()
            for ext in (".jsonl", ".jsonl.gz")
        )
        and latest_checkpoint(r.run_dir) is not None
    ]
    for r in tqdm(todo, desc="gate traces", unit="run"):
        stage_names = list(trace_gate(r.run_dir, int(cfg.episodes), int(cfg.seed))["stage_names"] or [])
    if not stage_names:
        stage_names = list(cfg.stage_names)
    traces = load_traces(runs, int(cfg.episodes), float(cfg.speed_scale))
    if not traces:
        raise FileNotFoundError(
            f"runs = {cfg.runs!r}: no run has a trace of {cfg.episodes} episodes or a checkpoint to make one"
        )
    overrides = " ".join(HydraConfig.get().overrides.task) if HydraConfig.initialized() else ""
    text = gate_trace_markdown(
        traces, stage_names, int(cfg.episodes), str(cfg.speed_unit), f"dpiil-gate-trace {overrides}".strip()
    )
    print(text)
    if cfg.out is not None:
        out = Path(str(cfg.out))
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        print(f"wrote {out}")
    return text


def main() -> None:
    """The ``dpiil-gate-trace`` command."""
    run()


if __name__ == "__main__":
    main()
