"""ThriftyDAgger (Hoque et al. 2021): novelty or risk hands control to the expert.

* novelty: the ensemble's disagreement ``σ²_θ(s) > χ_n`` (as EnsembleDAgger);
* risk: ``1 − Q(s, π(s)) > χ_r``, where ``Q`` is a critic of task success learned by temporal
  differences from every transition executed during training — the robot's own, failures
  (collisions, leaving the task space, timeouts) included. Before the robot has failed, ``Q``
  has only seen successes and cannot tell where failure lies: this is the paper's point.
* switch-back (ThriftyDAgger's rule): the expert hands control back once the robot's action is
  close to its own, ``‖π(s) − a_H‖² < δ`` (δ = the policy's mean squared error on its training
  data), and the risk is low, ``1 − Q(s, π(s)) < χ_back``. With a person as the expert, only steps
  where they drive count: before they take the robot their device commands "hold still", and a slow
  policy agreeing with that is not a reason to hand back.

The authors' pieces (their code, ``thrifty/algos``), each an option here:

* ``critic.q_networks``: the authors keep two Q networks and read the smaller value (default 2);
* ``critic.gamma``: their discount is 0.9999, so ``Q`` is close to the probability of success rather
  than to how soon it comes (default 0.9999; 0.99 made states far from the goal look risky);
* ``threshold_source``: ``dataset`` sets χ_n from D and χ_r, χ_back from the critic's transitions
  after every refit (the top 20%, the paper's protocol for every risk-aware gate: the default);
  ``robot_steps`` is the authors' rule — χ_n, χ_r the ``1 − target_rate`` quantiles of σ² and of
  ``1 − Q`` over the states the *robot* drove in this round, χ_back their median, refreshed at every
  episode start once 25 such states are seen (until then the dataset values hold);
* ``autonomous_rollouts``: episodes of the robot alone after every refit whose transitions feed the
  critic (the authors' ``test_agent``, 10 per iteration); they are training episodes with their own
  risk, recorded as phase ``rollout`` and counted in the summary (default 0 here, the paper's protocol
  has no unsupervised runs during training).

``configs/method/thrifty_dagger.yaml`` is the paper's protocol with the authors' critic;
``thrifty_dagger_authors.yaml`` turns every authors' piece on.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Sequence, cast

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase

from dpiil_rl.collectors.expert_switch import CONSULTED_KEY, QUERIED_KEY
from dpiil_rl.collectors.stop_rules import EpisodeBudget
from dpiil_rl.data.buffer import training_data
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.hooks.evaluate import autonomous_policy
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.gate import ThresholdRule
from dpiil_rl.modules.success_critic import CriticTargets, SuccessCritic
from dpiil_rl.modules.switching_gate import SwitchingGate
from dpiil_rl.utils.specs import spec_bounds

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


#: where χ_n, χ_r and χ_back come from (``method.threshold_source``)
THRESHOLD_SOURCES = ("dataset", "robot_steps")
MIN_ROBOT_STEPS = 25  # robot-driven states a round must have seen before they set the thresholds (the authors' 25)


class ThriftyGate(SwitchingGate):
    chi: torch.Tensor  # buffers (registered in __init__)
    chi_risk: torch.Tensor
    chi_back: torch.Tensor
    delta_back: torch.Tensor

    def __init__(
        self,
        critic: SuccessCritic,
        expert: "ExpertSource",
        novelty_rule: ThresholdRule,
        risk_rule: ThresholdRule,
        threshold_source: str = "dataset",
        target_rate: float = 0.2,
    ) -> None:
        super().__init__(in_keys=["observation", "policy_action", "action_var"], out_keys=["expert_mode", "risk"])
        if threshold_source not in THRESHOLD_SOURCES:
            raise ValueError(
                f"method.threshold_source = {threshold_source!r}: expected one of {', '.join(THRESHOLD_SOURCES)}"
            )
        if not 0.0 < float(target_rate) < 1.0:
            raise ValueError(f"method.target_rate = {target_rate}: expected a fraction strictly between 0 and 1")
        self.critic = critic
        self.expert = expert
        self.novelty_rule = novelty_rule
        self.risk_rule = risk_rule
        self.threshold_source = threshold_source
        self.target_rate = float(target_rate)
        for name in ("chi", "chi_risk", "chi_back", "delta_back"):  # χ_n, χ_r, switch-back risk and discrepancy
            self.register_buffer(name, torch.tensor(float("inf") if name != "delta_back" else 0.0, dtype=torch.float64))
        # σ² and 1 − Q of the states the robot drove in this round (threshold_source = robot_steps)
        self._robot_novelty: list[torch.Tensor] = []
        self._robot_risk: list[torch.Tensor] = []

    def start_round(self, iteration: int, phase: str) -> None:
        """A new round: the robot-driven statistics start afresh (the authors refit them every iteration)."""
        del iteration, phase
        self._robot_novelty, self._robot_risk = [], []

    def _refresh_from_robot_steps(self) -> None:
        novelty, risk = torch.cat(self._robot_novelty).double(), torch.cat(self._robot_risk).double()
        if novelty.numel() <= MIN_ROBOT_STEPS:
            return
        q = 1.0 - self.target_rate
        self.chi.fill_(float(torch.quantile(novelty, q)))
        self.chi_risk.fill_(float(torch.quantile(risk, q)))
        self.chi_back.fill_(float(torch.quantile(risk, 0.5)))

    def get_extra_state(self) -> Any:
        return {
            "robot_novelty": [t.clone() for t in self._robot_novelty],
            "robot_risk": [t.clone() for t in self._robot_risk],
        }

    def set_extra_state(self, state: Any) -> None:
        self._robot_novelty = list(state.get("robot_novelty", []))
        self._robot_risk = list(state.get("robot_risk", []))

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        """``1 − Q(s, π(s))`` ``[*batch, 1]``."""
        return 1.0 - self.critic(tensordict.get("observation"), tensordict.get("policy_action"))

    def decide(self, tensordict: TensorDictBase, previous: torch.Tensor) -> torch.Tensor:
        risk = self.risk(tensordict)
        tensordict.set("risk", risk)
        if self.threshold_source == "robot_steps":
            is_init = tensordict.get("is_init", None)
            if is_init is not None and bool(is_init.any()) and self._robot_novelty:  # an episode ended: refresh
                self._refresh_from_robot_steps()
            robot = ~previous.reshape(-1)
            self._robot_novelty.append(tensordict.get("action_var").reshape(-1)[robot].detach().clone())
            self._robot_risk.append(risk.reshape(-1)[robot].detach().clone())
        novel = tensordict.get("action_var").double() > self.chi
        to_expert = novel | (risk.double() > self.chi_risk)
        if not bool(previous.any()):
            return to_expert
        expert_action = self.expert.get_action(tensordict).to(previous.device)
        tensordict.set(QUERIED_KEY, expert_action)  # the switch reuses it: the expert is asked once per step
        tensordict.set(CONSULTED_KEY, previous.clone())  # the expert in control judged the hand-back
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
        data = training_data(trainer.experience)
        with torch.no_grad():
            next_action = trainer.actor.members(data["next_observation"]).mean(-2)
            policy_action = trainer.actor.members(data["observation"]).mean(-2)
        losses = gate.critic.fit(
            data["observation"],
            data["action"],
            data["next_observation"],
            next_action,
            data["success"],
            data["done"],
            self.settings,
            self.targets,
            trainer.generator,
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


class AutonomousRolloutHook(LoopHook):
    """After the policy refit, before the critic's: ``episodes`` episodes of the robot alone, whose
    transitions reach the critic's experience (the authors' ``test_agent``). Recorded as phase ``rollout``;
    none after the last iteration (no critic refit follows that would use them)."""

    def __init__(self, episodes: int) -> None:
        self.episodes = int(episodes)

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        if self.episodes < 1 or trainer.iteration >= trainer.iterations:
            return {}
        t0 = time.perf_counter()
        rows = []
        with torch.no_grad():
            for episode in trainer.collector.rollout(
                EpisodeBudget(self.episodes), "rollout", trainer.iteration, policy=autonomous_policy(trainer.actor)
            ):
                trainer.record_episode(episode)
                rows.append(episode.record)
        return {
            "thrifty/rollout_success": sum(r["success"] for r in rows) / len(rows),
            "time/rollouts_s": time.perf_counter() - t0,
        }


class ThriftyDAgger(Method):
    needs_experience = True

    def __init__(
        self,
        name: str,
        threshold: ThresholdRule,
        risk_threshold: ThresholdRule,
        critic: DictConfig | dict,
        threshold_source: str = "dataset",
        target_rate: float = 0.2,
        autonomous_rollouts: int = 0,
        **options: Any,
    ) -> None:
        super().__init__(name, **options)
        if threshold_source not in THRESHOLD_SOURCES:
            raise ValueError(
                f"method.threshold_source = {threshold_source!r}: expected one of {', '.join(THRESHOLD_SOURCES)}"
            )
        if not 0.0 < float(target_rate) < 1.0:
            raise ValueError(f"method.target_rate = {target_rate}: expected a fraction strictly between 0 and 1")
        if int(autonomous_rollouts) < 0:
            raise ValueError(f"method.autonomous_rollouts = {autonomous_rollouts}: expected a number of episodes >= 0")
        self.threshold_source = threshold_source
        self.target_rate = float(target_rate)
        self.autonomous_rollouts = int(autonomous_rollouts)
        for key, rule in (("threshold", threshold), ("risk_threshold", risk_threshold)):
            if not callable(rule):
                raise ValueError(f"method.{key} = {rule!r}: expected a threshold rule with a '_target_'")
        self.threshold = threshold
        self.risk_threshold = risk_threshold
        spec = cast(  # a mapping node's container is a dict
            "dict[str, Any]",
            OmegaConf.to_container(critic, resolve=True) if isinstance(critic, DictConfig) else dict(critic),
        )
        self.hidden: Sequence[int] = list(spec.pop("hidden"))
        self.q_networks = int(spec.pop("q_networks", 2))
        self.fit = FitSettings(**spec.pop("fit"))
        self.targets = CriticTargets(**spec)

    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> ThriftyGate:
        if env is None or expert is None:
            raise ValueError("method=thrifty_dagger needs the env (critic sizes) and the expert source (switch-back)")
        obs_low, obs_high = spec_bounds(env.observation_spec["observation"])
        act_low, act_high = spec_bounds(env.action_spec)
        critic = SuccessCritic(obs_low, obs_high, act_low, act_high, self.hidden, self.q_networks)
        return ThriftyGate(critic, expert, self.threshold, self.risk_threshold, self.threshold_source, self.target_rate)

    def extra_hooks(self) -> list[Any]:
        rollouts = [AutonomousRolloutHook(self.autonomous_rollouts)] if self.autonomous_rollouts else []
        return [*rollouts, CriticRefitHook(self.fit, self.targets)]
