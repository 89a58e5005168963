"""SafetyLimits: the shipped config builds; anything that cannot be enforced is refused with a clear message."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from dpiil_rl.robots.safety_limits import SafetyLimits

ROOT = Path(__file__).resolve().parents[2]


def test_default_config_builds_sane_ur5e_limits() -> None:
    limits = instantiate(OmegaConf.load(ROOT / "configs" / "safety" / "default.yaml"))
    assert isinstance(limits, SafetyLimits)
    assert np.all(limits.low < limits.high)
    assert 0 < limits.max_speed <= 0.25 and limits.max_tracking_error == pytest.approx(0.05)
    assert limits.watchdog_timeout == pytest.approx(0.1)
    # the box can hold a stop from full speed along each axis (else the arm could never reach max_speed)
    assert np.all(limits.high - limits.low > limits.max_speed**2 / limits.max_acceleration)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"low": [0, 0, 0], "high": [1, 0, 1]}, ["low < high", "y"]),
        ({"low": [0, 0, 2], "high": [1, 1, 1]}, ["low < high", "z"]),
        ({"low": [0, 0], "high": [1, 1, 1]}, ["low=", "3 numbers"]),
        ({"low": [0, float("nan"), 0], "high": [1, 1, 1]}, ["low=", "finite"]),
        ({"low": [0, 0, 0], "high": [1, 1, float("inf")]}, ["high=", "finite"]),
        ({"low": [0, 0, 0], "high": ["a", 1, 1]}, ["high=", "3 numbers"]),
        ({"max_speed": 0.0}, ["max_speed=0.0", "> 0"]),
        ({"max_speed": -1.0}, ["max_speed=-1.0", "> 0"]),
        ({"max_acceleration": float("nan")}, ["max_acceleration=nan", "finite"]),
        ({"max_tracking_error": float("inf")}, ["max_tracking_error=inf", "finite"]),
        ({"watchdog_timeout": -0.1}, ["watchdog_timeout=-0.1", "> 0"]),
        ({"watchdog_timeout": "soon"}, ["watchdog_timeout='soon'", "positive number"]),
    ],
)
def test_bad_limits_are_refused_naming_the_value(kwargs: dict, words: list[str]) -> None:
    args = {"low": [0, 0, 0], "high": [1, 1, 1], **kwargs}
    with pytest.raises(ValueError) as info:
        SafetyLimits(**args)
    for word in words:
        assert word in str(info.value)


def test_contains_and_clamp() -> None:
    limits = SafetyLimits(low=np.zeros(3), high=np.ones(3))
    assert limits.contains([0.5, 0.5, 0.5]) and limits.contains([0.0, 1.0, 0.0])
    assert not limits.contains([1.5, 0.5, 0.5]) and not limits.contains([np.nan, 0.5, 0.5])
    np.testing.assert_allclose(limits.clamp([1.5, -2.0, 0.5]), [1.0, 0.0, 0.5])
    with pytest.raises(ValueError):
        limits.low[0] = 3.0  # the box cannot be changed behind the filter's back
    assert limits.to_dict()["high"] == [1.0, 1.0, 1.0]
