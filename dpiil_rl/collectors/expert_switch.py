"""The hand-over between learner and expert: the action executed, and the intervention events."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from dpiil_rl.experts.base import ExpertSource

QUERIED_KEY = "queried_expert_action"
#: ``[*batch, 1]`` bool a gate may write: states whose expert action enters D although the robot drives
#: (DAgger as Ross et al. wrote it labels every visited state)
LABEL_REQUEST_KEY = "label_request"
#: ``[*batch, 1]`` bool a gate may write: the expert was consulted at this step without driving
#: (a monitoring check, a switch-back comparison, an HG-DAgger expert watching)
CONSULTED_KEY = "expert_consulted"


class ExpertSwitch(TensorDictModuleBase):
    """Writes ``action`` (expert's where ``expert_mode`` else the learner's), ``expert_action``,
    ``intervention`` (an auto → expert switch at this step; the first step of an episode in expert
    mode counts as one), and the expert's effort at this step:

    * ``expert_labelled``: the expert's action enters D — where the expert drives, and where the gate
      asks for a label while the robot drives (``LABEL_REQUEST_KEY``); with a person, only where
      they actually drove (a person's input means nothing while the robot drives);
    * ``expert_queried``: the expert had to produce an action or a judgement — every labelled step,
      every step the expert drives, and every step the gate consulted them (``CONSULTED_KEY``).

    The source is queried every step when it can label any state (scripted), and only where it is
    in control otherwise (a person's input means nothing while the robot drives). A gate that
    already asked the expert this step (ThriftyDAgger's switch-back test) leaves the answer under
    ``QUERIED_KEY`` and the source is not asked twice. With no source (the robot alone) the
    learner's action is executed.
    """

    def __init__(self, expert: ExpertSource | None) -> None:
        super().__init__()
        self.in_keys = ["policy_action", "expert_mode", "is_init"]
        self.out_keys = ["action", "expert_action", "intervention", "expert_labelled", "expert_queried"]
        self.expert = expert
        self._previous: torch.Tensor | None = None

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        mode = tensordict.get("expert_mode")
        learner = tensordict.get("policy_action", None)
        if self.expert is not None:
            self.expert.observe(tensordict)
        if learner is None and not bool(mode.all()):
            raise RuntimeError("ExpertSwitch: no 'policy_action' in the tensordict but the expert is not in control")
        # a gate that consulted the expert this step left its answer; popped so it never goes stale
        # (TorchRL's step_mdp carries other keys over to the next step)
        queried = tensordict.pop(QUERIED_KEY, None)
        request = tensordict.pop(LABEL_REQUEST_KEY, None)
        wanted = mode if request is None else mode | request.reshape(mode.shape).bool()
        consulted = tensordict.pop(CONSULTED_KEY, None)
        if self.expert is None:
            if not bool((~mode).all()):
                raise RuntimeError("ExpertSwitch: the gate asked for the expert but no expert source is connected")
            assert learner is not None  # the robot is in control (without a learner the check above raised)
            expert_action = torch.full_like(learner, float("nan"))
        elif queried is not None:
            expert_action = queried
        elif self.expert.labels_every_step or bool(wanted.any()):
            expert_action = self.expert.get_action(tensordict).to(mode.device)
        else:
            assert learner is not None  # nobody wants the expert: the learner is in control
            expert_action = torch.full_like(learner, float("nan"))
        action = expert_action if learner is None else torch.where(mode, expert_action, learner)
        previous = self._previous
        is_init = tensordict.get("is_init", None)
        if previous is None or previous.shape != mode.shape:
            previous = torch.zeros_like(mode)
        if is_init is not None:
            previous = previous & ~is_init
        person = getattr(self.expert, "labelled", None) if self.expert is not None else None
        labelled = wanted if self.expert is not None else torch.zeros_like(mode)
        if person is not None and person.numel() == mode.numel():
            labelled = labelled & person.reshape(mode.shape).to(mode.device)
        asked = wanted if consulted is None else wanted | consulted.reshape(mode.shape).bool()
        tensordict.set("expert_labelled", labelled)
        tensordict.set("expert_queried", asked if self.expert is not None else torch.zeros_like(mode))
        tensordict.set("expert_action", expert_action)
        tensordict.set("action", action)
        tensordict.set("intervention", mode & ~previous)
        self._previous = mode.clone()
        return tensordict

    def reset_history(self) -> None:
        """Forget the previous mode (start of a collection round)."""
        self._previous = None
