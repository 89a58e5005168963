"""One robosuite ``NutAssemblyRound`` simulation with a UR5e, stepped with the paper's 6-D action.

robosuite / MuJoCo are imported when a :class:`RingSim` is built (here, and by the fast step it uses,
:mod:`dpiil_rl.envs.ring_fast_step`), so the 2D task never loads them. It runs in the main process or inside a
worker process (:mod:`dpiil_rl.envs.ring_workers`) and speaks numpy only.

The 6-D action ``[dx, dy, dz, rot_y, rot_z, gripper]`` in [-1, 1] maps to robosuite's 7-D OSC_POSE
+ gripper action with ``rot_x`` from a small proportional hold that keeps the gripper vertical (not
part of the policy's action). robosuite's own episode end is disabled (``ignore_done``): the horizon
is enforced by the TorchRL env. With ``fast_step`` (the default) a control step runs robosuite's controller law
and physics compiled (:class:`~dpiil_rl.envs.ring_fast_step.FastStep`), else robosuite's own ``env.step``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dpiil_rl.envs.ring_task import STATE_KEYS, RingGeometry
from dpiil_rl.utils.robosuite_import import quiet_robosuite

ROBOT_PREFIXES = ("robot0_", "gripper0_")


@dataclass(frozen=True)
class RingSimSettings:
    """How a simulation is built: the robosuite side of ``configs/env/ring.yaml``."""

    robot: str = "UR5e"  # robosuite robot name
    controller: str = "BASIC"  # composite controller: OSC_POSE arm + gripper
    control_freq: int = 20  # control steps per second
    roll_hold_gain: float = 2.0  # rot_x command per radian of tilt about world x (keeps the gripper vertical)
    settle_ring: bool = True  # put the ring on the table at reset (robosuite drops it from 6 cm)
    fast_step: bool = True  # step with FastStep (robosuite's law and physics, compiled) instead of env.step

    def __post_init__(self) -> None:
        for key in ("settle_ring", "fast_step"):
            value = getattr(self, key)
            if not isinstance(value, bool):
                raise ValueError(f"env.sim.{key} = {value!r}: expected true or false")


class RingSim:
    """A single simulation: ``reset(seed) -> frame``, ``step(action6) -> frame``.

    A frame is a dict of numpy arrays: ``observation`` [51] float32, ``eef_pos`` [3], ``success``,
    ``collision`` (robot touching a peg or the table, or the ring touching the square peg).
    """

    def __init__(self, geometry: RingGeometry, settings: RingSimSettings) -> None:
        with quiet_robosuite():
            import robosuite  # noqa: PLC0415  (lazy: only ring runs load MuJoCo)
            from robosuite.controllers import load_composite_controller_config  # noqa: PLC0415
        self.geometry = geometry
        self.settings = settings
        controller = load_composite_controller_config(controller=settings.controller, robot=settings.robot)
        self.env = robosuite.make(
            "NutAssemblyRound",
            robots=settings.robot,
            controller_configs=controller,
            has_renderer=False,
            has_offscreen_renderer=False,
            use_camera_obs=False,
            ignore_done=True,
            hard_reset=False,
            horizon=10 * geometry.max_steps,
            control_freq=settings.control_freq,
            reward_shaping=False,
        )
        self._setup_geoms()
        self._check_geometry()
        if settings.fast_step:
            from dpiil_rl.envs.ring_fast_step import FastStep  # noqa: PLC0415

            self._env_step = self._fast_env_step
            self._fast = FastStep(self.env)
            self._observed = [key for key, _ in STATE_KEYS] + ["robot0_eef_pos"]
        else:
            self._env_step = self.env.step
        self._obs: dict[str, Any] = {}
        self._renderers: dict[tuple[int, int], Any] = {}

    # ---------------------------------------------------------------------------- model facts
    def _setup_geoms(self) -> None:
        model = self.env.sim.model
        body_names = [model.body(i).name for i in range(model.nbody)]
        geom_body = np.asarray(model.geom_bodyid)
        robot_bodies = {i for i, n in enumerate(body_names) if n.startswith(ROBOT_PREFIXES)}
        peg_bodies = {model.body_name2id("peg1"), model.body_name2id("peg2")}
        table = model.body_name2id("table")
        ring = model.body_name2id("RoundNut_main")
        square_peg = model.body_name2id("peg1")
        self._robot_geom = np.isin(geom_body, list(robot_bodies))
        self._obstacle_geom = np.isin(geom_body, list(peg_bodies | {table}))
        self._ring_geom = geom_body == ring
        self._square_peg_geom = geom_body == square_peg
        self._ring_joint = self.env.nuts[1].joints[0]
        self._eef_site = self.env.robots[0].eef_site_id["right"]

    def _check_geometry(self) -> None:
        data, g = self.env.sim.data, self.geometry
        model = self.env.sim.model
        round_peg = data.body_xpos[model.body_name2id("peg2")]
        square_peg = data.body_xpos[model.body_name2id("peg1")]
        checks = {
            "round_peg_xy": (tuple(round_peg[:2]), g.round_peg_xy),
            "square_peg_xy": (tuple(square_peg[:2]), g.square_peg_xy),
            "table_z": (float(self.env.table_offset[2]), g.table_z),
        }
        for key, (actual, configured) in checks.items():
            if not np.allclose(actual, configured, atol=1e-3):
                raise ValueError(
                    f"ring geometry {key} = {configured}: the robosuite model has {actual} (fix configs/env/ring.yaml)"
                )

    # ---------------------------------------------------------------------------- episode
    def reset(self, seed: int) -> dict[str, np.ndarray]:
        """Start an episode whose ring placement and robot start noise are drawn from ``seed``."""
        self.env.rng.bit_generator.state = np.random.PCG64(int(seed)).state  # shared by robosuite's samplers
        self.env.reset()
        if self.settings.settle_ring:
            sim = self.env.sim
            qpos = np.array(sim.data.get_joint_qpos(self._ring_joint))
            qpos[2] = self.geometry.table_z + self.geometry.ring_half_height
            sim.data.set_joint_qpos(self._ring_joint, qpos)
            sim.data.set_joint_qvel(self._ring_joint, np.zeros(6))
            sim.forward()
        # robosuite leaves the ring-relative sensors at zero until the first step: compute them now
        self._obs = self.env._get_observations(force_update=True)
        return self._frame(success=False, collision=False)

    def step(self, action: np.ndarray) -> dict[str, np.ndarray]:
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(6), -1.0, 1.0)
        rot_x = np.clip(-self.settings.roll_hold_gain * self._roll_tilt(), -1.0, 1.0)
        full = np.array([a[0], a[1], a[2], rot_x, a[3], a[4], a[5]])
        self._obs, _, _, _ = self._env_step(full)
        return self._frame(success=bool(self.env._check_success()), collision=self._collision())

    def _fast_env_step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, dict[str, Any]]:
        """``env.step`` by the fast step, with only the observations a frame reads (robosuite's observables'
        current values: what ``_get_observations`` would put under these keys)."""
        reward, done, info = self._fast.advance(action)
        observables = self.env._observables
        return {key: observables[key].obs for key in self._observed}, reward, done, info

    # ---------------------------------------------------------------------------- pieces
    def _roll_tilt(self) -> float:
        """Tilt of the gripper axis about world x (radians, 0 = pointing straight down)."""
        rot = np.asarray(self.env.sim.data.site_xmat[self._eef_site]).reshape(3, 3)
        axis = rot[:, 2]  # the gripper's approach axis in the world frame
        # tilt of the approach axis in the world y-z plane; vertical (pointing down) is zero
        return float(np.arctan2(axis[1], -axis[2]))

    def _collision(self) -> bool:
        data = self.env.sim.data
        n = int(data.ncon)
        if n == 0:
            return False
        g1 = np.asarray(data.contact.geom1[:n])
        g2 = np.asarray(data.contact.geom2[:n])
        robot_hits = (self._robot_geom[g1] & self._obstacle_geom[g2]) | (self._robot_geom[g2] & self._obstacle_geom[g1])
        ring_hits = (self._ring_geom[g1] & self._square_peg_geom[g2]) | (
            self._ring_geom[g2] & self._square_peg_geom[g1]
        )
        return bool(robot_hits.any() or ring_hits.any())

    def _frame(self, success: bool, collision: bool) -> dict[str, np.ndarray]:
        obs = self._obs
        state = np.concatenate([np.asarray(obs[key], dtype=np.float32).reshape(size) for key, size in STATE_KEYS])
        return {
            "observation": state,
            "eef_pos": np.asarray(obs["robot0_eef_pos"], dtype=np.float32).reshape(3),
            "success": np.array(success),
            "collision": np.array(collision),
        }

    def render(self, width: int, height: int, camera: str) -> np.ndarray:
        """An RGB image ``[height, width, 3]`` uint8 of the scene from robosuite camera ``camera``.

        Needs an OpenGL context: a display (``MUJOCO_GL=glfw``, the default) or ``MUJOCO_GL=egl|osmesa``.
        """
        import mujoco  # noqa: PLC0415

        model, data = self.env.sim.model._model, self.env.sim.data._data
        key = (int(width), int(height))
        if key not in self._renderers:
            self._renderers[key] = mujoco.Renderer(model, height=key[1], width=key[0])
        renderer = self._renderers[key]
        renderer.update_scene(data, camera=camera)
        return renderer.render()

    def close(self) -> None:
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers = {}
        self.env.close()
