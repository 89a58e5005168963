"""Entry-script helpers: report bad input as one clear line, not a stack trace; read ``runs=`` lists."""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Any, Callable, TypeVar

from omegaconf import DictConfig, ListConfig

from dpiil_rl.utils.config_types import check_config_types

F = TypeVar("F", bound=Callable[..., Any])

USER_ERRORS = (ValueError, FileNotFoundError)


def report_user_errors(fn: F) -> F:
    """Exit with status 2 and ``error: <message>`` on stderr when ``fn`` raises a bad-input error; a Hydra
    app's config is first checked for wrong-typed values (:mod:`dpiil_rl.utils.config_types`)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            if args and isinstance(args[0], DictConfig):  # a wrong-typed value names its key before anything runs
                check_config_types(args[0])
            return fn(*args, **kwargs)
        except USER_ERRORS as err:
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)

    return wrapper  # type: ignore[return-value]


def run_roots(runs: object) -> list[Path]:
    """``runs`` as a list of directories: one path, a list of paths, or a comma-separated string."""
    items = list(runs) if isinstance(runs, (list, tuple, ListConfig)) else str(runs).split(",")
    roots = [Path(str(item).strip()) for item in items if str(item).strip()]
    if not roots:
        raise ValueError(f"runs = {runs!r}: expected one or more directories of finished runs")
    return roots


def comma_list_override(argv: list[str]) -> list[str]:
    """Hydra reads ``runs=a,b`` as a sweep; turn an unbracketed, unquoted comma list into ``runs=[a,b]``."""
    return [f"runs=[{a[5:]}]" if a.startswith("runs=") and "," in a and a[5] not in "[\"'" else a for a in argv]
