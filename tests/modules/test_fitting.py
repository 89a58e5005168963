import pytest

from dpiil_rl.modules.fitting import FitSettings


def test_fixed_budget_or_passes_over_the_data():
    assert FitSettings(steps=500).num_steps(10_000) == 500
    assert FitSettings(steps=500, epochs=2, batch_size=64).num_steps(1000) == 32  # ceil(2 * 1000 / 64)
    assert FitSettings(epochs=0.01, batch_size=64).num_steps(10) == 1


@pytest.mark.parametrize("epochs", [0, -1.0])
def test_bad_epochs_are_named(epochs):
    with pytest.raises(ValueError, match=f"epochs = {epochs}: expected a positive number"):
        FitSettings(epochs=epochs)


def test_unknown_schedule_is_named():
    with pytest.raises(ValueError, match="schedule = 'step': expected one of cosine, constant"):
        FitSettings(schedule="step")


def test_cosine_schedule_anneals_to_zero_at_the_last_step():
    import torch

    from dpiil_rl.modules.fitting import adam

    w = torch.nn.Parameter(torch.zeros(1))
    opt, scheduled = adam([w], FitSettings(lr=1e-2, schedule="cosine"), steps=10)
    rates = []
    for _ in range(10):
        rates.append(opt.param_groups[0]["lr"])
        opt.step()
        scheduled()
    assert rates[0] == pytest.approx(1e-2) and rates[5] == pytest.approx(5e-3)
    assert opt.param_groups[0]["lr"] == pytest.approx(0.0, abs=1e-12)
    opt, scheduled = adam([w], FitSettings(lr=1e-2, schedule="constant"), steps=10)
    for _ in range(10):
        opt.step()
        scheduled()
    assert opt.param_groups[0]["lr"] == pytest.approx(1e-2)


def test_a_small_dataset_gets_at_least_min_steps():
    assert FitSettings(epochs=100, batch_size=64, min_steps=1000).num_steps(250) == 1000  # 100 * 250 / 64 = 391
    assert FitSettings(epochs=100, batch_size=64, min_steps=1000).num_steps(1250) == 1954
    with pytest.raises(ValueError, match="min_steps = -1"):
        FitSettings(min_steps=-1)
