"""Write a teleoperation session a replay can drive: a hand trajectory and its button presses.

``make teleop ENV=shaft EXPERT=ur5e_sim`` needs a person's recorded session. Without a capture volume
here, :func:`record_scripted_session` makes one from the task's scripted careful person: it runs the
scripted expert in the simulation from the nominal start (no start noise), and writes its TCP path as
the hand's path (robot base frame, 100 Hz, held still for ``lead_in`` seconds first) plus a button file:
A (sync) at ``lead_in / 3``, B (follow) held from ``2 lead_in / 3`` to the end. Replayed with the sync
offset, the robot retraces that path from wherever an episode starts. A session recorded from Motive
(:func:`dpiil_rl.mocap.trajectory.record_trajectory`) plus its buttons replaces both files.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import torch
from torchrl.envs import EnvBase

from dpiil_rl.experts.scripted import build_scripted_policy
from dpiil_rl.mocap.trajectory import HandTrajectory, save_trajectory

if TYPE_CHECKING:
    from dpiil_rl.envs.shaft import ShaftEnv

RATE_HZ = 100.0  # samples per second of the written hand trajectory


def scripted_tcp_path(env: EnvBase, seed: int = 0) -> tuple[np.ndarray, bool]:
    """TCP positions ``[T, 3]`` of one scripted episode on a batch-1 env (start included), and its success."""
    policy = build_scripted_policy(env)
    rng = torch.Generator().manual_seed(int(seed))
    td = env.reset()
    path = [td.get(env.position_key)[0].double().numpy().copy()]
    success = False
    for _ in range(int(cast("ShaftEnv", env).geometry.max_steps)):  # the robot tasks' env (shaft, ring_real)
        td.set("action", policy(td.get("observation"), rng))
        td = env.step(td).get("next")
        path.append(td.get(env.position_key)[0].double().numpy().copy())
        if bool(td.get("done").any()):
            success = bool(td.get("success").any())
            break
    return np.stack(path), success


def write_session(
    hand_path: Path,
    buttons_path: Path,
    tcp_path: np.ndarray,
    control_period: float,
    quaternion: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0),
    lead_in: float = 0.6,
) -> None:
    """Write ``tcp_path`` (control-rate samples) as a 100 Hz hand trajectory after ``lead_in`` s of stillness,
    and the button file (A tap, then B held to the end)."""
    if lead_in <= 0 or control_period <= 0 or len(tcp_path) < 2:
        raise ValueError(
            f"lead_in = {lead_in}, control_period = {control_period}, path of {len(tcp_path)} samples: "
            "expected positive times and at least 2 samples"
        )
    t_path = lead_in + control_period * np.arange(len(tcp_path))
    t = np.arange(0.0, t_path[-1] + 1.0, 1.0 / RATE_HZ)  # a second of stillness at the end too
    position = np.stack([np.interp(t, t_path, tcp_path[:, i]) for i in range(3)], axis=1)  # flat before/after
    quat = np.tile(np.asarray(quaternion, dtype=np.float64), (len(t), 1))
    save_trajectory(hand_path, HandTrajectory(t=t, position=position, quaternion=quat))
    rows = [
        (0.0, 0, 0, 0),
        (lead_in / 3, 1, 0, 0),
        (lead_in / 3 + 0.1, 0, 0, 0),
        (2 * lead_in / 3, 0, 1, 0),
        (float(t[-1]), 0, 1, 0),
    ]
    buttons_path.parent.mkdir(parents=True, exist_ok=True)
    with buttons_path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t", "a", "b", "y"])
        writer.writerows([(f"{r[0]:.3f}", *r[1:]) for r in rows])


def record_scripted_session(env: EnvBase, out_dir: Path, name: str, seed: int = 0) -> tuple[Path, Path, bool]:
    """Run the scripted expert once on ``env`` (batch 1, start noise off) and write ``<name>_hand.csv`` and
    ``<name>_buttons.csv`` to ``out_dir``. Returns both paths and whether the scripted episode succeeded."""
    tcp_path, success = scripted_tcp_path(env, seed)
    period = float(cast("ShaftEnv", env).robots[0].control_period)
    hand, buttons = Path(out_dir) / f"{name}_hand.csv", Path(out_dir) / f"{name}_buttons.csv"
    write_session(hand, buttons, tcp_path, period)
    return hand, buttons, success
