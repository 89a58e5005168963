"""The paper's real-robot tasks (section VI) as a batched TorchRL environment over robot backends.

The env talks only to :class:`~dpiil_rl.robots.interface.RobotBackend` objects, one per env of the
batch, built from the config's ``robot`` block (``_target_``): the simulated UR5e by default
(``configs/robot/sim.yaml``), a real arm by choosing another backend. Its own config gives the task
(:class:`~dpiil_rl.envs.shaft_task.ShaftTask`): shaft reaching (``env=shaft``) or ring threading on
the real-robot setting (``env=ring_real``).

State (12-D, ``observation``): 6 joint angles, TCP xyz, target xyz (base frame). Action (3-D): TCP
velocity in [-1, 1] per axis, times ``max_speed`` (m/s), held for one control period with the
orientation held. An episode succeeds when the controlled point (TCP + ``tool_offset``) enters the goal
region; it fails on contact with the scene (``collision``; ends the episode when
``collision_ends_episode``, else contacts are counted), on the TCP leaving the workspace
(``out_of_bounds``) or after ``max_steps`` steps. Starts are the nominal TCP start plus U(-noise, noise)
per axis, drawn from the env's seeded generator.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.envs.shaft_task import STATE_DIM, STATE_SLICES, ShaftTask
from dpiil_rl.envs.task_specs import reset_frame, reset_mask, set_task_specs
from dpiil_rl.robots.interface import RobotBackend, RobotState


class ShaftEnv(EnvBase):
    """Batched arm-reaching env (``batch_size=[len(robots)]``) with partial resets."""

    # a class constant over EnvBase's read-only property, as TorchRL's own envs declare it
    batch_locked = True  # pyright: ignore[reportAssignmentType]
    position_key = "tcp_pos"  # the position part of the state used for the speed f_v: the TCP xyz
    observation_parts = STATE_SLICES  # the named parts of the 12-D state (what a module may be told to ignore)

    def __init__(
        self,
        geometry: ShaftTask,
        robots: Sequence[RobotBackend],
        device: str | torch.device = "cpu",
        seed: int | None = None,
        expert: Mapping[str, Any] | None = None,
    ) -> None:
        n = len(robots)
        if n < 1:
            raise ValueError("num_envs = 0: expected at least one environment (one robot backend each)")
        super().__init__(device=device, batch_size=torch.Size([n]))
        self.geometry = geometry
        self.expert_config = dict(expert or {})
        self.robots = list(robots)
        self._low, self._high = geometry.observation_bounds()
        tcp = STATE_SLICES["tcp"]
        set_task_specs(
            self,
            {"observation": (self._low, self._high), "tcp_pos": (self._low[tcp], self._high[tcp])},
            geometry.max_steps,
            ("success", "collision", "out_of_bounds"),
            action=(-torch.ones(3), torch.ones(3)),
        )
        self.rng = torch.Generator().manual_seed(0 if seed is None else int(seed))
        self._observation = torch.zeros(n, STATE_DIM)
        self._steps = torch.zeros(n, 1, dtype=torch.int64)
        self._target = torch.tensor(geometry.target_position, dtype=torch.float32)
        self._goal = geometry.goal_position
        self._tool_offset = np.array(geometry.tool_offset)
        self._workspace = (np.array(geometry.workspace_low), np.array(geometry.workspace_high))
        for robot in self.robots:
            robot.connect()

    # ----------------------------------------------------------------------------- EnvBase API
    def _set_seed(self, seed: int | None) -> None:
        self.rng.manual_seed(0 if seed is None else int(seed))

    def _reset(self, tensordict: TensorDictBase | None, **kwargs: Any) -> TensorDictBase:
        indices = reset_mask(self, tensordict).cpu().nonzero().reshape(-1).tolist()
        g = self.geometry
        noise = (torch.rand(len(indices), 3, generator=self.rng, dtype=torch.float64) * 2 - 1) * g.start_noise
        starts = np.asarray(g.start_position) + noise.numpy()
        for k, i in enumerate(indices):
            self.robots[i].move_to(starts[k], g.reset_speed)
            self._observation[i] = self._state(self.robots[i].read_state())
            self._steps[i] = 0
        return reset_frame(
            self, {"observation": self._observation, "tcp_pos": self._observation[:, STATE_SLICES["tcp"]]}, self._steps
        )

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        g = self.geometry
        action = tensordict.get("action").detach().cpu().double().clamp(-1.0, 1.0).numpy() * g.max_speed
        n = self.batch_size[0]
        contact = np.zeros(n, dtype=bool)
        tcp = np.zeros((n, 3))
        for i, robot in enumerate(self.robots):
            robot.command_tcp_velocity(action[i], g.acceleration)
            state = robot.read_state()
            tcp[i] = state.tcp_position
            contact[i] = bool(state.collision or state.protective_stop)
            self._observation[i] = self._state(state)
        self._steps = self._steps + 1
        out = ~np.all((tcp >= self._workspace[0]) & (tcp <= self._workspace[1]), axis=-1)
        error = tcp + self._tool_offset - self._goal
        lateral = np.sqrt((error[:, :2] ** 2).sum(-1))
        in_goal = (lateral <= g.goal_radius) & (error[:, 2] >= g.goal_depth[0]) & (error[:, 2] <= g.goal_depth[1])
        success = torch.from_numpy(in_goal & ~contact & ~out).unsqueeze(-1)
        failed = out | (contact & g.collision_ends_episode)
        terminated = success | torch.from_numpy(failed).unsqueeze(-1)
        truncated = (self._steps >= g.max_steps) & ~terminated
        return self._frame(
            {
                "success": success,
                "collision": torch.from_numpy(contact).unsqueeze(-1),
                "out_of_bounds": torch.from_numpy(out).unsqueeze(-1),
                "reward": success.float(),
                "done": terminated | truncated,
                "terminated": terminated,
                "truncated": truncated,
            }
        )

    # ----------------------------------------------------------------------------- helpers
    def _state(self, state: RobotState) -> torch.Tensor:
        """The clipped 12-D state of one robot reading."""
        raw = torch.cat(
            [
                torch.as_tensor(np.asarray(state.joint_positions, dtype=np.float32)),
                torch.as_tensor(np.asarray(state.tcp_position, dtype=np.float32)),
                self._target,
            ]
        )
        return torch.maximum(torch.minimum(raw, self._high), self._low)

    def _frame(self, flags: dict[str, torch.Tensor]) -> TensorDictBase:
        return TensorDict(
            {
                "observation": self._observation.clone(),
                "tcp_pos": self._observation[:, STATE_SLICES["tcp"]].clone(),
                "step_count": self._steps.clone(),
                **flags,
            },
            batch_size=self.batch_size,
            device=self.device,
        )

    def plot_paths(self, paths: Any, success: dict[int, bool], path: Any, title: str = "") -> Any:
        """Capability used by the run's plot hook: TCP paths in top and side views, with the scene."""
        from dpiil_rl.envs.shaft_paths import plot_shaft_paths  # noqa: PLC0415

        return plot_shaft_paths(paths, success, self.geometry, path, title)

    def close(self, *, raise_if_closed: bool = True) -> None:
        for robot in self.__dict__.get("robots", []):
            robot.disconnect()
        super().close(raise_if_closed=raise_if_closed)


