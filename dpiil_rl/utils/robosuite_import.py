"""Import robosuite without its import-time notices.

robosuite warns at import, in every process that imports it, about files and packages our tasks do not
need (a private macro file, robosuite_models, mink). Its logger resets its own level while importing, so
:func:`quiet_robosuite` drops them with a filter; afterwards only robosuite's errors are shown.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Iterator


def _errors_only(record: logging.LogRecord) -> bool:
    return record.levelno >= logging.ERROR


@contextlib.contextmanager
def quiet_robosuite() -> Iterator[None]:
    """Import robosuite modules inside this block."""
    loggers = [logging.getLogger(name) for name in ("robosuite", "robosuite_logs")]
    for logger in loggers:
        logger.addFilter(_errors_only)
    try:
        yield
    finally:
        for logger in loggers:
            logger.removeFilter(_errors_only)
            logger.setLevel(logging.ERROR)
