"""``expert=ur5e_teleop`` / ``ur5e_sim``: the paper's real-robot teleoperation (section VI, Fig. 5).

A person holds a tracked object (the ring) in a motion-capture volume and a game pad. **A** syncs: the
offset between the hand and the robot's TCP is captured, so control starts without a jump. **B** held:
the TCP follows the hand (its target is hand + offset; the command is a velocity toward it). Releasing
B stops the robot; press A again (re-sync) before moving it. **Y** held lets the learned policy run.
The protocol is the shared :class:`~dpiil_rl.experts.handover.HandoverMachine` table.

Safety on the input side (the robot side, workspace box / speed / acceleration, is
:class:`~dpiil_rl.robots.safety.SafeRobot` inside the env):
- deadman: B released = stop (the hand-over table);
- watchdog: a hand pose older than ``limits.watchdog_timeout`` (or tracking lost), or a lost pad, stops
  the robot within the same control period and needs a re-sync;
- tracking error: a target further than ``limits.max_tracking_error`` from the TCP (the hand ran away
  from the robot) stops it and needs a re-sync;
- every event goes to the run's ``safety_events.jsonl`` (:class:`~dpiil_rl.robots.safety.SafetyLog`).

The source works on any env whose action is a 3-D TCP velocity in [-1, 1] times ``env.geometry.max_speed``
and whose tensordict carries the TCP (``env.position_key``): ``env=shaft`` and ``env=ring_real``, on the
simulated arm or a real UR5e. With ``replay_per_episode`` the hand (``ReplayMocap``) and the buttons
(:class:`~dpiil_rl.experts.replay_pad.ReplayPadReader`) replay their recordings from the start of every
episode on the episode's own clock (simulated time), so a recorded session drives the robot hands-free.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase

from dpiil_rl.experts.base import ExpertSource, check_person_env
from dpiil_rl.experts.device_teleop import PadReader, PadState, PygameJoystickReader, button_events
from dpiil_rl.experts.handover import Handover, HandoverEvent, HandoverMachine
from dpiil_rl.mocap.base import MocapSource
from dpiil_rl.robots.safety_limits import SafetyLimits
from dpiil_rl.robots.safety_log import SafetyEventKind, SafetyLog
from dpiil_rl.utils.config import build_component
from dpiil_rl.utils.pacing import RealTimePacer

if TYPE_CHECKING:
    from dpiil_rl.envs.shaft import ShaftEnv

log = logging.getLogger(__name__)


class UR5eTeleopExpert(ExpertSource):
    labels_every_step = False  # the person's commands mean something only while they follow

    def __init__(
        self,
        env: EnvBase,
        seed: int = 0,
        mocap: Any = None,
        pad: Any = None,
        limits: Any = None,
        gain: float = 4.0,
        rigid_body_id: int | None = None,
        safety_log: str | None = None,
        control_hz: float = 20.0,
        realtime: bool = True,
        replay_per_episode: bool = False,
    ) -> None:
        super().__init__()
        del seed
        check_person_env(env, "ur5e_teleop", 3, "a 3-D TCP velocity (env=shaft or env=ring_real)")
        if not gain > 0 or not control_hz > 0:
            raise ValueError(f"expert.gain = {gain}, control_hz = {control_hz}: expected positive values")
        self.max_speed = float(cast("ShaftEnv", env).geometry.max_speed)  # m/s at action 1 (a 3-D TCP task's env)
        self.position_key = str(getattr(env, "position_key", "tcp_pos"))
        self.limits = limits if isinstance(limits, SafetyLimits) else SafetyLimits(**dict(limits or {}))
        self.mocap: MocapSource = build_component(mocap)
        self.pad: PadReader = build_component(pad, f"{PygameJoystickReader.__module__}.{PygameJoystickReader.__name__}")
        self.gain = float(gain)
        self.rigid_body_id = rigid_body_id
        self.period = 1.0 / float(control_hz)
        self.realtime = bool(realtime)
        self.pacer = RealTimePacer(self.period)
        self.replay_per_episode = bool(replay_per_episode)
        self.episode_steps = 0
        if self.replay_per_episode:  # both recordings run on simulated time from the episode's start
            self.mocap.clock = self.episode_time  # type: ignore[attr-defined]
            self.pad.clock = self.episode_time  # type: ignore[attr-defined]
        self.safety_log = SafetyLog(Path(safety_log)) if safety_log else SafetyLog()
        self.handover = HandoverMachine()
        self.labelled = torch.zeros(1, dtype=torch.bool)
        self.offset = np.zeros(3)
        self._previous = PadState()
        self._hand: np.ndarray | None = None

    # ---------------------------------------------------------------------------- lifecycle
    def connect(self) -> None:
        if self.is_connected:
            return
        self.mocap.connect()
        self.pad.open()
        super().connect()

    def disconnect(self) -> None:
        if self.is_connected:
            self.pad.close()
            self.mocap.disconnect()
            self.safety_log.close()
        super().disconnect()

    def episode_time(self) -> float:
        """Seconds of the current episode on the control clock (steps x period)."""
        return self.episode_steps * self.period

    @property
    def policy_requested(self) -> bool:
        """Y held: the person lets the learned policy run."""
        return self.handover.state is Handover.POLICY

    # ---------------------------------------------------------------------------- per step
    def observe(self, tensordict: TensorDictBase) -> None:
        """Every step, whoever drives: read the inputs (so B and Y work while the robot drives), keep time."""
        self._read_inputs(self._tcp(tensordict))
        self.episode_steps += 1
        if self.realtime:
            self.pacer.wait()

    def get_action(self, tensordict: TensorDictBase) -> torch.Tensor:
        tcp = self._tcp(tensordict)
        hand = self._read_inputs(tcp)
        action = torch.zeros(1, 3)
        if self.handover.moving and hand is not None:
            target = hand + self.offset
            error = target - tcp
            if float(np.linalg.norm(error)) > self.limits.max_tracking_error:
                self._stop(
                    SafetyEventKind.TRACKING_ERROR,
                    "the robot fell behind the hand: press A to re-sync, move slower",
                    error_m=float(np.linalg.norm(error)),
                )
            else:
                velocity = self.gain * error
                speed = float(np.linalg.norm(velocity))
                cap = min(self.limits.max_speed, self.max_speed)
                if speed > cap:
                    velocity *= cap / speed
                action[0] = torch.as_tensor(np.clip(velocity / self.max_speed, -1.0, 1.0), dtype=torch.float32)
        self.labelled = torch.tensor([self.handover.moving])
        return action

    def wants_control(self, tensordict: TensorDictBase, in_control: torch.Tensor) -> torch.Tensor:
        """HG-DAgger: the person takes over by following (A, then B held) and hands back by releasing B."""
        self._read_inputs(self._tcp(tensordict))
        return torch.tensor([[self.handover.moving]])

    def reset(self, mask: torch.Tensor) -> None:
        """A new episode: the robot starts elsewhere, so the person re-syncs; replays restart."""
        if not bool(mask.reshape(-1)[0]):
            return
        if self.handover.state is not Handover.STOPPED:
            self.handover.fire(HandoverEvent.FOLLOW_END if self.handover.moving else HandoverEvent.DEVICE_LOST)
        self.episode_steps = 0
        self._previous = PadState()
        if self.replay_per_episode and self.is_connected:
            self.mocap.disconnect()
            self.mocap.connect()
            self.pad.open()

    # ---------------------------------------------------------------------------- internals
    def _tcp(self, tensordict: TensorDictBase) -> np.ndarray:
        return tensordict.get(self.position_key).reshape(-1, 3)[0].detach().cpu().double().numpy()

    def _read_inputs(self, tcp: np.ndarray) -> np.ndarray | None:
        """Apply the pad's events and the watchdog; the hand position (robot frame) or None when stale."""
        pad = self.pad.read()
        if not pad.connected:
            if self.handover.state is not Handover.STOPPED or self._previous.connected:
                self._stop(SafetyEventKind.DEVICE_LOST, f"{self.pad.name} lost: plug it back in, then press A")
            self._previous = PadState(connected=False)
            return None
        now = self.episode_time() if self.replay_per_episode else None  # a replay ages on the episode's clock
        pose = self.mocap.fresh(self.limits.watchdog_timeout, self.rigid_body_id, now)
        hand = None if pose is None else np.asarray(pose.position, dtype=np.float64)
        for event in button_events(self._previous, pad):
            if event is HandoverEvent.SYNC:
                if hand is None:
                    self.safety_log.record(SafetyEventKind.WATCHDOG, reason="sync refused: no fresh hand pose")
                    continue
                self.offset = tcp - hand
            if event is HandoverEvent.FOLLOW_END and self.handover.moving:
                self.safety_log.record(SafetyEventKind.DEADMAN, reason="B released: the robot stops")
            self.handover.fire(event)
        self._previous = pad
        if hand is None and self.handover.moving:
            self._stop(
                SafetyEventKind.WATCHDOG,
                f"hand pose from {self.mocap.name} older than "
                f"{self.limits.watchdog_timeout * 1000:.0f} ms or not tracked: check the capture, then press A",
            )
        self._hand = hand
        return hand

    def _stop(self, kind: SafetyEventKind, message: str, **details: Any) -> None:
        self.safety_log.record(kind, reason=message, **details)
        self.handover.fire(HandoverEvent.DEVICE_LOST)
