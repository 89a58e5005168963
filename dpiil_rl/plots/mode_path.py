"""One episode's path coloured by who was in control, for the arm tasks' top and side views."""

from __future__ import annotations

from typing import Any, Sequence

from matplotlib.collections import LineCollection

EXPERT, ROBOT = "tab:orange", "tab:blue"  # segment colours: expert in control / robot in control


def draw_mode_path(
    ax: Any, xs: Sequence[float], ys: Sequence[float], modes: Sequence[bool], success: bool | None, zorder: int = 4
) -> None:
    """Segments of ``(xs, ys)`` coloured by ``modes`` (True = expert), and the end marked o (success) or x."""
    if len(xs) < 2:
        return
    segments = [[(xs[i], ys[i]), (xs[i + 1], ys[i + 1])] for i in range(len(xs) - 1)]
    colors = [EXPERT if modes[min(i, len(modes) - 1)] else ROBOT for i in range(len(segments))]
    ax.add_collection(LineCollection(segments, colors=colors, linewidths=1.2, alpha=0.8, zorder=zorder))
    if success is not None:
        ax.plot(
            xs[-1],
            ys[-1],
            "o" if success else "x",
            color="tab:green" if success else "tab:red",
            ms=5,
            zorder=zorder + 1,
        )
