"""Every key of every config group, given a value of the wrong type, is named with the value and the expected type."""

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from dpiil_rl.utils.config_types import _container, _expected, _interpolated, check_types, check_values, flatten
from tests.conftest import ROOT, run_script

GROUPS = ("env", "method", "expert", "logger", "experiment")


def _options():
    for group in GROUPS:
        for path in sorted((ROOT / "configs" / group).glob("*.yaml")):
            yield f"{group}={path.stem}"


def _wrong(expected):
    return {bool: "maybe", int: "abc", float: "abc", str: [1, 2], list: "abc", dict: 3}[expected]


ENTRY_CONFIGS = sorted(p.stem for p in (ROOT / "configs").glob("*.yaml") if p.stem != "config")


@pytest.mark.parametrize("choice", list(_options()) + [f"entry:{name}" for name in ENTRY_CONFIGS])
def test_every_key_of_the_group_names_a_wrong_type(choice):
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        if choice.startswith("entry:"):  # the other entry scripts' configs (report, evaluate, frontier, ...)
            reference = compose(choice[6:])
        else:
            reference = compose("config", overrides=[choice])
    defaults = flatten(_container(reference))
    raw = flatten(OmegaConf.to_container(reference, resolve=False))
    checked = 0
    for key, default in defaults.items():
        if key.endswith("_target_") or key.startswith("hydra") or _interpolated(raw, key):
            continue  # interpolations repeat another key
        expected = _expected(key, default)
        if expected is None or expected is dict:
            continue
        given = dict(defaults)
        given[key] = _wrong(expected)
        with pytest.raises(ValueError) as err:
            check_values(given, defaults, raw)
        assert str(err.value).startswith(f"{key} = ") and "expected" in str(err.value), (key, str(err.value))
        checked += 1
    assert checked >= (1 if choice.startswith("entry:") else 20)  # every group brings keys of its own


def test_right_types_pass_and_numbers_stand_for_strings():
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        reference = compose("config")
        cfg = compose("config", overrides=["study=2024", "protocol.iterations=3", "chi=1e-4", "modules.actor.fit.lr=1"])
    check_types(cfg, reference)


def test_the_command_line_names_the_key(tmp_path: Path):
    proc = run_script("train", "protocol.iterations=abc", f"hydra.run.dir={tmp_path}", "logger=none", check=False)
    assert proc.returncode == 2
    assert "error: protocol.iterations = 'abc': expected an integer" in proc.stderr
