"""Ring threading with a UR5e in robosuite (paper section V-B) as a batched TorchRL environment.

State: the 51-D UR5e + ring state (:data:`~dpiil_rl.envs.ring_task.STATE_KEYS`). Action: the paper's
6-D ``[dx, dy, dz, rot_y, rot_z, gripper]`` in [-1, 1]. An episode succeeds when robosuite's
``_check_success`` fires (ring centre within 3 cm of the round peg's axis and low, gripper clear of
the ring's centre) and fails after ``max_steps``. Contacts of the robot with a peg or the table, or
of the ring with the square peg, are flagged per step (``collision``) and counted per episode; they
do not end the episode. Each step also writes the ``stage`` the state is in (:data:`RING_STAGES`:
reach, grasped, lifted, at_peg, threaded), so an episode's record says how far it got.

The simulations run in this process or in ``workers`` processes (:class:`RingSimBatch`); robosuite
is imported only when the env is built.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.envs.ring_task import RING_STAGES, STATE_DIM, STATE_SLICES, RingGeometry, ring_stage
from dpiil_rl.envs.ring_workers import RingSimBatch
from dpiil_rl.envs.task_specs import reset_frame, reset_mask, set_task_specs

WORKSPACE_LOW = (-0.6, -0.6, 0.6)  # bounds of the end-effector position spec (m); the robot cannot leave them
WORKSPACE_HIGH = (0.6, 0.6, 1.4)


class RingEnv(EnvBase):
    """Batched ring-threading env (``batch_size=[num_envs]``) with partial resets."""

    # a class constant over EnvBase's read-only property, as TorchRL's own envs declare it
    batch_locked = True  # pyright: ignore[reportAssignmentType]
    position_key = "eef_pos"  # the position part of the state used for the speed f_v
    observation_parts = STATE_SLICES  # the named parts of the 51-D state (what a module may be told to ignore)

    def __init__(
        self,
        geometry: RingGeometry,
        sim_settings: Any,
        num_envs: int = 1,
        workers: int = 0,
        device: str | torch.device = "cpu",
        seed: int | None = None,
        expert: Mapping[str, Any] | None = None,
    ) -> None:
        if int(num_envs) < 1:
            raise ValueError(f"num_envs = {num_envs}: expected at least one environment")
        super().__init__(device=device, batch_size=torch.Size([int(num_envs)]))
        n = int(num_envs)
        self.geometry = geometry
        self.expert_config = dict(expert or {})
        self._low = torch.tensor(geometry.observation_low, dtype=torch.float32)
        self._high = torch.tensor(geometry.observation_high, dtype=torch.float32)
        if self._low.numel() != STATE_DIM:
            raise ValueError(
                f"observation bounds have {self._low.numel()} values: expected {STATE_DIM} (configs/env/ring.yaml)"
            )
        set_task_specs(
            self,
            {
                "observation": (self._low, self._high),
                "eef_pos": (torch.tensor(WORKSPACE_LOW), torch.tensor(WORKSPACE_HIGH)),
            },
            geometry.max_steps,
            ("success", "collision"),
            action=(-torch.ones(6), torch.ones(6)),
            stages=RING_STAGES,
        )
        self.rng = torch.Generator().manual_seed(0 if seed is None else int(seed))
        self._steps = torch.zeros(n, 1, dtype=torch.int64)
        self._observation = torch.zeros(n, STATE_DIM)
        self._eef = torch.zeros(n, 3)
        self.sims = RingSimBatch(geometry, sim_settings, n, workers)

    # ----------------------------------------------------------------------------- EnvBase API
    def _set_seed(self, seed: int | None) -> None:
        self.rng.manual_seed(0 if seed is None else int(seed))

    def skip_starts(self, starts: int) -> None:
        """Draw and discard the seeds of ``starts`` episode starts. A batch of ``k`` envs built with the same
        seed then begins on the start states ``starts .. starts + k − 1`` of a batch of ``starts + k``: how a
        long evaluation runs its episodes a few at a time on exactly the start states of all side by side."""
        if int(starts) < 0:
            raise ValueError(f"starts = {starts}: expected a number of start states to skip >= 0")
        torch.randint(0, 2**31 - 1, (int(starts),), generator=self.rng)

    def _reset(self, tensordict: TensorDictBase | None, **kwargs: Any) -> TensorDictBase:
        indices = reset_mask(self, tensordict).cpu().nonzero().reshape(-1).tolist()
        seeds = torch.randint(0, 2**31 - 1, (len(indices),), generator=self.rng).tolist()
        if indices:
            frames = self.sims.reset(indices, seeds)
            self._observation[indices] = self._clip(torch.from_numpy(frames["observation"]))
            self._eef[indices] = torch.from_numpy(frames["eef_pos"])
            self._steps[indices] = 0
        return reset_frame(self, {"observation": self._observation, "eef_pos": self._eef}, self._steps)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action").detach().cpu().clamp(-1.0, 1.0).numpy().astype(np.float64)
        frames = self.sims.step(action)
        self._observation = self._clip(torch.from_numpy(frames["observation"]))
        self._eef = torch.from_numpy(frames["eef_pos"]).float()
        self._steps = self._steps + 1
        success = torch.from_numpy(frames["success"]).reshape(-1, 1)
        collision = torch.from_numpy(frames["collision"]).reshape(-1, 1)
        truncated = (self._steps >= self.geometry.max_steps) & ~success
        return TensorDict(
            {
                "observation": self._observation.clone(),
                "eef_pos": self._eef.clone(),
                "step_count": self._steps.clone(),
                "success": success,
                "collision": collision,
                "stage": ring_stage(self._observation, success, self.geometry).reshape(-1, 1),
                "reward": success.float(),
                "done": success | truncated,
                "terminated": success.clone(),
                "truncated": truncated,
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    def _clip(self, observation: torch.Tensor) -> torch.Tensor:
        return torch.maximum(torch.minimum(observation.float(), self._high), self._low)

    def render_frame(
        self, index: int = 0, width: int = 640, height: int = 480, camera: str = "frontview"
    ) -> np.ndarray:
        """RGB image ``[height, width, 3]`` uint8 of env ``index`` from a robosuite camera (``frontview``,
        ``birdview``, ``agentview``, ``sideview``): the on-screen view of a person teleoperating the robot."""
        if not 0 <= int(index) < int(self.batch_size[0]):
            raise IndexError(f"render_frame(index={index}): expected 0 <= index < {int(self.batch_size[0])}")
        return self.sims.render(int(index), int(width), int(height), str(camera))

    def plot_paths(self, paths: Any, success: dict[int, bool], path: Any, title: str = "") -> Any:
        """Capability used by the run's plot hook: end-effector paths in top and side views."""
        from dpiil_rl.envs.ring_paths import plot_ring_paths  # noqa: PLC0415

        return plot_ring_paths(paths, success, self.geometry, path, title)

    def close(self, *, raise_if_closed: bool = True) -> None:
        sims = self.__dict__.get("sims")
        if sims is not None:
            sims.close()
        super().close(raise_if_closed=raise_if_closed)


def build_ring_env(
    num_envs: int = 1,
    seed: int | None = None,
    device: str = "cpu",
    workers: int = 0,
    sim: Mapping[str, Any] | None = None,
    expert: Mapping[str, Any] | None = None,
    **geometry: Any,
) -> RingEnv:
    """Hydra target of ``configs/env/ring.yaml``: validates the task and builds the batched env."""
    from dpiil_rl.envs.ring_sim import RingSimSettings  # noqa: PLC0415  (no robosuite import at module level)

    geometry.pop("name", None)
    sim_spec = dict(sim or {})
    unknown = sorted(set(sim_spec) - set(RingSimSettings.__dataclass_fields__))
    if unknown:
        raise ValueError(
            f"env.sim keys {unknown}: unknown (expected some of {sorted(RingSimSettings.__dataclass_fields__)})"
        )
    return RingEnv(
        RingGeometry.from_mapping(geometry),
        RingSimSettings(**sim_spec),
        num_envs=num_envs,
        workers=workers,
        device=device,
        seed=seed,
        expert=expert,
    )
