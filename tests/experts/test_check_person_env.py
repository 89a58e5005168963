"""A person-driven source refuses a batch of robots and an action of the wrong size, naming both."""

import pytest

from dpiil_rl.envs.factory import make_env
from dpiil_rl.experts.base import check_person_env


def test_one_robot_with_the_right_action_passes(aperture_cfg) -> None:
    check_person_env(make_env(aperture_cfg, num_envs=1, seed=0), "mouse", 2, "a 2-D velocity")


def test_a_batch_of_robots_is_refused(aperture_cfg) -> None:
    with pytest.raises(
        ValueError, match=r"expert=mouse: protocol.interactive_envs = 3: a person drives one robot, expected 1"
    ):
        check_person_env(make_env(aperture_cfg, num_envs=3, seed=0), "mouse")


def test_a_wrong_action_size_is_named(aperture_cfg) -> None:
    with pytest.raises(
        ValueError, match=r"expert=gamepad commands the 6-D action; env action has 2 dimensions, expected 6"
    ):
        check_person_env(make_env(aperture_cfg, num_envs=1, seed=0), "gamepad", 6, "the 6-D action")
