"""What a saved run's gate sees along the task: its components at every step of autonomous episodes.

The records of a run keep the gate's risk per step, not what it is made of. With a checkpoint, the final
(or any saved) policy is run alone for ``episodes`` episodes on one env (so the steps come in episode
order), and at every step the state goes through the actor, the speed head and the method's gate, which
writes down, without acting on it:

- ``action_var``: the ensemble's action variance σ²_θ(s);
- ``speed_mu``, ``speed_sigma``: the speed head's μ_λ(s) and σ_λ(s), the demonstrator's predicted speed
  at s (DPIIL's precision is its inverse);
- ``risk`` and ``chi``: the method's risk and its threshold (``risk > chi``: the gate would hand over);
- ``stage`` (staged tasks) and ``speed``: the robot's own end-effector speed coming into the state
  (``‖pos_t − pos_{t−1}‖``, in the env's position unit per step; nan at an episode's first step).

Every method's run has a speed head (the other gates fit it once, on the demos), so the same components
can be read for an uncertainty gate too. Written to ``<run>/evaluations/gate_trace_<episodes>ep.jsonl``,
one row per episode.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase, TensorDictSequential
from tqdm import tqdm

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.methods.base import RiskGatedMethod
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.records.checkpoints import checkpoint_dir, latest_checkpoint, load_state
from dpiil_rl.training.evaluation import load_run_config
from dpiil_rl.training.factory import build_env, make_actor, make_method, make_speed_head

COMPONENTS = ("action_var", "speed_mu", "speed_sigma", "risk")


class ComponentRecorder(TensorDictModuleBase):
    """Appends the gate's components of every state it sees (one env: in step order) and leaves the robot in
    control; the gate itself is only read, so the rollout is the policy's own."""

    def __init__(self, gate: Any | None) -> None:
        super().__init__()
        self.in_keys = ["action_var", "speed_mu", "speed_sigma"]
        self.out_keys = []
        self.gate = gate
        self.steps: dict[str, list[float]] = {k: [] for k in COMPONENTS}

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        if self.gate is not None:
            self.steps["risk"].append(float(self.gate.risk(tensordict).reshape(-1)[0]))
        else:
            self.steps["risk"].append(float("nan"))
        for key in COMPONENTS[:3]:
            self.steps[key].append(float(tensordict.get(key).reshape(-1)[0]))
        return tensordict


def trace_gate(
    run_dir: str | Path, episodes: int = 20, seed: int = 12_345, iteration: int | None = None
) -> dict[str, Any]:
    """Run ``episodes`` autonomous episodes of the run's saved policy; write and return the per-step trace."""
    run_dir = Path(run_dir)
    if int(episodes) < 1:
        raise ValueError(f"episodes = {episodes}: expected a positive number of traced episodes")
    cfg = load_run_config(run_dir)
    ckpt = checkpoint_dir(run_dir, iteration) if iteration is not None else latest_checkpoint(run_dir)
    if ckpt is None or not (ckpt / "state.pt").exists():
        raise FileNotFoundError(f"run_dir = {str(run_dir)!r}: no checkpoint to trace (expected checkpoints/)")
    state = load_state(ckpt)
    env = build_env(cfg.env, 1, seed=int(seed))
    actor = make_actor(cfg.modules.actor, env)
    actor.load_state_dict(state["actor"])
    speed_head = make_speed_head(cfg.modules.speed_head, env)
    speed_head.load_state_dict(state["speed_head"])
    method = make_method(cfg.method, cfg.get("chi"), cfg.protocol.get("chi_quantile"))
    gate = method.make_gate(env) if isinstance(method, RiskGatedMethod) else None
    if gate is not None:
        gate.load_state_dict(state["gate"])
    recorder = ComponentRecorder(gate)
    policy = TensorDictSequential([actor, speed_head, recorder, ConstantGate(False), ExpertSwitch(None)])
    collector = InterventionCollector(env, policy=actor, keep_paths=True)
    rows = []
    try:
        with torch.no_grad():
            done = 0
            for episode in tqdm(
                collector.rollout(EpisodeBudget(int(episodes)), "trace", int(state["iteration"]), policy),
                total=int(episodes),
                desc=f"trace {run_dir.name}",
                unit="ep",
                leave=False,
            ):
                n = int(episode.record["length"])
                pos = episode.positions
                assert pos is not None  # keep_paths
                speed = [float("nan")] + torch.linalg.vector_norm(pos[1:n] - pos[: n - 1], dim=-1).tolist()
                row = {
                    **{k: episode.record[k] for k in ("episode", "success", "collision", "length")},
                    **({"final_stage": episode.record["stage"]} if "stage" in episode.record else {}),
                    **{k: recorder.steps[k][done : done + n] for k in COMPONENTS},
                    "speed": speed,
                    **({"stage": episode.stage.tolist()} if episode.stage is not None else {}),
                }
                done += n
                rows.append(row)
    finally:
        env.close()
    chi = float(gate.chi) if gate is not None else float("nan")
    out = run_dir / "evaluations"
    out.mkdir(exist_ok=True)
    path = out / f"gate_trace_{int(episodes)}ep.jsonl"
    with path.open("w") as f:
        for row in rows:
            f.write(json.dumps({**row, "chi": chi, "checkpoint": ckpt.name, "seed": int(seed)}) + "\n")
    return {"path": str(path), "episodes": len(rows), "chi": chi, "stage_names": collector.stage_names}
