"""The commands of the safety–effort frontier: for each geometry and method, a lockstep multirun of
``dpiil-train`` over the method's own knob (:class:`~dpiil_rl.methods.frontier_knob.FrontierKnob`)
and the seeds, with the study protocol of the aperture task (8 scripted robots side by side, no per-run
figures, no dashboard)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence, cast

from omegaconf import DictConfig, OmegaConf

from dpiil_rl.methods.frontier_knob import FrontierKnob

#: every frontier run: the paper protocol with 8 scripted robots side by side, quiet and figure-free
RUN_SETTINGS = ("progress=false", "plots=false", "logger=none", "protocol.interactive_envs=8", "checkpoint_keep=1")


def method_config(config_dir: str | Path, method: str) -> dict:
    """``configs/method/<method>.yaml`` with the method files its defaults list names merged under it (a
    variant such as ``lazy_dagger`` or ``dagger_1step`` extends another method's file)."""
    path = Path(config_dir) / "method" / f"{method}.yaml"
    if not path.exists():
        known = sorted(p.stem for p in (Path(config_dir) / "method").glob("*.yaml"))
        raise ValueError(f"methods: {method!r} is not a method (expected one of {', '.join(known)})")
    own = cast(DictConfig, OmegaConf.load(path))  # a method file is a mapping
    merged = OmegaConf.create({})
    for entry in own.pop("defaults", []) or []:
        if entry != "_self_":
            merged = OmegaConf.merge(merged, method_config(config_dir, str(entry)))
    return OmegaConf.to_container(OmegaConf.merge(merged, own), resolve=False)  # type: ignore[return-value]


def method_knob(config_dir: str | Path, method: str) -> FrontierKnob:
    """The frontier knob of ``configs/method/<method>.yaml``."""
    spec = method_config(config_dir, method).get("frontier")
    if spec is None:
        raise ValueError(
            f"methods: {method!r} has no frontier knob (expected a frontier: block in configs/method/{method}.yaml)"
        )
    return FrontierKnob.from_config(spec, method)


def frontier_commands(
    config_dir: str | Path,
    methods: Sequence[str],
    experiments: Sequence[str | None],
    seeds: int,
    study: str,
    jobs: int,
    args: Sequence[str] = (),
) -> list[list[str]]:
    """One ``train.py -m`` argument list per (geometry, method)."""
    if int(seeds) < 2:
        raise ValueError(f"seeds = {seeds}: expected at least 2 seeds per knob value (the bands are over seeds)")
    out = []
    for experiment in experiments:
        for method in methods:
            knob = method_knob(config_dir, method)
            values = ",".join(f"{v:g}" for v in knob.values)
            cmd = [
                "-m",
                f"method={method}",
                f"{knob.key}={values}",
                *(f"{t}=${{{knob.key}}}" for t in knob.tied),
                f"run_name=${{method.name}}-{knob.label}${{{knob.key}}}",
                f"seed={','.join(str(s) for s in range(int(seeds)))}",
                f"study={study}",
                *RUN_SETTINGS,
                "hydra/launcher=lockstep",
                f"hydra.launcher.n_jobs={int(jobs)}",
                *args,
            ]
            if experiment:
                cmd.insert(1, f"experiment={experiment}")
            out.append(cmd)
    return out
