"""The person's side of a hand-over, as an explicit state machine (paper Fig. 5(c)).

Every human expert source (mouse, gamepad, the UR5e teleoperation) drives the robot through the same
protocol: *sync* (gamepad A, or pressing on the agent with the mouse) aligns the person's device with
the robot so control starts without a jump; *follow* (B held, or the mouse button held) makes the
robot follow the device; releasing stops the robot, which then waits for the next sync; *policy* (Y
held) lets the learned policy run while the person watches. A device that is lost stops the robot.

The table is the whole protocol: an event not listed for a state leaves the state unchanged.
"""

from __future__ import annotations

import enum


class Handover(enum.Enum):
    STOPPED = "stopped"  # expert side, not synchronised: the robot holds still
    SYNCED = "synced"  # device aligned with the robot, not yet following
    FOLLOWING = "following"  # the robot follows the device
    POLICY = "policy"  # the person lets the learned policy run (verification only)


class HandoverEvent(enum.Enum):
    SYNC = "sync"  # A pressed / mouse pressed on the agent
    FOLLOW_START = "follow_start"  # B pressed (the mouse press also starts following)
    FOLLOW_END = "follow_end"  # B / mouse button released
    POLICY_START = "policy_start"  # Y pressed
    POLICY_END = "policy_end"  # Y released
    DEVICE_LOST = "device_lost"  # pad unplugged, window lost focus, stream stale


TRANSITIONS: dict[tuple[Handover, HandoverEvent], Handover] = {
    (Handover.STOPPED, HandoverEvent.SYNC): Handover.SYNCED,
    (Handover.SYNCED, HandoverEvent.SYNC): Handover.SYNCED,
    (Handover.SYNCED, HandoverEvent.FOLLOW_START): Handover.FOLLOWING,
    (Handover.FOLLOWING, HandoverEvent.FOLLOW_END): Handover.STOPPED,  # released: stop, re-sync before moving again
    (Handover.STOPPED, HandoverEvent.POLICY_START): Handover.POLICY,
    (Handover.SYNCED, HandoverEvent.POLICY_START): Handover.POLICY,
    (Handover.POLICY, HandoverEvent.POLICY_END): Handover.STOPPED,
    (Handover.STOPPED, HandoverEvent.DEVICE_LOST): Handover.STOPPED,
    (Handover.SYNCED, HandoverEvent.DEVICE_LOST): Handover.STOPPED,
    (Handover.FOLLOWING, HandoverEvent.DEVICE_LOST): Handover.STOPPED,
    (Handover.POLICY, HandoverEvent.DEVICE_LOST): Handover.STOPPED,
}


class HandoverMachine:
    """Current :class:`Handover` state; :meth:`fire` applies one event and returns the new state."""

    def __init__(self, state: Handover = Handover.STOPPED) -> None:
        self.state = state
        self.history: list[tuple[Handover, HandoverEvent, Handover]] = []

    def fire(self, event: HandoverEvent) -> Handover:
        new = TRANSITIONS.get((self.state, event), self.state)
        self.history.append((self.state, event, new))
        self.state = new
        return new

    @property
    def moving(self) -> bool:
        """True while the person's device commands the robot."""
        return self.state is Handover.FOLLOWING
