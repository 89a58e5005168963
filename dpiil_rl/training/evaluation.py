"""Evaluate a saved run's policy alone, optionally on a modified task (e.g. another aperture width)."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any, Mapping, cast

import torch
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from dpiil_rl.collectors.intervention import Episode, InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.records.checkpoints import checkpoint_dir, latest_checkpoint, load_state
from dpiil_rl.records.run_files import RunFiles, read_jsonl
from dpiil_rl.training.factory import build_env, make_actor


def load_run_config(run_dir: str | Path) -> DictConfig:
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise FileNotFoundError(
            f"run_dir = {str(run_dir)!r}: no such directory (expected a run directory made by dpiil-train)"
        )
    cfg_path = run_dir / ".hydra" / "config.yaml"
    if not cfg_path.exists():
        raise FileNotFoundError(
            f"run_dir = {str(run_dir)!r}: no .hydra/config.yaml inside (expected a run directory made by dpiil-train)"
        )
    return OmegaConf.load(cfg_path)  # type: ignore[return-value]


def evaluate_run(
    run_dir: str | Path,
    episodes: int = 100,
    num_envs: int = 100,
    iteration: int | None = None,
    seed: int = 12_345,
    env_overrides: Mapping[str, Any] | None = None,
    name: str | None = None,
    max_envs: int | None = None,
) -> dict[str, Any]:
    """Run ``episodes`` autonomous episodes of the run's policy; write ``evaluations/<name>.json``.

    ``max_envs``: at most this many simulations at once (a ring simulation holds ≈ 0.1 GB, so 100 side by
    side need ≈ 11 GB). With ``num_envs >= episodes`` the episodes are then run in chunks on exactly the
    start states of all side by side, rows in the order one batch would end them (ties by env), the policy's
    rows computed in their places in the batch of all. Not byte for byte the batch of all: on a 100-episode
    ring check 99 episodes were identical and one ended a step later (the cause is not found; the policy's
    rows are identical, tested). Needs an env that can skip start states (``skip_starts``: the ring tasks).
    """
    run_dir = Path(run_dir)
    for key, value in (("episodes", episodes), ("num_envs", num_envs)):
        if int(value) < 1:
            raise ValueError(f"{key} = {value}: expected a positive number of test episodes / side-by-side envs")
    if max_envs is not None and int(max_envs) < 2:
        raise ValueError(f"max_envs = {max_envs}: expected at least 2 simulations at once (or null: no limit)")
    cfg = load_run_config(run_dir)
    if env_overrides:
        cfg.env = cast(DictConfig, OmegaConf.merge(cfg.env, OmegaConf.create(dict(env_overrides))))  # two mappings
    ckpt = checkpoint_dir(run_dir, iteration) if iteration is not None else latest_checkpoint(run_dir)
    if ckpt is None or not (ckpt / "state.pt").exists():
        which = "latest" if iteration is None else f"iteration {iteration}"
        raise FileNotFoundError(
            f"run_dir = {str(run_dir)!r}: no {which} checkpoint under checkpoints/ "
            "(expected a run that finished at least one iteration)"
        )
    state = load_state(ckpt)
    batch = min(int(num_envs), int(episodes))
    chunks = [batch]
    if max_envs is not None and batch > int(max_envs):
        if batch < int(episodes):
            raise ValueError(
                f"max_envs = {max_envs} with num_envs = {num_envs} < episodes = {episodes}: expected num_envs >= "
                "episodes (chunks run the start states of all episodes side by side) or num_envs <= max_envs"
            )
        chunks = chunk_sizes(int(episodes), int(max_envs))
    progress = tqdm(total=int(episodes), desc=f"evaluate {run_dir.name}", unit="ep", leave=False)
    rows: list[dict[str, Any]] = []
    ends: list[tuple[int, int]] = []  # when (its length) and where (env of the batch of all) each episode ended
    stage_names: list[str] = []
    with progress:
        for skipped, size in zip(itertools.accumulate([0, *chunks[:-1]]), chunks):
            run = int(episodes) if len(chunks) == 1 else size  # one batch: every episode (envs may run several)
            finished, stage_names = _chunk(cfg, state, int(seed), skipped, size, run, int(episodes), progress)
            rows += [e.record for e in finished]
            ends += [(e.record["length"], skipped + e.env_index) for e in finished]
    if len(chunks) > 1:  # the order of one batch: by the step each episode ended (its length), ties by env
        order = sorted(range(len(rows)), key=ends.__getitem__)
        rows = [{**rows[j], "episode": e} for e, j in enumerate(order)]
    n = len(rows)
    result = {
        "run_dir": "/".join(run_dir.resolve().parts[-2:]),  # <run name>/seed_<s>: no machine path in a record
        "checkpoint": ckpt.name,
        "episodes": n,
        "success": sum(r["success"] for r in rows) / n,
        "collision": sum(r["collision"] for r in rows) / n,
        "out_of_bounds": sum(r["out_of_bounds"] for r in rows) / n,
        "timeout": sum(r["timeout"] for r in rows) / n,
        "mean_length": sum(r["length"] for r in rows) / n,
        **({"stages": {stage: sum(r["stage"] == stage for r in rows) for stage in stage_names}} if stage_names else {}),
        "seed": int(seed),
        "chunks": chunks,  # the simulations side by side, chunk after chunk (one chunk: all at once)
        "env_overrides": dict(env_overrides or {}),
    }
    out = run_dir / "evaluations"
    out.mkdir(exist_ok=True)
    name = name or (
        "default"
        if not env_overrides
        else "_".join(f"{k}={v}" for k, v in sorted(_flatten(dict(env_overrides)).items()))
    )
    (out / f"{name}.json").write_text(json.dumps(result, indent=2) + "\n")
    files = RunFiles(out / name)
    files.start_fresh()
    for r in rows:
        files.add_episode(r)
    return result


def chunk_sizes(episodes: int, max_envs: int) -> list[int]:
    """Sizes of the chunks ``episodes`` side-by-side episodes run in with at most ``max_envs`` at once, as even
    as possible. No chunk has a single env (a batch of one row takes another matrix path than a batch of
    several), so with very few episodes a chunk can hold one more than ``max_envs``."""
    count = -(-int(episodes) // int(max_envs))
    if episodes > 1 and episodes // count < 2:
        count = episodes // 2
    base, extra = divmod(int(episodes), count)
    return [base + (1 if i < extra else 0) for i in range(count)]


def _chunk(
    cfg: DictConfig,
    state: dict[str, Any],
    seed: int,
    skipped: int,
    size: int,
    episodes: int,
    total: int,
    progress: tqdm,
) -> tuple[list[Episode], list[str]]:
    """``episodes`` episodes on ``size`` envs side by side, after skipping ``skipped`` start states (a chunk:
    ``episodes == size``, the start states ``skipped .. skipped + size − 1`` of the whole evaluation)."""
    env = build_env(cfg.env, size, seed=seed)
    chunk = episodes == size < total
    skip = getattr(env.base_env, "skip_starts", None)
    if chunk and skip is None:
        env.close()
        raise ValueError(
            f"max_envs: the env {cfg.env.get('name')!r} cannot skip start states, so its evaluation cannot be "
            "run in chunks; expected max_envs=null (all side by side)"
        )
    if chunk and skipped and skip is not None:
        skip(int(skipped))
    actor = make_actor(cfg.modules.actor, env)
    actor.load_state_dict(state["actor"])
    if chunk:  # the policy's rows computed as in the batch of all episodes, in their places there
        actor.pad_rows, actor.pad_offset = total, skipped
    collector = InterventionCollector(env, policy=actor)
    finished: list[Episode] = []
    try:
        with torch.no_grad():
            rollout = collector.rollout(
                EpisodeBudget(episodes), "eval", int(state["iteration"]), autonomous_policy(actor)
            )
            for e in rollout:
                finished.append(e)
                progress.update()
    finally:  # the env's simulation workers (robot tasks) end with it, also when the rollout fails
        env.close()
    return finished, list(collector.stage_names)


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            flat.update(_flatten(v, key + "."))
        else:
            flat[key] = v
    return flat


def saved_evaluation(
    run_dir: Path,
    name: str,
    episodes: int,
    seed: int,
) -> tuple[dict[str, Any], list[dict[str, Any]]] | None:
    """The run's evaluation ``name`` and its episode rows if on disk and complete for these settings, else None.
    In a run with checkpoints it must be of the latest one; a study's committed records keep no checkpoint, and
    there the saved evaluation is the record."""
    path = run_dir / "evaluations" / f"{name}.json"
    if not path.exists():
        return None
    result = json.loads(path.read_text())
    latest = latest_checkpoint(run_dir)
    rows = read_jsonl(run_dir / "evaluations" / name / "episodes.jsonl")
    same = (
        result.get("episodes") == episodes
        and result.get("seed") == seed
        and not result.get("env_overrides")
        and (latest is None or result.get("checkpoint") == latest.name)  # no checkpoint: committed records
        and len(rows) == episodes
    )
    return (result, rows) if same else None
