"""Where a run's expert-labelled pairs were collected, by stage of the ring task.

A method's data budget (1,000 expert pairs per iteration) is spent where its gate hands control to the
person. This reads the aggregate dataset D of a finished ring run (the replay buffer in its last
checkpoint: every demo and interactive pair with its 51-D state, the expert's action and the iteration
it was collected in) and counts the pairs per stage of the state (:func:`~dpiil_rl.envs.ring_task.ring_stage`:
reach, grasped, lifted, at_peg) — for the demonstrations (iteration 0) and for the later iterations
(k ≥ 1: interactive, or whole demonstrations for BC) apart — and how many of them were nearly still
(commanded translation below ``still``, e.g. waiting for the fingers to close): the person's slow, steady
phases, where the perceived precision (``1 / speed``) is largest.
"""

from __future__ import annotations

import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence, cast

import torch
from omegaconf import OmegaConf
from torchrl.data import LazyMemmapStorage

from dpiil_rl.data.buffer import make_buffer
from dpiil_rl.envs.ring_task import RING_STAGES, RingGeometry, ring_stage
from dpiil_rl.records.checkpoints import latest_checkpoint
from dpiil_rl.study.stage_table import StageCounts
from dpiil_rl.study.study_runs import StudyRun, method_order

#: the env config keys that are not geometry (see ``dpiil_rl.envs.ring.build_ring_env``)
_NOT_GEOMETRY = ("_target_", "name", "workers", "sim", "expert")
#: the stages an expert pair can be in (an episode ends when the ring is threaded)
PAIR_STAGES = RING_STAGES[:-1]
#: the initial demonstrations (iteration 0) and every later iteration's pairs (interactive, or more demos for BC)
PARTS = ("demos (k = 0)", "k ≥ 1")


@dataclass
class PairStages:
    """Expert pairs of one method over its runs, per part (:data:`PARTS`) and stage."""

    method: str
    runs: int = 0
    pairs: Counter = field(default_factory=Counter)  # (part, stage) -> pairs
    still: Counter = field(default_factory=Counter)  # (part, stage) -> nearly still pairs

    def total(self, part: str) -> int:
        return sum(v for (p, _), v in self.pairs.items() if p == part)


def load_dataset(run_dir: str | Path, capacity: int) -> Any:
    """Every pair of the run's dataset D (its latest checkpoint's buffer, of ``capacity`` frames as the run's
    ``buffer.capacity``) as one TensorDict ``[n]``."""
    ckpt = latest_checkpoint(Path(run_dir))
    if ckpt is None or not (ckpt / "buffer").is_dir():
        raise FileNotFoundError(
            f"run {str(run_dir)!r}: no checkpoint with a buffer/ (expected a run of dpiil-train with checkpoints)"
        )
    with tempfile.TemporaryDirectory() as scratch:
        buffer = make_buffer(scratch, int(capacity))  # reads compact dumps and full-capacity ones alike
        buffer.loads(str(ckpt / "buffer"))
        return cast(LazyMemmapStorage, buffer.storage).get(slice(0, len(buffer))).to_tensordict()


def ring_geometry(run: StudyRun) -> RingGeometry:
    env = cast("dict[str, Any]", OmegaConf.to_container(run.config.env, resolve=True))  # a mapping's container
    assert isinstance(env, dict)
    return RingGeometry.from_mapping({k: v for k, v in env.items() if k not in _NOT_GEOMETRY})


def expert_pair_stages(runs: Sequence[StudyRun], still: float = 0.05) -> list[PairStages]:
    """One :class:`PairStages` per method (paper order) of the ring runs in ``runs``."""
    if not still > 0:
        raise ValueError(f"still = {still}: expected a positive translation command (action units)")
    other = sorted({r.env for r in runs if r.env != "ring"})
    if other:
        raise ValueError(f"env = {other}: expert-pair stages are defined for the ring task (expected runs of env=ring)")
    by_method: dict[str, PairStages] = {}
    for run in runs:
        data = load_dataset(run.run_dir, int(run.config.buffer.capacity))
        stage = ring_stage(data["observation"], torch.zeros(data.shape[0], dtype=torch.bool), ring_geometry(run))
        quiet = data["expert_action"][:, :3].norm(dim=-1) < still
        part = [PARTS[0] if int(k) == 0 else PARTS[1] for k in data["iteration"].tolist()]
        stats = by_method.setdefault(run.method, PairStages(run.method))
        stats.runs += 1
        for p, s, q in zip(part, stage.tolist(), quiet.tolist()):
            stats.pairs[(p, RING_STAGES[s])] += 1
            stats.still[(p, RING_STAGES[s])] += int(q)
    return [by_method[m] for m in method_order(by_method)]


def pair_stages_markdown(stats: Sequence[PairStages], still: float) -> str:
    """Per method and part: the share of expert pairs in each stage, and the share of them nearly still."""
    header = ["method", "runs", "part", "expert pairs"] + [f"{s}" for s in PAIR_STAGES] + ["nearly still"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for s in stats:
        for part in PARTS:
            n = s.total(part)
            if not n:
                continue
            cells = [s.method, str(s.runs), part, f"{n:,}"]
            for stage in PAIR_STAGES:
                k = s.pairs[(part, stage)]
                cells.append(f"{100 * k / n:.0f}% ({100 * s.still[(part, stage)] / k:.0f}% still)" if k else "0%")
            cells.append(f"{100 * sum(v for (p, _), v in s.still.items() if p == part) / n:.0f}%")
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + (
        f"\n\nShares of each method's expert pairs (pooled over runs) by the stage of the state; "
        f'"still": commanded translation below {still} (action units, 1 = 5 cm/step).\n'
    )


def pair_stage_counts(stats: Sequence[PairStages], part: str) -> list[StageCounts]:
    """Per method, its expert pairs of ``part`` (:data:`PARTS`) by stage, as the stage figure's counts."""
    return [
        StageCounts("ring", s.method, s.runs, Counter({stage: s.pairs[(part, stage)] for stage in PAIR_STAGES}))
        for s in stats
    ]
