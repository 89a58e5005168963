"""Entry-script helper: report bad input as one clear line, not a stack trace."""

from __future__ import annotations

import functools
import sys
from typing import Any, Callable, TypeVar

F = TypeVar("F", bound=Callable[..., Any])

USER_ERRORS = (ValueError, FileNotFoundError)


def report_user_errors(fn: F) -> F:
    """Exit with status 2 and ``error: <message>`` on stderr when ``fn`` raises a bad-input error."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except USER_ERRORS as err:
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)

    return wrapper  # type: ignore[return-value]
