"""SafeDAgger (Zhang & Cho 2017): the expert acts where a classifier predicts that the policy's
action would differ from the expert's.

* discrepancy: ``d(s) = ‖(π(s) − a*(s)) / scale‖²`` over the action dims, in the action spec's
  units (each dim scaled to [-1, 1]);
* held-out data, as in the originals: at every refit a share ``classifier.heldout_fraction`` of D's
  episodes (default 0.3, the 70/30 split of the LazyDAgger code) is held out of the policy's fit, and
  the classifier learns from those, where the policy's discrepancy is what it will be in new states;
* τ: held-out states with ``d(s) > τ`` count as unsafe; τ by a threshold rule on their discrepancies
  (by default the top 20%, the paper's protocol for every risk-aware gate);
* the safety policy ``P(d(s) > τ | s)``: a classifier of the state alone (it is asked before the
  expert is), binary cross-entropy, refitted after every policy refit;
* the gate: ``P(d(s) > τ | s) > χ`` with ``χ = 0.5`` (a binary decision, as the originals); a
  quantile rule on D (``method.threshold``, e.g. the top 20%) is the option used before.

With ``heldout_fraction: 0`` the classifier is fitted on the discrepancies of the data the policy was
just fitted to, where it sees few unsafe states (the policy fits them) and learns little.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Sequence, cast

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.data.buffer import training_data
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.discrepancy_classifier import DiscrepancyClassifier
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.gate import ThresholdRule
from dpiil_rl.utils.specs import spec_bounds

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from dpiil_rl.experts.base import ExpertSource
    from dpiil_rl.training.interactive_trainer import InteractiveTrainer


class DiscrepancyGate(TensorDictModuleBase):
    """Writes ``risk = P(d(s) > τ | s)`` and ``expert_mode = risk > χ``."""

    act_scale: torch.Tensor  # buffers (registered in __init__)
    tau: torch.Tensor
    chi: torch.Tensor

    def __init__(
        self,
        classifier: DiscrepancyClassifier,
        act_low: torch.Tensor,
        act_high: torch.Tensor,
        discrepancy_rule: ThresholdRule,
        rule: ThresholdRule,
    ) -> None:
        super().__init__()
        self.in_keys = ["observation"]
        self.out_keys = ["risk", "expert_mode"]
        self.classifier = classifier
        self.discrepancy_rule = discrepancy_rule
        self.rule = rule
        self.register_buffer("act_scale", ((act_high - act_low) / 2).float().clamp_min(1e-6))
        self.register_buffer("tau", torch.tensor(float("inf"), dtype=torch.float64))  # τ on d(s)
        self.register_buffer("chi", torch.tensor(float("inf"), dtype=torch.float64))  # χ on P(d > τ)

    def discrepancy(self, policy_action: torch.Tensor, expert_action: torch.Tensor) -> torch.Tensor:
        """``d = ‖(π(s) − a*) / scale‖²`` ``[*batch, 1]``."""
        gap = (policy_action.float() - expert_action.float().to(policy_action.device)) / self.act_scale
        return (gap**2).sum(-1, keepdim=True)

    def risk(self, tensordict: TensorDictBase) -> torch.Tensor:
        return self.classifier(tensordict.get("observation"))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        risk = self.risk(tensordict)
        tensordict.set("risk", risk)
        tensordict.set("expert_mode", risk.double() > self.chi)
        return tensordict

    def fit_classifier(
        self,
        obs: torch.Tensor,
        policy_action: torch.Tensor,
        expert_action: torch.Tensor,
        settings: FitSettings,
        generator: torch.Generator,
        balanced: bool = True,
    ) -> dict[str, float]:
        """τ from D's discrepancies, then the classifier on ``(s, d(s) > τ)``; returns metrics."""
        d = self.discrepancy(policy_action, expert_action)
        self.tau.fill_(self.discrepancy_rule(d))
        unsafe = d.double() > self.tau
        losses = self.classifier.fit(obs, unsafe, settings, generator, balanced=balanced)
        with torch.no_grad():
            predicted = self.classifier(obs) > 0.5
        tail = max(1, len(losses) // 20)
        return {
            "safe/tau": float(self.tau),
            "safe/unsafe_fraction": float(unsafe.float().mean()),
            "safe/discrepancy_mean": float(d.double().mean()),
            "safe/classifier_bce": sum(losses[-tail:]) / tail,
            "safe/classifier_accuracy": float((predicted == unsafe).float().mean()),
        }

    def calibrate(self, tensordict: TensorDictBase) -> dict[str, float]:
        """χ by the method's rule on the classifier's output over D."""
        risk = self.risk(tensordict)
        self.chi.fill_(self.rule(risk))
        return {"chi": float(self.chi), "train/flagged_fraction": float((risk.double() > self.chi).float().mean())}


class ClassifierRefitHook(LoopHook):
    """After the policy refit (before χ): the discrepancies of the new policy on D, τ, the classifier."""

    def __init__(self, settings: FitSettings, balanced: bool) -> None:
        self.settings = settings
        self.balanced = balanced

    def __call__(self, trainer: "InteractiveTrainer") -> dict[str, Any]:
        t0 = time.perf_counter()
        fit = getattr(trainer.gate, "fit_classifier", None)
        if fit is None:
            raise RuntimeError(f"{type(trainer.gate).__name__} has no discrepancy classifier to refit")
        data = training_data(trainer.buffer)
        heldout = trainer.heldout
        if heldout is not None and heldout.shape[0] == data.shape[0] and bool(heldout.any()):
            # episodes the policy was not fitted to (fewer than 2 episodes: all of D); a mask picks frames
            data = cast(TensorDictBase, data[heldout])
        with torch.no_grad():
            policy_action = trainer.actor.members(data["observation"]).mean(-2)
        out = fit(
            data["observation"],
            policy_action,
            data["expert_action"],
            self.settings,
            trainer.generator,
            balanced=self.balanced,
        )
        return {**out, "safe/classifier_frames": int(data.shape[0]), "time/classifier_s": time.perf_counter() - t0}


class DiscrepancyMethod(Method):
    """What SafeDAgger and LazyDAgger share: τ's rule, χ's rule, and the classifier's network and fit."""

    def __init__(
        self,
        name: str,
        threshold: ThresholdRule,
        discrepancy_threshold: ThresholdRule,
        classifier: DictConfig | dict,
        **options: Any,
    ) -> None:
        super().__init__(name, **options)
        for key, rule in (("threshold", threshold), ("discrepancy_threshold", discrepancy_threshold)):
            if not callable(rule):
                raise ValueError(f"method.{key} = {rule!r}: expected a threshold rule with a '_target_'")
        self.threshold = threshold
        self.discrepancy_threshold = discrepancy_threshold
        spec = cast(  # a mapping node's container is a dict
            "dict[str, Any]",
            OmegaConf.to_container(classifier, resolve=True)
            if isinstance(classifier, DictConfig)
            else dict(classifier),
        )
        missing = {"hidden", "balanced", "fit", "heldout_fraction"} - set(spec)
        if missing:
            raise ValueError(
                f"method.classifier: missing {sorted(missing)} (expected hidden, balanced, heldout_fraction and fit)"
            )
        self.hidden: Sequence[int] = list(spec.pop("hidden"))
        self.balanced = bool(spec.pop("balanced"))
        fraction = spec.pop("heldout_fraction")
        if not isinstance(fraction, (int, float)) or not 0.0 <= float(fraction) < 1.0:
            raise ValueError(
                f"method.classifier.heldout_fraction = {fraction!r}: expected a fraction in [0, 1) "
                "(the share of D's episodes the policy is not fitted to)"
            )
        self.heldout_fraction = float(fraction)
        self.fit = FitSettings(**spec.pop("fit"))
        if spec:
            raise ValueError(
                f"method.classifier.{next(iter(spec))}: unknown key (expected hidden, balanced, heldout_fraction, fit)"
            )

    def discrepancy_gate(self, env: "EnvBase | None") -> DiscrepancyGate:
        if env is None:
            raise ValueError(
                f"method={self.name} needs the env: the classifier's input and the action scale come from its specs"
            )
        obs_low, obs_high = spec_bounds(env.observation_spec["observation"])
        act_low, act_high = spec_bounds(env.action_spec)
        classifier = DiscrepancyClassifier(obs_low, obs_high, self.hidden)
        return DiscrepancyGate(classifier, act_low, act_high, self.discrepancy_threshold, self.threshold)

    def extra_hooks(self) -> list[Any]:
        return [ClassifierRefitHook(self.fit, self.balanced)]


class SafeDAgger(DiscrepancyMethod):
    def make_gate(self, env: "EnvBase | None" = None, expert: "ExpertSource | None" = None) -> DiscrepancyGate:
        del expert
        return self.discrepancy_gate(env)
