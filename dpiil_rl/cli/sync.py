"""``make sync RUNS=<dir>``: upload the offline wandb runs below ``<dir>`` where a server is reachable.

Usage: ``dpiil-sync [RUNS] [--dry-run]`` (default ``runs``).
"""

from __future__ import annotations

import argparse
import sys

from dpiil_rl.loggers.wandb_sync import sync


def run() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="?", default="runs", help="a run directory or a folder of runs")
    parser.add_argument("--dry-run", action="store_true", help="list what would be synced, upload nothing")
    args = parser.parse_args()
    try:
        return sync(args.runs, dry_run=args.dry_run)
    except FileNotFoundError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


def main() -> None:
    """The ``dpiil-sync`` command."""
    sys.exit(run())


if __name__ == "__main__":
    main()
