"""ThriftyDAgger (Hoque et al. 2021): novelty or risk hands control to the expert.

* novelty: the ensemble's disagreement ``σ²_θ(s) > χ_n`` (as EnsembleDAgger);
* risk: ``1 − Q(s, π(s)) > χ_r``, where ``Q`` is a critic of task success learned by temporal
  differences from every transition executed during training — the robot's own, failures
  (collisions, leaving the task space, timeouts) included. Before the robot has failed, ``Q``
  has only seen successes and cannot tell where failure lies: this is the paper's point.
* switch-back (ThriftyDAgger's rule): the expert hands control back once the robot's action is
  close to its own, ``‖π(s) − a_H‖² < δ`` (δ = the policy's mean squared error on its training
  data), and the risk is low, ``1 − Q(s, π(s)) < χ_back`` (the median risk of the critic's data).
  With a person as the expert, only steps where they drive count: before they take the robot their
  device commands "hold still", and a slow policy agreeing with that is not a reason to hand back.

χ_n and χ_r follow the same protocol as every risk gate (by default the top 20% of the respective
training data: D for novelty, the critic's transitions for risk), or are fixed by hand.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Sequence

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase

from dpiil_rl.data.buffer import buffer_contents
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.expert_switch import QUERIED_KEY
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.gate import ThresholdRule
from dpiil_rl.modules.success_critic import CriticTargets, SuccessCritic
from dpiil_rl.modules.switching_gate import SwitchingGate
from dpiil_rl.utils.specs import spec_bounds

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class ThriftyGate(SwitchingGate):
    def __init__(
        self, critic: SuccessCritic, expert: "ExpertSource", novelty_rule: ThresholdRule, risk_rule: ThresholdRule
    ) -> None:
        super().__init__(in_keys=["observation", "policy_action", "action_var"], out_keys=["expert_mode", "risk"])
        self.critic = critic
        self.expert = expert
        self.novelty_rule = novelty_rule
        self.risk_rule = risk_rule
        for name in ("chi", "chi_risk", "chi_back", "delta_back"):  # χ_n, χ_r, switch-back risk and discrepancy
            self.register_buffer(name, torch.tensor(float("inf") if name != "delta_back" else 0.0, dtype=torch.float64))

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        """``1 − Q(s, π(s))`` ``[*batch, 1]``."""
        return 1.0 - self.critic(tensordict.get("observation"), tensordict.get("policy_action"))

    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        risk = self.risk(tensordict)
        tensordict.set("risk", risk)
        novel = tensordict.get("action_var").double() > self.chi
        to_expert = novel | (risk.double() > self.chi_risk)
        if not bool(previous.any()):
            return to_expert
        expert_action = self.expert.get_action(tensordict).to(previous.device)
        tensordict.set(QUERIED_KEY, expert_action)  # the switch reuses it: the expert is asked once per step
        gap = ((tensordict.get("policy_action") - expert_action) ** 2).sum(-1, keepdim=True)
        hand_back = (gap.double() < self.delta_back) & (risk.double() < self.chi_back)
        labelled = getattr(self.expert, "labelled", None)  # a person: only where they drive is theirs an action
        if labelled is not None and labelled.numel() == hand_back.numel():
            # a person who has not taken the robot yet commands "hold still"; agreeing with that is no hand-back
            hand_back = hand_back & labelled.reshape(hand_back.shape).to(hand_back.device)
        return torch.where(previous, ~hand_back, to_expert)

    def calibrate(self, tensordict: TensorDictBase) -> dict[str, float]:
        """χ_n and δ from the policy's training data D (heads already run on it)."""
        self.chi.fill_(self.novelty_rule(tensordict.get("action_var")))
        gap = ((tensordict.get("policy_action") - tensordict.get("expert_action")) ** 2).sum(-1)
        self.delta_back.fill_(float(gap.double().mean()))
        flagged = float((tensordict.get("action_var").double() > self.chi).float().mean())
        return {"chi": float(self.chi), "thrifty/delta_back": float(self.delta_back), "train/flagged_fraction": flagged}

    def calibrate_risk(self, risk: torch.Tensor) -> dict[str, float]:
        """χ_r by the risk rule and the switch-back risk (median) from the critic's own data."""
        self.chi_risk.fill_(self.risk_rule(risk))
        self.chi_back.fill_(float(torch.quantile(risk.double().reshape(-1), 0.5)))
        return {"thrifty/chi_risk": float(self.chi_risk), "thrifty/chi_back": float(self.chi_back)}


class CriticRefitHook(LoopHook):
    """After the policy refit: TD-fit the success critic on every transition so far, then χ_r."""

    def __init__(self, settings: FitSettings, targets: CriticTargets) -> None:
        self.settings = settings
        self.targets = targets

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        t0 = time.perf_counter()
        gate: ThriftyGate = trainer.gate  # type: ignore[assignment]
        if trainer.experience is None:
            raise RuntimeError("thrifty_dagger: the loop keeps no experience buffer (Method.needs_experience)")
        data = buffer_contents(trainer.experience)
        with torch.no_grad():
            next_action = trainer.actor.members(data["next_observation"]).mean(-2)
            policy_action = trainer.actor.members(data["observation"]).mean(-2)
        losses = gate.critic.fit(
            data["observation"], data["action"], data["next_observation"], next_action, data["success"], data["done"],
            self.settings, self.targets, trainer.generator,
        )
        with torch.no_grad():
            risk = 1.0 - gate.critic(data["observation"], policy_action)
        tail = max(1, len(losses) // 20)
        return {
            **gate.calibrate_risk(risk),
            "thrifty/critic_bce": sum(losses[-tail:]) / tail,
            "thrifty/transitions": int(data.shape[0]),
            "thrifty/failures_seen": int(((data["done"] > 0) & (data["success"] == 0)).sum()),
            "time/critic_s": time.perf_counter() - t0,
        }


class ThriftyDAgger(Method):
    needs_experience = True

    def __init__(
        self, name: str, threshold: ThresholdRule, risk_threshold: ThresholdRule, critic: DictConfig | dict,
        **options: Any,
    ) -> None:
        super().__init__(name, **options)
        for key, rule in (("threshold", threshold), ("risk_threshold", risk_threshold)):
            if not callable(rule):
                raise ValueError(f"method.{key} = {rule!r}: expected a threshold rule with a '_target_'")
        self.threshold = threshold
        self.risk_threshold = risk_threshold
        spec = OmegaConf.to_container(critic, resolve=True) if isinstance(critic, DictConfig) else dict(critic)
        self.hidden: Sequence[int] = list(spec.pop("hidden"))
        self.fit = FitSettings(**spec.pop("fit"))
        self.targets = CriticTargets(**spec)

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> ThriftyGate:
        if env is None or expert is None:
            raise ValueError("method=thrifty_dagger needs the env (critic sizes) and the expert source (switch-back)")
        obs_low, obs_high = spec_bounds(env.observation_spec["observation"])
        act_low, act_high = spec_bounds(env.action_spec)
        critic = SuccessCritic(obs_low, obs_high, act_low, act_high, self.hidden)
        return ThriftyGate(critic, expert, self.threshold, self.risk_threshold)

    def extra_hooks(self) -> list[Any]:
        return [CriticRefitHook(self.fit, self.targets)]