def build_shaft_env(
    num_envs: int = 1,
    seed: int | None = None,
    device: str = "cpu",
    robot: Mapping[str, Any] | None = None,
    expert: Mapping[str, Any] | None = None,
    **task: Any,
) -> ShaftEnv:
    """Hydra target of ``configs/env/shaft.yaml`` and ``ring_real.yaml``: validates the task, builds one robot
    backend per env from the ``robot`` block (its ``_target_``) and the batched env."""
    from dpiil_rl.utils.config import instantiate_checked  # noqa: PLC0415

    task.pop("name", None)
    task.pop("defaults", None)  # present when the file is loaded without Hydra's composition
    geometry = ShaftTask.from_mapping(task)
    if int(num_envs) < 1:
        raise ValueError(f"num_envs = {num_envs}: expected at least one environment")
    spec = dict(robot or {})
    if "_target_" not in spec:
        raise ValueError(
            f"env.robot = {spec!r}: expected a robot backend with a '_target_' (compose the config with Hydra: "
            "the env's defaults list adds configs/robot/sim.yaml, or robot@env.robot=<backend>)"
        )
    robots = [instantiate_checked(spec, _convert_="all") for _ in range(int(num_envs))]
    return ShaftEnv(geometry, robots, device=device, seed=seed, expert=expert)
