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
