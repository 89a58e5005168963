"""Hydra instantiation that surfaces the library's own validation errors unwrapped."""

from __future__ import annotations

from typing import Any

from hydra.errors import InstantiationException
from hydra.utils import instantiate


def instantiate_checked(config: Any, *args: Any, **kwargs: Any) -> Any:
    """``hydra.utils.instantiate``, but a ``ValueError`` raised by the target (bad input, named by
    the target's message) propagates as itself instead of inside Hydra's wrapper."""
    try:
        return instantiate(config, *args, **kwargs)
    except InstantiationException as err:
        cause = err.__cause__
        if isinstance(cause, (ValueError, FileNotFoundError)):
            raise cause from None
        raise
