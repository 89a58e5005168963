"""The lifecycle every device-like object shares: expert sources, robot backends, motion-capture streams."""

from __future__ import annotations

from types import TracebackType
from typing import Self


class Connectable:
    """``connect`` / ``disconnect`` (idempotent; subclasses open and release their device, then call super),
    ``is_connected``, and use as a context manager."""

    _connected: bool = False

    def connect(self) -> None:
        """Open the device (window, joystick, network stream, robot). Idempotent."""
        self._connected = True

    def disconnect(self) -> None:
        """Release the device. Idempotent."""
        self._connected = False

    @property
    def is_connected(self) -> bool:
        return self._connected

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.disconnect()
