"""At the end of a run: learning curve and, for 2D tasks, precision/uncertainty/risk maps (PNG + dashboard)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from torchrl.envs import EnvBase

from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.plots.learning_curve import plot_learning_curve
from dpiil_rl.plots.state_maps import evaluate_grid, plot_state_maps
from dpiil_rl.records.checkpoints import checkpoint_dir, load_state

if TYPE_CHECKING:
    import torch
    from torchrl.data.tensor_specs import ContinuousBox

    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class PlotHook(LoopHook):
    stage = "post_train"

    def __init__(self, env: EnvBase) -> None:
        self.env = env

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        out = Path(trainer.run_dir) / "plots"
        out.mkdir(exist_ok=True)
        title = f"{trainer.info.get('env')} · {trainer.info.get('method')} · seed {trainer.info.get('seed')}"
        images = {
            "plots/learning_curve": plot_learning_curve(trainer.run_files.metrics, out / "learning_curve.png", title)
        }
        draw = getattr(self.env, "draw_background", None)
        obs_spec = self.env.observation_spec["observation"]
        if draw is not None and obs_spec.shape[-1] == 2:
            images.update(self._maps(trainer, draw, out, title))
        draw_paths = getattr(self.env, "plot_paths", None)  # tasks whose state is not a plane draw their paths
        if draw_paths is not None:
            images.update(self._paths(trainer, draw_paths, out, title))
        for name, path in images.items():
            trainer.logger.log_image(name, path)
        return {}

    def _paths(self, trainer: "InteractiveTrainer", draw_paths: Any, out: Path, title: str) -> dict[str, Path]:
        paths = trainer.run_files.read_paths()
        success = {int(r["episode"]): bool(r["success"]) for r in trainer.run_files.episodes}
        images: dict[str, Path] = {}
        demos = [r for r in paths if r["phase"] == "demo" and r["iteration"] == 0][:10]
        if demos:
            images["plots/paths_demos"] = draw_paths(demos, success, out / "paths_demos.png", title + " · first demos")
        last = [r for r in paths if r["phase"] == "interactive" and r["iteration"] == trainer.iteration][:10]
        if last:
            images["plots/paths_interactive_final"] = draw_paths(
                last,
                success,
                out / "paths_interactive_final.png",
                title + f" · interactive episodes, k={trainer.iteration}",
            )
        return images

    def _maps(self, trainer: "InteractiveTrainer", draw: Any, out: Path, title: str) -> dict[str, Path]:
        geometry = getattr(self.env, "geometry", None)
        extent = (
            geometry.arena
            if geometry is not None
            else (
                # a bounded spec's space is a box
                *cast("ContinuousBox", self.env.observation_spec["observation"].space).low[0].tolist(),
                *cast("ContinuousBox", self.env.observation_spec["observation"].space).high[0].tolist(),
            )
        )
        paths = trainer.run_files.read_paths()
        demos = [r for r in paths if r["phase"] == "demo" and r["iteration"] == 0]
        risk_fn = getattr(trainer.gate, "risk", None)
        images: dict[str, Path] = {}
        initial = checkpoint_dir(trainer.run_dir, 0)
        if (initial / "state.pt").exists():
            state = load_state(initial)
            actor, speed = copy.deepcopy(trainer.actor), copy.deepcopy(trainer.speed_head)
            actor.load_state_dict(state["actor"])
            speed.load_state_dict(state["speed_head"])
            # the gate's networks and χ are copied; an expert source it consults (ThriftyDAgger's switch-back,
            # HG-DAgger's takeover) is shared: a person's window, pad, stream or robot cannot be copied
            expert = trainer.collector.expert
            gate = copy.deepcopy(trainer.gate, memo={} if expert is None else {id(expert): expert})
            gate.load_state_dict(state["gate"])
            first = [r for r in paths if r["phase"] == "interactive" and r["iteration"] == 1][:1]
            grids = evaluate_grid(actor, speed, getattr(gate, "risk", None), extent)
            chi = float(cast("torch.Tensor", gate.chi)) if hasattr(gate, "chi") else None  # a gate's buffer
            images["plots/maps_initial"] = plot_state_maps(
                grids, extent, draw, out / "maps_initial.png", demos, first, chi, title + " · after demos (k=0)"
            )
        last = [r for r in paths if r["phase"] == "interactive" and r["iteration"] == trainer.iteration]
        grids = evaluate_grid(trainer.actor, trainer.speed_head, risk_fn, extent)
        chi = float(cast("torch.Tensor", trainer.gate.chi)) if hasattr(trainer.gate, "chi") else None
        images["plots/maps_final"] = plot_state_maps(
            grids,
            extent,
            draw,
            out / "maps_final.png",
            demos,
            last[:3],
            chi,
            title
            + f" · final (k={trainer.iteration})"
            + ("" if trainer.method.uses_speed_head else " · precision from k=0 (unused)"),
        )
        return images
