"""``make sync RUNS=<dir>``: upload the offline wandb runs below ``<dir>`` where a server is reachable.

Usage: ``python trainers/sync.py [RUNS] [--dry-run]`` (default ``runs``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dpiil_rl.loggers.wandb_sync import sync  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("runs", nargs="?", default="runs", help="a run directory or a folder of runs")
    parser.add_argument("--dry-run", action="store_true", help="list what would be synced, upload nothing")
    args = parser.parse_args()
    try:
        return sync(args.runs, dry_run=args.dry_run)
    except FileNotFoundError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
