"""Hydra instantiation that surfaces the library's own validation errors unwrapped."""

from __future__ import annotations

from typing import Any

from hydra.errors import InstantiationException
from hydra.utils import get_object, instantiate

from dpiil_rl.utils.errors import DeviceUnavailable, MocapUnavailable, RobotUnavailable

#: errors that name a user's bad input or missing hardware: shown as themselves, not as Hydra's wrapper
USER_ERRORS = (ValueError, FileNotFoundError, RobotUnavailable, MocapUnavailable, DeviceUnavailable)


def instantiate_checked(config: Any, *args: Any, **kwargs: Any) -> Any:
    """``hydra.utils.instantiate``, but a :data:`USER_ERRORS` error raised by the target (bad input, an
    unreachable device, named by the target's message) propagates as itself instead of inside Hydra's wrapper."""
    try:
        return instantiate(config, *args, **kwargs)
    except InstantiationException as err:
        cause = err.__cause__
        if isinstance(cause, USER_ERRORS):
            raise cause from None
        raise


def build_component(spec: Any, default_target: str | None = None, **kwargs: Any) -> Any:
    """``spec`` itself when it is already built (Hydra instantiates nested ``_target_`` blocks), else the
    object its config describes (``_target_``, or ``default_target`` when it has none), with ``kwargs``."""
    if spec is not None and not hasattr(spec, "keys"):
        return spec
    config = dict(spec or {})
    target = config.pop("_target_", default_target)
    if target is None:
        raise ValueError(f"component config {config!r}: expected a '_target_' naming its class")
    return get_object(target)(**config, **kwargs)
