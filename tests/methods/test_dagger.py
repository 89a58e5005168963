import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.methods.dagger import DAgger


def _run_gate(gate, envs: int, steps: int) -> torch.Tensor:
    td = TensorDict({"observation": torch.zeros(envs, 2), "is_init": torch.zeros(envs, 1, dtype=torch.bool)}, [envs])
    modes = []
    for t in range(steps):
        td["is_init"] = torch.full((envs, 1), t == 0)
        modes.append(gate(td)["expert_mode"].reshape(envs).clone())
    return torch.stack(modes, 1)  # [envs, steps]


def test_random_takeovers_match_the_expert_share_and_segment_length():
    torch.manual_seed(0)
    method = DAgger("dagger", expert_share=0.2, mean_segment_steps=10)
    modes = _run_gate(method.make_gate(), envs=400, steps=400)[:, 100:]  # after burn-in
    assert abs(float(modes.float().mean()) - 0.2) < 0.02
    starts = (modes[:, 1:] & ~modes[:, :-1]).sum()
    assert abs(float(modes[:, 1:].sum()) / float(starts) - 10) < 1.5  # mean expert segment ≈ 10 steps


def test_per_step_coin_flip_when_segments_last_one_step():
    torch.manual_seed(1)
    modes = _run_gate(DAgger("dagger", expert_share=0.3, mean_segment_steps=1).make_gate(), 300, 200)
    assert abs(float(modes.float().mean()) - 0.3) < 0.02


def test_random_stream_is_saved_with_the_gate():
    torch.manual_seed(2)
    gate = DAgger("dagger").make_gate()
    _run_gate(gate, 8, 5)
    state = gate.state_dict()
    a = _run_gate(gate, 8, 50)
    gate.load_state_dict(state)
    assert torch.equal(_run_gate(gate, 8, 50), a)


@pytest.mark.parametrize("share", [0.0, 1.0, 1.5])
def test_bad_share_is_named(share):
    with pytest.raises(ValueError, match=f"method.expert_share = {share}"):
        DAgger("dagger", expert_share=share)
