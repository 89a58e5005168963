import torch
from tensordict import TensorDict

from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings


def _actor(members=5):
    return EnsembleActor(
        torch.zeros(2), torch.full((2,), 10.0), -torch.ones(2), torch.ones(2), num_members=members, hidden=(32, 32)
    )


def test_outputs_mean_and_variance_of_members():
    actor = _actor()
    obs = torch.rand(7, 3, 2) * 10
    td = actor(TensorDict({"observation": obs}, batch_size=[7, 3]))
    members = td["action_members"]
    assert (
        members.shape == (7, 3, 5, 2) and td["policy_action"].shape == (7, 3, 2) and td["action_var"].shape == (7, 3, 1)
    )
    assert torch.allclose(td["policy_action"], members.mean(-2))
    assert torch.allclose(td["action_var"], members.var(-2, unbiased=False).mean(-1, keepdim=True))
    assert members.abs().max() <= 1.0  # inside the action spec's bounds


def test_fit_learns_and_uncertainty_grows_off_data():
    g = torch.Generator().manual_seed(0)
    obs = torch.rand(300, 2, generator=g) * 3 + 1  # data only in [1, 4]^2
    act = torch.stack([torch.sin(obs[:, 0]), torch.cos(obs[:, 1])], -1) * 0.5
    actor = _actor()
    losses = actor.fit(obs, act, FitSettings(steps=800, batch_size=64, lr=3e-3), g)
    assert losses[-1] < 0.1 * losses[0]
    td = actor(TensorDict({"observation": torch.tensor([[2.5, 2.5], [9.5, 9.5]])}, batch_size=[2]))
    assert td["action_var"][1] > 5 * td["action_var"][0]  # epistemic uncertainty far from the data


def test_reinit_with_the_same_generator_is_reproducible():
    obs, act = torch.rand(50, 2) * 10, torch.rand(50, 2) - 0.5
    a, b = _actor(), _actor()
    a.fit(obs, act, FitSettings(steps=20), torch.Generator().manual_seed(3))
    b.fit(obs, act, FitSettings(steps=20), torch.Generator().manual_seed(3))
    for pa, pb in zip(a.parameters(), b.parameters()):
        assert torch.equal(pa, pb)


def test_an_annealed_fit_ends_closer_to_the_data_than_a_constant_rate():
    """Two fits from different seeds on noisy labels: at a constant rate each ends wherever the last
    minibatches left it; annealed, both settle near the noise-free mean (docs/learner.md)."""
    g = torch.Generator().manual_seed(0)
    obs = torch.rand(400, 2, generator=g) * 10
    clean = 0.4 * torch.tanh(obs - 5.0)
    act = clean + 0.1 * torch.randn(400, 2, generator=g)

    def member_error(schedule: str) -> float:
        actor = _actor()
        actor.fit(
            obs,
            act,
            FitSettings(steps=600, batch_size=32, lr=1e-2, schedule=schedule),
            torch.Generator().manual_seed(1),
        )
        with torch.no_grad():
            members = actor.members(obs)  # [400, E, 2]
        return float(((members - clean.unsqueeze(1)) ** 2).mean())

    assert member_error("cosine") < 0.7 * member_error("constant")
