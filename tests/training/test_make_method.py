"""A task protocol's χ quantile (Table I: χ at 50%) reaches the methods that calibrate χ, and only them."""

from typing import Any, cast

import pytest

from dpiil_rl.methods.base import Method
from dpiil_rl.training.factory import make_method
from tests.conftest import ROOT, load_config


def _method(name):
    return load_config(ROOT / "configs" / "method" / f"{name}.yaml")


def _rule(method: Method) -> Any:
    """The χ rule of a method that has one."""
    return cast(Any, method).threshold


@pytest.mark.parametrize("name", ["dpiil_ucb", "dpiil_mu", "ensemble_dagger"])
def test_protocol_quantile_sets_the_threshold(name):
    assert _rule(make_method(_method(name), chi_quantile=0.5)).quantile == 0.5
    assert _rule(make_method(_method(name))).quantile != 0.5  # the method's own rule otherwise


def test_methods_without_chi_ignore_it():
    assert not hasattr(make_method(_method("bc"), chi_quantile=0.5), "threshold")


def test_a_fixed_chi_wins_over_the_quantile():
    method = make_method(_method("dpiil_ucb"), chi=1e-4, chi_quantile=0.5)
    assert not hasattr(_rule(method), "quantile")
