"""How much a refit's outcome depends on chance: refit a run's actor many times on the same dataset D and
test the mean policy and every ensemble member alone.

A run's ``checkpoints/iter_<k>/buffer`` holds D after iteration ``k``. Each refit uses its own generator
(seed ``1000 + i``) and the run's fit settings (``overrides`` change them, e.g. ``modules.actor.fit.lr=3e-3``);
each policy is tested on the same ``episodes`` start states. What this measures: if the members
succeed or fail independently of each other, the fits are noisy and the mean policy's outcome is a draw
(docs/learner.md); if they all fail together, they share a bias.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence, cast

import torch
from omegaconf import OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.data.buffer import make_buffer, training_data
from dpiil_rl.data.splits import heldout_episodes
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.records.checkpoints import checkpoint_dir, load_buffer
from dpiil_rl.training.evaluation import load_run_config
from dpiil_rl.training.factory import build_env, fit_settings, make_actor


class MemberPolicy(TensorDictModuleBase):
    """One ensemble member acting alone (writes ``policy_action``)."""

    def __init__(self, actor: EnsembleActor, member: int) -> None:
        super().__init__()
        self.actor, self.member = actor, int(member)
        self.in_keys, self.out_keys = ["observation"], ["policy_action"]

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict.set("policy_action", self.actor.members(tensordict.get("observation"))[..., self.member, :])
        return tensordict


def refit_variance(
    run_dir: str | Path,
    iteration: int,
    fits: int = 10,
    episodes: int = 100,
    overrides: Sequence[str] = (),
    seed: int = 12_345,
) -> dict[str, Any]:
    """Refit ``fits`` times on D after ``iteration``; returns each refit's mean-policy and member success rates."""
    cfg = load_run_config(run_dir)
    cfg = OmegaConf.merge(cfg, OmegaConf.from_dotlist(list(overrides)))
    ckpt = checkpoint_dir(run_dir, iteration)
    if not (ckpt / "buffer").is_dir():
        raise FileNotFoundError(
            f"run_dir = {str(run_dir)!r}: no checkpoints/iter_{iteration:03d}/buffer "
            "(expected a run that kept its checkpoints)"
        )
    with tempfile.TemporaryDirectory() as scratch:
        buffer = make_buffer(scratch, int(cfg.buffer.capacity))
        load_buffer(buffer, ckpt, "buffer")
        data = training_data(buffer)
    fraction = float(OmegaConf.select(cfg, "method.classifier.heldout_fraction", default=0.0) or 0.0)
    if fraction:  # SafeDAgger / LazyDAgger: the policy is fitted without the held-out episodes, as in the run
        data = cast(TensorDictBase, data[~heldout_episodes(data["episode"], fraction, int(cfg.seed))])
    env = build_env(cfg.env, min(int(episodes), 100), seed=seed)
    actor = make_actor(cfg.modules.actor, env)
    settings = fit_settings(cfg.modules.actor.fit)

    def success(policy: TensorDictModuleBase) -> float:
        env.set_seed(seed)
        collector = InterventionCollector(env, policy=policy)
        with torch.no_grad():
            rows = [e.record for e in collector.rollout(EpisodeBudget(int(episodes)), "eval", iteration, policy)]
        return sum(r["success"] for r in rows) / len(rows)

    refits = []
    for i in range(int(fits)):
        t0 = time.perf_counter()
        actor.fit(data["observation"], data["expert_action"], settings, torch.Generator().manual_seed(1000 + i))
        fit_s = time.perf_counter() - t0
        members = [success(autonomous_policy(MemberPolicy(actor, m))) for m in range(actor.num_members)]
        refits.append({"mean_policy": success(autonomous_policy(actor)), "members": members, "fit_s": round(fit_s, 2)})
    env.close()
    member_rates = [m for r in refits for m in r["members"]]
    return {
        "run_dir": Path(run_dir).name,
        "iteration": int(iteration),
        "dataset_size": int(data.shape[0]),
        "overrides": list(overrides),
        "refits": refits,
        "mean_policy_success": statistics.mean(r["mean_policy"] for r in refits),
        "mean_policy_collapsed": sum(r["mean_policy"] < 0.1 for r in refits),
        "member_success": statistics.mean(member_rates),
        "members_failing_all": sum(m < 0.1 for m in member_rates),
        "members": len(member_rates),
    }
