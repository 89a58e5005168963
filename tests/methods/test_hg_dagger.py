import pytest
import torch
from omegaconf import OmegaConf
from tensordict import TensorDict

from dpiil_rl.envs.factory import make_env
from dpiil_rl.experts.scripted import ScriptedExpert
from dpiil_rl.methods.hg_dagger import HGDAgger
from tests.conftest import plain
from tests.mocks.constant_expert import ConstantExpert


@pytest.fixture
def gate(aperture_cfg):
    env = make_env(aperture_cfg, num_envs=1, seed=0)
    return HGDAgger("hg_dagger").make_gate(env, ScriptedExpert(env, seed=0))


def _td(positions, actions, first=True):
    n = len(positions)
    return TensorDict(
        {
            "observation": torch.tensor(positions, dtype=torch.float32),
            "policy_action": torch.tensor(actions, dtype=torch.float32),
            "is_init": torch.full((n, 1), first),
        },
        batch_size=[n],
    )


def test_expert_takes_over_before_a_collision_and_when_the_learner_goes_astray(gate):
    # (5, 8.3) is below the 3 cm aperture of the first wall (y = 9.5..10.5, gap x = 3.5..6.5)
    mode = (
        gate(
            _td([[4.0, 8.7], [5.0, 6.0], [5.0, 6.0], [5.0, 6.0]], [[-0.3, 0.3], [0.0, 0.4], [0.0, -0.4], [0.0, 0.01]])
        )["expert_mode"]
        .reshape(-1)
        .tolist()
    )
    # heading into the wall corner | on course | reversing (astray) | stalling
    assert mode == [True, False, True, True]


def test_conservative_expert_keeps_control_in_narrow_places_and_hands_back_in_the_open(gate):
    gate(_td([[15.0, 9.0], [5.0, 5.0]], [[0.0, 0.4], [0.0, -0.4]]))  # both start astray: expert takes over
    # next step: the learner now agrees with the expert; one is inside the 1.5 cm aperture, one in the open
    td = _td([[15.0, 10.0], [5.0, 5.0]], [[0.0, -0.1], [0.0, 0.4]], first=False)
    assert gate(td)["expert_mode"].reshape(-1).tolist() == [True, False]


def test_a_source_that_cannot_judge_is_named():
    gate = HGDAgger("hg_dagger").make_gate(None, ConstantExpert([0.0, 0.0]))
    with pytest.raises(NotImplementedError, match="ConstantExpert cannot decide when to take over"):
        gate(_td([[5.0, 5.0]], [[0.0, 0.1]]))


def test_takeover_rule_is_validated(aperture_cfg):
    cfg = plain(aperture_cfg)
    cfg["expert"]["takeover"]["release_angle_deg"] = 0.0
    env = make_env(OmegaConf.create(cfg), num_envs=1, seed=0)
    with pytest.raises(ValueError, match="takeover.release_angle_deg = 0.0"):
        ScriptedExpert(env, seed=0)
