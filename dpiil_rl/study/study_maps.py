"""Paper Fig. 3(a) for a study: what the models learned from the initial demos, and one early
interactive episode of several methods.

Every method of a seed starts from the same demos and the same initial models, so one run's
``checkpoints/iter_000`` (the map method's, DPIIL_UCB by default) gives the normalised precision and
ensemble-uncertainty maps; the trajectory panels show the first interactive episode of iteration 1 of
each method (cyan: robot, red: expert; end marker green on success, red on failure).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from dpiil_rl.plots.state_maps import draw_path, evaluate_grid, normalise  # noqa: E402
from dpiil_rl.records.checkpoints import checkpoint_dir, load_state  # noqa: E402
from dpiil_rl.study.study_runs import StudyRun, method_order  # noqa: E402
from dpiil_rl.training.factory import build_env, make_actor, make_speed_head  # noqa: E402

if TYPE_CHECKING:
    from torchrl.data.tensor_specs import ContinuousBox

#: methods whose first interactive episode is drawn (paper Fig. 3(a)), when they exist
TRAJECTORY_METHODS = ("dagger", "ensemble_dagger", "dpiil_ucb")


def draw_episode(ax: Any, path_row: dict[str, Any], success: bool | None) -> None:
    """One interactive path (auto and expert segments in different colours) with an end marker."""
    draw_path(ax, path_row, demo=False)
    end = np.asarray(path_row["positions"])[-1]
    color = "0.5" if success is None else ("tab:green" if success else "tab:red")
    ax.scatter([end[0]], [end[1]], s=60, marker="o", color=color, edgecolor="k", zorder=6)


def first_interactive_episode(run: StudyRun, iteration: int = 1) -> tuple[dict[str, Any], bool | None] | None:
    """The run's first interactive path of ``iteration`` and whether that episode succeeded."""
    paths = sorted(
        (r for r in run.paths() if r["phase"] == "interactive" and r["iteration"] == iteration),
        key=lambda r: r["episode"],
    )
    if not paths:
        return None
    row = paths[0]
    outcome = [e["success"] for e in run.episodes if e["phase"] == "interactive" and e.get("episode") == row["episode"]]
    return row, (bool(outcome[0]) if outcome else None)


def _source_run(runs: Sequence[StudyRun], map_method: str, seed: int | None) -> StudyRun | None:
    """The run whose initial checkpoint is drawn: ``map_method`` at ``seed`` (default its smallest seed),
    else the first method (paper order) that has that seed."""
    main = [r for r in runs if r.chi_fixed is None and (r.run_dir / "checkpoints" / "iter_000" / "state.pt").exists()]
    preferred = sorted(
        (r for r in main if r.method == map_method and (seed is None or r.seed == seed)), key=lambda r: r.seed
    )
    if preferred:
        return preferred[0]
    for method in method_order(r.method for r in main):
        candidates = sorted(
            (r for r in main if r.method == method and (seed is None or r.seed == seed)), key=lambda r: r.seed
        )
        if candidates:
            return candidates[0]
    return None


def plot_study_maps(
    runs: Sequence[StudyRun],
    path: str | Path,
    seed: int | None = None,
    map_method: str = "dpiil_ucb",
    trajectory_methods: Sequence[str] = TRAJECTORY_METHODS,
    resolution: int = 120,
) -> tuple[Path | None, str]:
    """Draw Fig. 3(a) for one env's runs; returns ``(path, note)``, ``path`` None when skipped (note says why)."""
    source = _source_run(runs, map_method, seed)
    if source is None:
        return None, "fig3a skipped: no calibrated-χ run with checkpoints/iter_000/state.pt" + (
            f" for seed {seed}" if seed is not None else ""
        )
    cfg = source.config
    env = build_env(cfg.env, 1, seed=source.seed)
    draw = getattr(env, "draw_background", None)
    if draw is None or env.observation_spec["observation"].shape[-1] != 2:
        return None, f"fig3a skipped: env {source.env!r} has no 2-D observation with draw_background"
    geometry = getattr(env, "geometry", None)
    spec = cast("ContinuousBox", env.observation_spec["observation"].space)  # a bounded spec's space is a box
    extent = (
        geometry.arena
        if geometry is not None
        else (*spec.low.reshape(-1, 2)[0].tolist(), *spec.high.reshape(-1, 2)[0].tolist())
    )
    actor, speed = make_actor(cfg.modules.actor, env), make_speed_head(cfg.modules.speed_head, env)
    state = load_state(checkpoint_dir(source.run_dir, 0))
    actor.load_state_dict(state["actor"])
    speed.load_state_dict(state["speed_head"])
    grids = evaluate_grid(actor, speed, None, extent, resolution)
    demos = [r for r in source.paths() if r["phase"] == "demo" and r["iteration"] == 0]

    episodes = []
    for method in trajectory_methods:
        run = next((r for r in runs if r.method == method and r.seed == source.seed and r.chi_fixed is None), None)
        found = first_interactive_episode(run) if run is not None else None
        if found is not None:
            episodes.append((method, *found))

    x0, y0, x1, y1 = extent
    panels = 2 + len(episodes)
    fig, axes = plt.subplots(1, panels, figsize=(3.9 * panels, 4.1), squeeze=False)
    axes = axes[0]
    maps = [
        ("normalised precision 1/(μ+σ)", normalise(grids["precision"]), "magma"),
        ("normalised ensemble uncertainty σ²_θ", normalise(grids["uncertainty"]), "viridis"),
    ]
    for ax, (name, image, cmap) in zip(axes, maps):
        im = ax.imshow(image, origin="lower", extent=(x0, x1, y0, y1), cmap=cmap, vmin=0, vmax=1, zorder=1)
        fig.colorbar(im, ax=ax, fraction=0.046)
        draw(ax)
        for row in demos:
            draw_path(ax, row, demo=True)
        ax.set_title(name, fontsize=9)
    faint = normalise(grids["uncertainty"])
    for ax, (method, row, success) in zip(axes[2:], episodes):
        ax.imshow(faint, origin="lower", extent=(x0, x1, y0, y1), cmap="Greys", vmin=0, vmax=2.5, zorder=1)
        draw(ax)
        for demo in demos:
            ax.plot(*np.asarray(demo["positions"]).T, color="0.35", lw=0.6, alpha=0.6, zorder=4)
        draw_episode(ax, row, success)
        outcome = "?" if success is None else ("success" if success else "failure")
        ax.set_title(f"{method}: first episode of k=1 ({outcome})", fontsize=9)
    for ax in axes:
        ax.set_xlabel("x (cm)")
    axes[0].set_ylabel("y (cm)")
    fig.suptitle(
        f"{source.env} · seed {source.seed} · models after the demos (k=0, from {source.method})   "
        "black: demos · cyan: robot · red: expert · end ● green success / red failure",
        fontsize=9,
    )
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    missing = [m for m in trajectory_methods if m not in {e[0] for e in episodes}]
    note = f"fig3a: seed {source.seed}, maps from {source.method}'s iter_000"
    if missing:
        note += f"; no interactive episode of k=1 for {', '.join(missing)}"
    return path, note
