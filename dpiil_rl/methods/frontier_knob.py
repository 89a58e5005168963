"""A method's unit-free knob: the setting ``make frontier`` sweeps to trade the person's effort for safety.

Each method names its own in its YAML (``frontier:``): a quantile of the training data's risk for the risk
gates, a take-over rate for the DAgger variants, a take-over margin for HG-DAgger. A raw χ grid would
mean a different share of risky states for every method (their risks have different units), a knob like
these means the same thing for all of them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping


@dataclass(frozen=True)
class FrontierKnob:
    """``key`` (a full config key, e.g. ``method.threshold.quantile``) swept over ``values``; ``tied`` keys
    take the same value (ThriftyDAgger's two quantiles); ``label`` names the runs (``<method>-<label><value>``)."""

    key: str
    values: tuple[float, ...]
    label: str
    tied: tuple[str, ...] = ()

    @classmethod
    def from_config(cls, spec: Mapping[str, Any], method: str) -> "FrontierKnob":
        known = {"key", "values", "label", "tied"}
        unknown = sorted(set(spec) - known)
        if unknown:
            raise ValueError(
                f"method.frontier.{unknown[0]}: unknown key for method {method!r} (expected some of {sorted(known)})"
            )
        key = spec.get("key")
        if not isinstance(key, str) or "." not in key:
            raise ValueError(
                f"method.frontier.key = {key!r}: expected a full config key such as method.threshold.quantile"
            )
        values = spec.get("values")
        if (
            not isinstance(values, (list, tuple))
            or len(values) < 2
            or not all(isinstance(v, (int, float)) for v in values)
        ):
            raise ValueError(f"method.frontier.values = {values!r}: expected a list of at least two numbers")
        label = spec.get("label")
        if not isinstance(label, str) or not label:
            raise ValueError(f"method.frontier.label = {label!r}: expected a short name for run directories (e.g. q)")
        tied = tuple(spec.get("tied") or ())
        return cls(key, tuple(float(v) for v in values), label, tied)
