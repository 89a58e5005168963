"""The protocol's final test of a finished run: its last policy alone on the common start states.

A study compares methods on the same start states (``protocol.final_eval_episodes`` episodes drawn from
``protocol.final_eval_seed``, the same for every run; the paper tests each ring policy on 100 episodes).
Done inside the run, right after it finishes, the evaluation lands in the run's records
(``evaluations/common_<N>ep_seed<S>.json`` and its ``episodes.jsonl``) while the checkpoint is still on
disk, so a study's committed records hold it and no run has to be trained again to be compared. It is
exactly what ``dpiil-evaluate run_dir=<run> episodes=<N> seed=<S>`` writes (all episodes side by side; at
most ``protocol.final_eval_envs`` simulations at once, in chunks on the same start states with the same records),
and a run killed during it runs it again the next time the same command starts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from dpiil_rl.records.checkpoints import latest_checkpoint
from dpiil_rl.training.evaluation import evaluate_run, saved_evaluation


def common_start_name(episodes: int, seed: int) -> str:
    """The file name (under ``evaluations/``) of an evaluation on ``episodes`` common starts of ``seed``."""
    return f"common_{int(episodes)}ep_seed{int(seed)}"


def final_evaluation(cfg: DictConfig, run_dir: str | Path) -> dict[str, Any] | None:
    """Evaluate the finished run in ``run_dir`` on the protocol's common starts unless it has been already;
    the result, or None when the protocol asks for none (``final_eval_episodes: 0``) or there is no
    checkpoint to evaluate (committed records without their evaluation: said in one line)."""
    protocol = cfg.protocol
    episodes = int(protocol.get("final_eval_episodes", 0))
    if episodes == 0:
        return None
    if episodes < 0:
        raise ValueError(
            f"protocol.final_eval_episodes = {episodes}: expected a number of test episodes >= 0 (0 = none)"
        )
    seed = int(protocol.get("final_eval_seed", 12_345))
    run_dir = Path(run_dir)
    name = common_start_name(episodes, seed)
    saved = saved_evaluation(run_dir, name, episodes, seed)
    if saved is not None:
        return saved[0]
    if latest_checkpoint(run_dir) is None:
        print(f"[dpiil_rl] {run_dir}: no checkpoint, so no final evaluation {name} (train the run again to make it)")
        return None
    max_envs = protocol.get("final_eval_envs")
    if max_envs is not None and int(max_envs) < 2:
        raise ValueError(
            f"protocol.final_eval_envs = {max_envs}: expected at least 2 simulations at once "
            "(or null: all side by side)"
        )
    result = evaluate_run(
        run_dir,
        episodes=episodes,
        num_envs=episodes,
        seed=seed,
        name=name,
        max_envs=None if max_envs is None else int(max_envs),
    )
    print(
        f"[dpiil_rl] final evaluation {name}: success {100 * result['success']:.0f}%, "
        f"collision {100 * result['collision']:.0f}% ({run_dir / 'evaluations' / name}.json)",
        flush=True,
    )
    return result
