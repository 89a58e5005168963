"""LazyDAgger (Hoque et al. 2021): SafeDAgger's switch to the expert, with a lazier switch back.

* to the expert: as SafeDAgger, when the classifier, fitted on episodes held out of the policy's
  fit, predicts ``P(d(s) > τ | s) > χ = 0.5`` (:mod:`dpiil_rl.methods.safe_dagger`);
* back to the robot: only when the *measured* gap between the robot's and the expert's actions,
  ``d = ‖(π(s) − a_H) / scale‖²``, falls below ``β_R`` (``β_R < τ``, the hysteresis of LazyDAgger):
  the expert keeps the robot until the policy would do what they do, which makes fewer, longer
  interventions than a memoryless gate (fewer context switches for a person). β_R is set by a
  threshold rule on D's discrepancies after every refit, as τ is (by default their 0.2-quantile:
  the gap of the policy's best-fitted fifth of D). A noisy expert disagrees with any policy by
  its noise, so a β_R close to τ hands back after a step or two. With a person as the expert
  only steps where they drive count, as in ThriftyDAgger.

LazyDAgger also injects noise into the supervisor's actions while they are in control
(``supervisor_noise``, a fraction of the action range; :class:`SupervisorNoise`): the label stays
the expert's clean action, the robot executes a perturbed one, so the corrections cover states
around the expert's path. It is off by default here (0.0): every result in the README was made
without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from tensordict import TensorDictBase

from dpiil_rl.collectors.expert_switch import CONSULTED_KEY, QUERIED_KEY
from dpiil_rl.methods.safe_dagger import DiscrepancyGate, DiscrepancyMethod
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.gate import ThresholdRule
from dpiil_rl.modules.supervisor_noise import SupervisorNoise
from dpiil_rl.modules.switching_gate import SwitchingGate
from dpiil_rl.utils.specs import spec_bounds

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource


class LazyGate(SwitchingGate):
    beta_back: torch.Tensor  # buffer (registered in __init__)

    def __init__(
        self,
        safety: DiscrepancyGate,
        expert: "ExpertSource",
        back_rule: ThresholdRule,
        noise: SupervisorNoise | None = None,
    ) -> None:
        super().__init__(in_keys=["observation", "policy_action"], out_keys=["expert_mode", "risk"])
        self.safety = safety
        self.expert = expert
        self.back_rule = back_rule
        self.noise = noise
        self.register_buffer("beta_back", torch.tensor(0.0, dtype=torch.float64))  # β_R on the measured d

    @property
    def after_switch(self) -> SupervisorNoise | None:
        """Run after the hand-over by the loop: the noise on the expert's executed action, if any."""
        return self.noise

    @property
    def chi(self) -> torch.Tensor:
        """χ on the classifier's output (the switch to the expert)."""
        return self.safety.chi

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return self.safety.risk(tensordict)

    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        risk = self.risk(tensordict)
        tensordict.set("risk", risk)
        to_expert = risk.double() > self.safety.chi
        if not bool(previous.any()):
            return to_expert
        expert_action = self.expert.get_action(tensordict).to(previous.device)
        tensordict.set(QUERIED_KEY, expert_action)  # the switch reuses it: the expert is asked once per step
        tensordict.set(CONSULTED_KEY, previous.clone())  # the expert in control judged the hand-back
        gap = self.safety.discrepancy(tensordict.get("policy_action"), expert_action)
        hand_back = gap.double() < self.beta_back
        labelled = getattr(self.expert, "labelled", None)  # a person: only where they drive is theirs an action
        if labelled is not None and labelled.numel() == hand_back.numel():
            hand_back = hand_back & labelled.reshape(hand_back.shape).to(hand_back.device)
        return torch.where(previous, ~hand_back, to_expert)

    def fit_classifier(
        self,
        obs: torch.Tensor,
        policy_action: torch.Tensor,
        expert_action: torch.Tensor,
        settings: FitSettings,
        generator: torch.Generator,
        balanced: bool = True,
    ) -> dict[str, float]:
        out = self.safety.fit_classifier(obs, policy_action, expert_action, settings, generator, balanced=balanced)
        beta = self.back_rule(self.safety.discrepancy(policy_action, expert_action))
        if beta > float(self.safety.tau):
            raise ValueError(
                f"method.back_threshold gave β_R = {beta:.4g} > τ = {float(self.safety.tau):.4g}: "
                "expected a hand-back threshold below τ (e.g. a lower quantile than discrepancy_threshold)"
            )
        self.beta_back.fill_(beta)
        return {**out, "lazy/beta_back": beta}

    def calibrate(self, tensordict: TensorDictBase) -> dict[str, float]:
        return self.safety.calibrate(tensordict)


class LazyDAgger(DiscrepancyMethod):
    def __init__(self, name: str, back_threshold: ThresholdRule, supervisor_noise: float = 0.0, **options: Any) -> None:
        if not callable(back_threshold):
            raise ValueError(f"method.back_threshold = {back_threshold!r}: expected a threshold rule with a '_target_'")
        if not float(supervisor_noise) >= 0.0:
            raise ValueError(
                f"method.supervisor_noise = {supervisor_noise}: expected a standard deviation >= 0 "
                "(a fraction of each action dim's half-range; 0 = off)"
            )
        super().__init__(name, **options)
        self.back_threshold = back_threshold
        self.supervisor_noise = float(supervisor_noise)

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> LazyGate:
        if expert is None:
            raise ValueError(
                "method=lazy_dagger needs the expert source in the loop: control returns when the robot agrees with it"
            )
        safety = self.discrepancy_gate(env)
        noise = None
        if self.supervisor_noise > 0.0 and env is not None:
            act_low, act_high = spec_bounds(env.action_spec)
            seed = int(torch.randint(0, 2**31 - 1, (1,)))  # from the run's seeded global RNG (as DAgger's gate)
            noise = SupervisorNoise(act_low, act_high, self.supervisor_noise, seed)
        return LazyGate(safety, expert, self.back_threshold, noise)
