import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.collectors.expert_switch import LABEL_REQUEST_KEY, ExpertSwitch
from dpiil_rl.methods.dagger_beta import DAggerBeta
from dpiil_rl.modules.beta_schedule import ConstantBeta, ExponentialBeta, LinearBeta
from tests.mocks.constant_expert import ConstantExpert


def test_schedules_follow_ross_and_imitation():
    assert [ExponentialBeta(0.5)(k) for k in range(4)] == [1.0, 0.5, 0.25, 0.125]
    assert [ExponentialBeta(0.0)(k) for k in range(3)] == [1.0, 0.0, 0.0]  # pure DAgger after the demos
    assert [LinearBeta(4)(k) for k in range(6)] == [1.0, 0.75, 0.5, 0.25, 0.0, 0.0]
    assert [ConstantBeta(0.3)(k) for k in range(3)] == [1.0, 0.3, 0.3]


@pytest.mark.parametrize("cls,arg", [(ExponentialBeta, 1.5), (ConstantBeta, -0.1), (LinearBeta, 0)])
def test_bad_schedules_are_named(cls, arg):
    with pytest.raises(ValueError, match="method.beta_schedule"):
        cls(arg)


def test_the_expert_drives_a_share_beta_and_every_state_is_labelled():
    torch.manual_seed(0)
    gate = DAggerBeta("dagger_beta", beta_schedule=ExponentialBeta(0.5)).make_gate()
    gate.start_round(2, "interactive")  # β = 0.25
    n = 4000
    td = TensorDict(
        {
            "observation": torch.zeros(n, 2),
            "policy_action": torch.zeros(n, 2),
            "is_init": torch.zeros(n, 1, dtype=torch.bool),
        },
        [n],
    )
    td = gate(td)
    assert abs(float(td["expert_mode"].float().mean()) - 0.25) < 0.02
    assert bool(td[LABEL_REQUEST_KEY].all())
    td = ExpertSwitch(ConstantExpert([0.5, -0.5]))(td)
    assert bool(td["expert_labelled"].all()) and bool(td["expert_queried"].all())  # every state is an expert label
    mode = td["expert_mode"].reshape(n)
    assert torch.equal(td["action"][mode], td["expert_action"][mode])
    assert bool((td["action"][~mode] == 0).all())  # the learner drives the rest


def test_the_random_stream_is_saved_with_the_gate():
    torch.manual_seed(1)
    gate = DAggerBeta("dagger_beta", beta_schedule=ConstantBeta(0.5)).make_gate()
    gate.start_round(1, "interactive")
    td = TensorDict({"observation": torch.zeros(16, 2)}, [16])
    state = gate.state_dict()
    a = gate(td.clone())["expert_mode"]
    gate.load_state_dict(state)
    assert torch.equal(gate(td.clone())["expert_mode"], a)
