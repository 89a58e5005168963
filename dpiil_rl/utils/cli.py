"""Entry-script helpers: report bad input as one clear line, not a stack trace; read ``runs=`` lists."""

from __future__ import annotations

import errno
import functools
import os
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
        except OSError as err:
            if err.errno not in WRITE_ERRNOS:
                raise
            print(f"error: {describe_write_error(err)}", file=sys.stderr)
            sys.exit(2)

    return wrapper  # type: ignore[return-value]


#: errors of writing a run's files that the person can fix (and then run the same command again)
WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM)


def describe_write_error(err: OSError) -> str:
    """One line for a write that failed: what, where, and the way out (the run resumes from its checkpoint)."""
    where = f" writing {err.filename}" if err.filename else ""
    if err.errno in (errno.ENOSPC, errno.EDQUOT):
        return (
            f"no space left on the device{where} ({err.strerror}): the run stopped; its records up to the last "
            "checkpoint are kept. Free some space and run the same command to continue."
        )
    return (
        f"cannot write{where} ({err.strerror}): expected a writable run_root (run_root=<a directory you can write>); "
        "nothing was lost, run the same command once it is writable."
    )


def check_run_root(argv: list[str], default: str = "runs") -> None:
    """Before Hydra makes the run directory: ``run_root`` (``run_root=<dir>`` on the command line, else
    ``default``) must name a directory that exists or can be made, and that can be written; exit 2 with one
    line otherwise (Hydra would print a stack trace, or make directories at the file system's root)."""
    value = next((a.split("=", 1)[1] for a in argv if a.lstrip("+").startswith("run_root=")), default)
    problem = None
    if not value.strip() or value.strip() in ("null", "None"):
        problem = "expected a directory"
    else:
        root = Path(value)
        try:  # make it (Hydra would) and write a probe into it: permissions, read-only file systems, files in the way
            root.mkdir(parents=True, exist_ok=True)
            probe = root / f".write-probe-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
        except OSError as err:
            problem = f"cannot write there ({err.strerror}); expected a directory you can write"
    if problem:
        print(f"error: run_root = {value!r}: {problem}", file=sys.stderr)
        sys.exit(2)


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
