"""Which machines a study's records were made on (``summary.json``'s ``machine``, :mod:`dpiil_rl.utils.machine`).

Runs reproduce bit for bit on one CPU code path only, so a report says when its runs come from several; it
also names the commits its runs record (``summary.json``'s ``code``, :mod:`dpiil_rl.utils.code_version`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from dpiil_rl.study.study_runs import StudyRun


def machine_label(machine: dict[str, Any]) -> str:
    """``<cpu> (<torch CPU capability>[, MKL_CBWR=...])``: what decides the CPU kernels of a run."""
    kernels = machine.get("kernel_variables") or {}
    extra = "".join(f", {k}={v}" for k, v in sorted(kernels.items()))
    return f"{machine.get('cpu', '?')} ({machine.get('torch_cpu_capability', '?')}{extra})"


def machines_note(runs: Sequence[StudyRun]) -> str | None:
    """One line: how many runs were made on which machine, and how many do not say; None if none says."""
    labels = Counter(machine_label(r.recorded["machine"]) for r in runs if isinstance(r.recorded.get("machine"), dict))
    if not labels:
        return None
    unknown = len(runs) - sum(labels.values())
    parts = [f"{n} on {label}" for label, n in sorted(labels.items(), key=lambda kv: (-kv[1], kv[0]))]
    if unknown:
        parts.append(f"{unknown} made before runs recorded their machine")
    several = len(labels) > 1 or unknown > 0
    tail = (
        " — runs reproduce bit for bit on the same CPU code path only, so runs of different machines match in "
        "distribution, not byte for byte"
        if several
        else ""
    )
    return f"machines: {'; '.join(parts)}{tail}"


def code_note(runs: Sequence[StudyRun]) -> str | None:
    """One line: how many runs each recorded commit made (``+dirty`` when ``dpiil_rl/`` differed from it), and
    how many do not say; None if no run records its code."""
    recorded = [r.recorded["code"] for r in runs if isinstance(r.recorded.get("code"), dict)]
    if not recorded:
        return None
    labels = Counter(
        f"{str(c.get('commit'))[:7]}{'+dirty' if c.get('dirty') else ''}" if c.get("commit") else "no commit"
        for c in recorded
    )
    parts = [f"{n} at {label}" for label, n in sorted(labels.items(), key=lambda kv: (-kv[1], kv[0]))]
    if len(runs) > len(recorded):
        parts.append(f"{len(runs) - len(recorded)} made before runs recorded their code")
    return f"code: {'; '.join(parts)}"
