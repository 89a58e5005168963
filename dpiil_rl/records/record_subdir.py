"""``hydra.output_subdir`` of ``dpiil-train``: ``.hydra`` for a run still to train, ``None`` for a finished one.

Hydra writes a job's ``.hydra/{config,hydra,overrides}.yaml`` before the run decides to skip itself, so a
sweep run again over finished runs (``make frontier``, ``make paper`` resumed with a newer config schema) would
overwrite the config the run was made with. The resolver reads the job's run directory: a ``summary.json``
there means the run is finished, and its ``.hydra/`` is left as the run wrote it."""

from __future__ import annotations

from pathlib import Path

from omegaconf import OmegaConf

RESOLVER = "dpiil_record_subdir"
SUBDIR = ".hydra"


def record_subdir(output_dir: str) -> str | None:
    """``None`` (write nothing) when ``output_dir`` holds a finished run, else ``.hydra``."""
    return None if (Path(output_dir) / "summary.json").exists() else SUBDIR


def register() -> None:
    """Register the resolver once (imported by ``dpiil-train`` before Hydra composes its config)."""
    if not OmegaConf.has_resolver(RESOLVER):
        OmegaConf.register_new_resolver(RESOLVER, record_subdir)
