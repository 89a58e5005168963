"""Wrong-typed config values named by their key: ``protocol.iterations = 'abc': expected an integer``.

A value's expected type is the type of the same key in the config composed with the same groups (env,
method, experiment, ...) and no value overrides — the YAML defaults the user changed. A key whose default
is null takes its type from :data:`NULLABLE` (matched by pattern); keys the user added (``++key=value``)
and ``_target_`` keys are not checked. Numbers are accepted where a string is expected (a study named 2024).
"""

from __future__ import annotations

import fnmatch
from typing import Any, cast

from omegaconf import DictConfig, ListConfig, OmegaConf, open_dict

#: the type of keys whose default is null (``float`` also accepts integers), by full key pattern
NULLABLE: dict[str, type] = {
    "chi": float,
    "*.fit.epochs": float,
    "env.barriers.*.aperture_center": float,
    "env.barriers.*.aperture_width": float,
    "env.robot.tcp_offset": list,
    "expert.mocap.natnet_version": str,
    "expert.mocap.mocap_to_robot": dict,
    "mocap_to_robot": dict,
    "natnet_version": str,
    "expert.view": bool,
    "expert.product_id": int,
    "expert.device.product_id": int,
    "out": str,
    "run_dir": str,
    "iteration": int,
}
NAMES = {
    bool: "true or false",
    int: "an integer",
    float: "a number",
    str: "a string",
    list: "a list",
    dict: "a mapping",
}


def _kind(value: Any) -> type | None:
    if value is None:
        return None
    if isinstance(value, bool):
        return bool
    if isinstance(value, int):
        return int
    if isinstance(value, float):
        return float
    if isinstance(value, str):
        return str
    if isinstance(value, (list, tuple, ListConfig)):
        return list
    if isinstance(value, (dict, DictConfig)):
        return dict
    return type(value)


def accepts(expected: type, value: Any) -> bool:
    """Whether ``value`` is of the ``expected`` kind (null is always accepted: every key may be unset)."""
    got = _kind(value)
    if got is None or got is expected or value == "???":  # unset (null, or a mandatory value not given yet)
        return True
    if expected is float and got is int:
        return True
    return expected is str and got in (int, float)


def _expected(key: str, default: Any) -> type | None:
    kind = None if default == "???" else _kind(default)  # a mandatory value (???) has no default to learn from
    if kind is not None:
        return kind
    for pattern, t in NULLABLE.items():
        if fnmatch.fnmatchcase(key, pattern):
            return t
    return None


def _container(cfg: Any) -> Any:
    try:
        return OmegaConf.to_container(cfg, resolve=True)
    except Exception:  # an interpolation a wrong value broke: compare the raw values
        return OmegaConf.to_container(cfg, resolve=False)


def flatten(node: Any, prefix: str = "") -> dict[str, Any]:
    """Every key of a plain config container by its full dotted path (mappings and their leaves)."""
    out: dict[str, Any] = {}
    if isinstance(node, dict):
        for k, v in node.items():
            key = f"{prefix}.{k}" if prefix else str(k)
            out[key] = v
            if isinstance(v, dict):
                out.update(flatten(v, key))
    return out


def check_types(cfg: DictConfig, reference: DictConfig) -> None:
    """Raise ``ValueError`` naming the first key of ``cfg`` whose value is not of the type of ``reference``'s."""
    check_values(
        flatten(_container(cfg)),
        flatten(_container(reference)),
        flatten(OmegaConf.to_container(reference, resolve=False)),
    )


def check_values(given: dict[str, Any], defaults: dict[str, Any], raw: dict[str, Any]) -> None:
    """:func:`check_types` on flattened containers: ``given`` values, resolved ``defaults``, unresolved ``raw``."""
    for key, value in given.items():
        if key.split(".")[-1] == "_target_" or key.startswith("hydra") or _interpolated(raw, key):
            continue  # an interpolation repeats another key, which is checked itself
        default = defaults.get(key, _MISSING)
        if default is _MISSING:
            continue  # a key the user added, or one the defaults do not hold
        expected = _expected(key, default)
        if expected is None or (expected is dict and isinstance(value, dict)):
            continue  # no type known, or a mapping whose keys are checked one by one
        if not accepts(expected, value):
            raise ValueError(f"{key} = {value!r}: expected {NAMES.get(expected, expected.__name__)}")
        if expected is list and isinstance(default, list) and isinstance(value, list) and default:
            kinds = {_kind(v) for v in default}
            if len(kinds) == 1 and (element := kinds.pop()) in (int, float, bool, str):
                for i, item in enumerate(value):
                    if not accepts(element, item):
                        raise ValueError(f"{key}[{i}] = {item!r}: expected {NAMES[element]} (a list of them)")


_MISSING = object()


def _interpolated(raw: dict[str, Any], key: str) -> bool:
    """Whether ``key`` or a mapping above it is an interpolation in the unresolved config."""
    parts = key.split(".")
    return any(isinstance(v := raw.get(".".join(parts[:i])), str) and "${" in v for i in range(1, len(parts) + 1))


def reference_config() -> DictConfig | None:
    """The running Hydra app's config composed with the same group choices and no value overrides; None
    outside a Hydra app."""
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.hydra_config import HydraConfig
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.types import RunMode

    if not HydraConfig.initialized() or not GlobalHydra.instance().is_initialized():
        return None
    hc = HydraConfig.get()
    choices = {str(k) for k in hc.runtime.choices}
    overrides = list(hc.overrides.task)
    groups = [
        cast(str, o.input_line)  # a parsed override keeps the line it came from
        for o in OverridesParser.create().parse_overrides(overrides)
        if o.get_key_element().lstrip("+~") in choices and not o.get_key_element().startswith("hydra")
    ]
    loader = GlobalHydra.instance().config_loader()
    composed = loader.load_configuration(str(hc.job.config_name), overrides=groups, run_mode=RunMode.RUN)
    with open_dict(composed):
        composed.pop("hydra", None)
    return composed


def check_config_types(cfg: DictConfig) -> None:
    """:func:`check_types` against :func:`reference_config` (does nothing outside a Hydra app)."""
    reference = reference_config()
    if reference is not None:
        check_types(cfg, reference)
