"""A task protocol's χ quantile (Table I: χ at 50%) reaches the methods that calibrate χ, and only them."""

import pytest
from omegaconf import OmegaConf

from dpiil_rl.training.factory import make_method
from tests.conftest import ROOT


def _method(name):
    return OmegaConf.load(ROOT / "configs" / "method" / f"{name}.yaml")


@pytest.mark.parametrize("name", ["dpiil_ucb", "dpiil_mu", "ensemble_dagger"])
def test_protocol_quantile_sets_the_threshold(name):
    assert make_method(_method(name), chi_quantile=0.5).threshold.quantile == 0.5
    assert make_method(_method(name)).threshold.quantile != 0.5  # the method's own rule otherwise


def test_methods_without_chi_ignore_it():
    assert not hasattr(make_method(_method("bc"), chi_quantile=0.5), "threshold")


def test_a_fixed_chi_wins_over_the_quantile():
    method = make_method(_method("dpiil_ucb"), chi=1e-4, chi_quantile=0.5)
    assert not hasattr(method.threshold, "quantile")
