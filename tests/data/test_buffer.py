import torch
from tensordict import TensorDict

from dpiil_rl.data.buffer import buffer_contents, canonical_order, make_buffer, training_data
from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings


def _frames(n: int, seed: int = 0) -> TensorDict:
    g = torch.Generator().manual_seed(seed)
    return TensorDict(
        {
            "observation": torch.rand(n, 2, generator=g) * 10,
            "expert_action": torch.rand(n, 2, generator=g) - 0.5,
            "iteration": torch.randint(0, 3, (n,), generator=g),
        },
        batch_size=[n],
    )


def test_canonical_order_sorts_by_content_column_by_column():
    td = TensorDict(
        {"a": torch.tensor([[1.0], [0.0], [1.0]]), "b": torch.tensor([[2.0], [5.0], [1.0]])}, batch_size=[3]
    )
    assert canonical_order(td).tolist() == [1, 2, 0]  # by a, then by b


def test_the_same_frames_in_another_order_give_the_same_training_data_and_the_same_fit(tmp_path):
    frames = _frames(300)
    shuffled = frames[torch.randperm(300, generator=torch.Generator().manual_seed(5))]
    a, b = make_buffer(tmp_path / "a", 1000), make_buffer(tmp_path / "b", 1000)
    a.extend(frames[:120])  # two rounds ...
    a.extend(frames[120:])
    b.extend(shuffled)  # ... or one, in another order
    assert not torch.equal(buffer_contents(a)["observation"], buffer_contents(b)["observation"])
    da, db = training_data(a), training_data(b)
    assert (da == db).all()
    fits = []
    for data in (da, db):
        actor = EnsembleActor(
            torch.zeros(2), torch.full((2,), 10.0), -torch.ones(2), torch.ones(2), num_members=3, hidden=(16,)
        )
        actor.fit(data["observation"], data["expert_action"], FitSettings(steps=30), torch.Generator().manual_seed(2))
        fits.append(torch.cat([p.reshape(-1) for p in actor.parameters()]))
    assert torch.equal(fits[0], fits[1])
