import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.modules.supervisor_noise import SupervisorNoise

LOW, HIGH = torch.tensor([-1.0, -0.1]), torch.tensor([1.0, 0.1])


def _td(mode):
    n = len(mode)
    return TensorDict(
        {"action": torch.full((n, 2), 0.05), "expert_mode": torch.tensor(mode).reshape(n, 1)}, batch_size=[n]
    )


def test_only_the_experts_executed_action_is_perturbed_within_the_spec():
    noise = SupervisorNoise(LOW, HIGH, std=0.5, seed=0)
    out = noise(_td([True, False] * 500))
    expert, robot = out["action"][0::2], out["action"][1::2]
    assert torch.equal(robot, torch.full((500, 2), 0.05))  # the robot's own action is left alone
    assert (expert >= LOW).all() and (expert <= HIGH).all()  # clipped to the action spec
    # scaled per dim: std 0.5 of the half-range (1.0 and 0.1); the narrow dim is clipped often
    assert 0.4 < float(expert[:, 0].std()) < 0.6
    assert float(expert[:, 1].std()) < 0.1


def test_zero_noise_changes_nothing_and_a_negative_one_is_refused():
    td = _td([True, True])
    assert torch.equal(SupervisorNoise(LOW, HIGH, std=0.0, seed=0)(td)["action"], torch.full((2, 2), 0.05))
    with pytest.raises(ValueError, match="method.supervisor_noise = -0.1"):
        SupervisorNoise(LOW, HIGH, std=-0.1, seed=0)


def test_the_random_stream_is_saved_and_restored():
    a = SupervisorNoise(LOW, HIGH, std=0.3, seed=1)
    a(_td([True] * 4))
    state = a.state_dict()
    expected = a(_td([True] * 4))["action"]
    b = SupervisorNoise(LOW, HIGH, std=0.3, seed=99)
    b.load_state_dict(state)
    assert torch.equal(b(_td([True] * 4))["action"], expected)
