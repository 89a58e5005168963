"""The errors a person can act on, shared by every layer: each message names what failed and how to fix it.

They live here, at the bottom of the layers, so that the entry points can show them as one line without
importing the experts, robots or motion-capture packages that raise them.
"""

from __future__ import annotations


class SessionEnded(RuntimeError):
    """The person ended the session (closed the window): stop, keep everything collected so far."""


class DeviceUnavailable(RuntimeError):
    """An input device (display, mouse, pad) cannot be opened; the message says how to fix it."""


class MocapUnavailable(RuntimeError):
    """A motion-capture source cannot be used (no answer, bad socket, not connected); the message says how to fix it."""


class RobotUnavailable(RuntimeError):
    """The robot (or its simulation) cannot be reached; the message says which and how to fix it."""
