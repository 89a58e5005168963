"""Do speed changes leave a study's records as they were? Train the same runs with this tree and with a checkout of
an older commit, and compare their records byte for byte.

``python -m dpiil_rl.bench.identity --base PATH`` (``PATH``: a checkout of the commit to compare with, e.g.
``git worktree add ../base <commit>``; it runs on this tree's environment). Each protocol's
(method, seed) runs are trained by the older tree batched (``hydra/launcher=lockstep``) and by this tree
batched and, for its first seed, alone; every run's ``episodes.jsonl`` and ``paths.jsonl`` must be equal
byte for byte and its ``metrics.jsonl`` and ``summary.json`` equal but for the time fields (``time/*``,
``wall_time_s``, ``machine``, ``code``). Exits non-zero on any difference.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from dpiil_rl.records.run_files import read_jsonl

METHODS = ("dpiil_ucb", "ensemble_dagger", "thrifty_dagger", "dagger", "safe_dagger")
#: reduced protocols: ``smoke`` (short fits, a speed head of another shape than the actor) and ``short`` (the
#: paper's modules and fits, 2 iterations of 100 pairs, 30 test episodes)
PROTOCOLS: dict[str, tuple[str, ...]] = {
    "smoke": ("experiment=smoke", "protocol.interactive_envs=4"),
    "short": (
        "protocol.iterations=2",
        "protocol.expert_pairs_per_iteration=100",
        "protocol.eval_episodes=30",
        "protocol.eval_envs=30",
        "protocol.interactive_envs=8",
    ),
}
COMMON = ("env=aperture", "study=identity", "plots=false", "logger=none", "progress=false")


def _strip(row: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in row.items() if not k.startswith("time/") and k not in ("wall_time_s", "machine", "code")}


def train(tree: Path | None, root: Path, protocol: str, methods: tuple[str, ...], seeds: str, lockstep: bool) -> None:
    """Train ``methods`` x ``seeds`` with the code of ``tree`` (None: this environment's package) into ``root``."""
    env = {**os.environ, "HYDRA_FULL_ERROR": "1", "WANDB_SILENT": "true"}
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    root.mkdir(parents=True, exist_ok=True)
    launch = ("hydra/launcher=lockstep", "hydra.launcher.n_jobs=1") if lockstep else ("hydra/launcher=basic",)
    cmd = [
        sys.executable,
        "-m",
        "dpiil_rl.cli.train",
        "-m",
        f"method={','.join(methods)}",
        f"seed={seeds}",
        f"run_root={root}",
        *COMMON,
        *PROTOCOLS[protocol],
        *launch,
    ]
    subprocess.run(cmd, check=True, env=env, cwd=tree or root, capture_output=True, text=True)


def compare_runs(a: Path, b: Path) -> list[str]:
    """The differences between the records of run directories ``a`` and ``b`` (empty: the same)."""
    out = []
    for name in ("episodes.jsonl", "paths.jsonl"):
        if (a / name).read_bytes() != (b / name).read_bytes():
            out.append(f"{name} differs")
    if [_strip(r) for r in read_jsonl(a / "metrics.jsonl")] != [_strip(r) for r in read_jsonl(b / "metrics.jsonl")]:
        out.append("metrics.jsonl differs")
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    if _strip(sa) != _strip(sb):
        out.append("summary.json differs")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--base", required=True, help="checkout of the commit to compare with")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 of each method")
    parser.add_argument("--protocols", default=",".join(PROTOCOLS))
    parser.add_argument("--new", help="checkout of the code to check (default: this environment's package)")
    parser.add_argument("--base-records", help="keep the older tree's runs here and reuse them when present")
    args = parser.parse_args()
    base = Path(args.base).resolve()
    new = Path(args.new).resolve() if args.new else None
    methods = tuple(m for m in args.methods.split(",") if m)
    seeds = ",".join(str(s) for s in range(args.seeds))
    failures, compared = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for protocol in args.protocols.split(","):
            roots = {way: Path(tmp) / protocol / way for way in ("base", "batched", "alone")}
            if args.base_records:
                roots["base"] = Path(args.base_records).resolve() / protocol
            if not (roots["base"] / "identity").is_dir():
                train(base, roots["base"], protocol, methods, seeds, lockstep=True)
            train(new, roots["batched"], protocol, methods, seeds, lockstep=True)
            train(new, roots["alone"], protocol, methods, "0", lockstep=False)
            for method in methods:
                for seed in range(args.seeds):
                    rel = Path("identity") / "aperture" / method / f"seed_{seed}"
                    for way in ("batched", "alone"):
                        if way == "alone" and seed != 0:
                            continue
                        diff = compare_runs(roots["base"] / rel, roots[way] / rel)
                        compared += 1
                        status = "same" if not diff else "; ".join(diff)
                        print(f"{protocol:6s} {method:16s} seed {seed} {way:8s}: {status}", flush=True)
                        failures += [f"{protocol} {method} seed {seed} {way}: {d}" for d in diff]
    print(f"{compared} runs compared, {len(failures)} differences")
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
