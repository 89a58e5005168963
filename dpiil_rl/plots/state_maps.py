"""Maps over a 2D state space of normalised precision, ensemble uncertainty and risk (paper Fig. 3(a)),
with demonstrations and interactive paths (auto and expert segments in different colours) on top."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from tensordict import TensorDict  # noqa: E402


def normalise(a: np.ndarray) -> np.ndarray:
    lo, hi = np.nanmin(a), np.nanmax(a)
    return (a - lo) / (hi - lo) if hi > lo else np.zeros_like(a)


def evaluate_grid(
    actor: torch.nn.Module,
    speed_head: torch.nn.Module,
    risk_fn: Callable[[TensorDict], torch.Tensor] | None,
    extent: Sequence[float],
    resolution: int = 120,
) -> dict[str, np.ndarray]:
    x0, y0, x1, y1 = extent
    xs, ys = np.linspace(x0, x1, resolution), np.linspace(y0, y1, resolution)
    gx, gy = np.meshgrid(xs, ys)
    obs = torch.tensor(np.stack([gx, gy], -1).reshape(-1, 2), dtype=torch.float32)
    with torch.no_grad():
        td = speed_head(actor(TensorDict({"observation": obs}, batch_size=[obs.shape[0]])))
        precision = (1.0 / (td["speed_mu"] + td["speed_sigma"])).reshape(resolution, resolution).numpy()
        uncertainty = td["action_var"].reshape(resolution, resolution).numpy()
        risk = risk_fn(td).reshape(resolution, resolution).numpy() if risk_fn is not None else precision * uncertainty
    return {"precision": precision, "uncertainty": uncertainty, "risk": risk}


def draw_path(ax: Any, row: dict[str, Any], demo: bool) -> None:
    p = np.asarray(row["positions"])
    if demo:
        ax.plot(p[:, 0], p[:, 1], color="k", lw=0.9, alpha=0.8, zorder=4)
        return
    mode = np.asarray(row["expert_mode"], dtype=bool)
    # step t is the segment from position t to t + 1, coloured by who drove it; one collection per path
    # (a line per step made plotting the slowest part of a short run)
    steps = min(len(mode), len(p) - 1)
    if steps <= 0:
        return
    segments = np.stack([p[:steps], p[1 : steps + 1]], axis=1)
    colours = np.where(mode[:steps], "tab:red", "tab:cyan")
    ax.add_collection(LineCollection(list(segments[:, :, :2]), colors=list(colours), linewidths=1.4, zorder=5))
    ax.autoscale_view()  # as ax.plot would


def plot_state_maps(
    grids: dict[str, np.ndarray],
    extent: Sequence[float],
    draw_background: Callable[[Any], None],
    path: str | Path,
    demos: Sequence[dict[str, Any]] = (),
    interactive: Sequence[dict[str, Any]] = (),
    chi: float | None = None,
    title: str = "",
) -> Path:
    x0, y0, x1, y1 = extent
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.8))
    panels = [
        ("normalised precision 1/(μ+σ)", normalise(grids["precision"]), "magma"),
        ("normalised ensemble uncertainty σ²_θ", normalise(grids["uncertainty"]), "viridis"),
        (
            "log10 risk" + (f"  (χ = {chi:.2e}: contour)" if chi else ""),
            np.log10(np.maximum(grids["risk"], 1e-12)),
            "inferno",
        ),
    ]
    for ax, (name, image, cmap) in zip(axes, panels):
        im = ax.imshow(image, origin="lower", extent=(x0, x1, y0, y1), cmap=cmap, zorder=1)
        fig.colorbar(im, ax=ax, fraction=0.046)
        if name.startswith("log10 risk") and chi:
            ax.contour(
                np.linspace(x0, x1, image.shape[1]),
                np.linspace(y0, y1, image.shape[0]),
                grids["risk"],
                levels=[chi],
                colors="w",
                linewidths=0.8,
                zorder=2,
            )
        draw_background(ax)
        for row in demos:
            draw_path(ax, row, demo=True)
        for row in interactive:
            draw_path(ax, row, demo=False)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("x (cm)")
    axes[0].set_ylabel("y (cm)")
    fig.suptitle(title + "   black: demos · cyan: robot (auto) · red: expert", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
