"""Study report of finished runs: ``dpiil-report runs=runs/paper`` (or ``make report``).

Recomputes every run's numbers from its ``episodes.jsonl`` and writes, into ``out`` (default
``<first of runs>/report``): ``results.md``/``results.csv`` (mean ± std per method beside the paper's
numbers), ``stats.md``/``stats.json`` (Welch t-tests, χ-sensitivity r²) and the paper's Fig. 3 panels.
Several roots: ``runs=[runs/paper,runs/paper_chi]`` or ``runs=runs/paper,runs/paper_chi``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from dpiil_rl.study.study_report import summary_text, write_study_report
from dpiil_rl.utils.cli import comma_list_override, report_user_errors, run_roots

ROOT = Path(__file__).resolve().parents[1]  # the package: its configs/ and cli/


@hydra.main(config_path="../configs", config_name="report", version_base="1.3")
@report_user_errors
def run(cfg: DictConfig) -> None:
    # Where the runs are and where the report goes
    if OmegaConf.is_missing(cfg, "runs"):
        raise ValueError("runs: not given; expected runs=<directory of finished runs> (or runs=[dir1,dir2])")
    roots = run_roots(cfg.runs)
    out = Path(cfg.out) if cfg.out is not None else roots[0] / "report"
    paper_dir = Path(cfg.paper_reference)
    # Recompute, test, plot, write
    result = write_study_report(
        roots, out, reference=str(cfg.reference), paper_dir=paper_dir if paper_dir.is_absolute() else ROOT / paper_dir
    )
    print(summary_text(result))


def main() -> None:
    """The ``dpiil-report`` command."""
    sys.argv = comma_list_override(sys.argv)
    run()


if __name__ == "__main__":
    main()
