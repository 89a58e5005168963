"""The arm-reaching tasks' TorchRL env (env=shaft, env=ring_real) on the simulated UR5e (no mocks)."""

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf
from torchrl.envs.utils import check_env_specs

from dpiil_rl.envs.factory import make_env
from dpiil_rl.envs.shaft import ShaftEnv
from dpiil_rl.envs.shaft_task import STATE_SLICES
from tests.conftest import ROOT, merged, plain


def env_config(name: str, *overrides: str):
    """The env block of the composed run config (the robot backend comes from the env's defaults)."""
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        return compose("config", overrides=[f"env={name}", *overrides]).env


@pytest.fixture(scope="module")
def shaft_cfg():
    return env_config("shaft")


@pytest.fixture(scope="module")
def env(shaft_cfg):
    env = make_env(shaft_cfg, num_envs=2, seed=0)
    yield env
    env.close()


def test_check_env_specs_and_keys(env):
    check_env_specs(env)
    assert isinstance(env, ShaftEnv) and env.position_key == "tcp_pos"
    assert env.observation_spec["observation"].shape[-1] == 12 and env.action_spec.shape[-1] == 3
    td = env.reset()
    assert torch.equal(td["tcp_pos"], td["observation"][:, STATE_SLICES["tcp"]])
    target = torch.tensor(env.geometry.target_position, dtype=torch.float32)
    assert torch.allclose(td["observation"][:, STATE_SLICES["target"]], target.expand(2, 3))  # the shaft's xyz


def test_same_seed_same_starts_within_the_noise_box_and_partial_reset(shaft_cfg):
    a = make_env(shaft_cfg, num_envs=2, seed=7)
    b = make_env(shaft_cfg, num_envs=2, seed=7)
    try:
        ta, tb = a.reset(), b.reset()
        assert torch.equal(ta["observation"], tb["observation"])
        assert not torch.allclose(ta["tcp_pos"][0], ta["tcp_pos"][1])
        offset = ta["tcp_pos"] - torch.tensor(shaft_cfg.start.position)
        assert float(offset.abs().max()) <= shaft_cfg.start.noise + 1e-3
        ta["action"] = torch.tensor([[0.5, 0.0, 0.0], [0.0, 0.5, 0.0]])
        moved = a.step(ta)["next"].clone()
        assert not torch.allclose(moved["tcp_pos"], ta["tcp_pos"])
        moved["_reset"] = torch.tensor([[True], [False]])
        out = a.reset(moved)
        assert torch.equal(out["observation"][1], moved["observation"][1])  # the other env keeps its state
        assert int(out["step_count"][0]) == 0 and int(out["step_count"][1]) == 1
        assert not torch.allclose(out["tcp_pos"][0], ta["tcp_pos"][0])  # a new start for the reset env
    finally:
        a.close()
        b.close()


def run_from(cfg, start, policy, steps: int) -> dict:
    """One episode from ``start`` (TCP, no noise) under ``policy(td) -> action``: its last step's flags."""
    env = make_env(merged(cfg, {"start": {"position": [float(v) for v in start], "noise": 0.0}}), num_envs=1, seed=0)
    try:
        td = env.reset()
        for _ in range(steps):
            td["action"] = policy(env, td)
            td = env.step(td)["next"]
            if bool(td["done"]):
                break
        return {key: bool(td[key]) for key in ("success", "collision", "done")}
    finally:
        env.close()


def straight_at_goal(env, td):
    error = torch.tensor(env.geometry.goal_position, dtype=torch.float32) - td["tcp_pos"]
    return (error / error.norm(dim=-1, keepdim=True) * 0.6).clamp(-1, 1)  # 0.15 m/s straight at the grasp position


@pytest.mark.parametrize("corner", [(-1, -1, -1), (1, 1, 1)], ids=["far-low", "near-high"])
def test_a_straight_line_reach_collides(shaft_cfg, corner):
    """The scene constrains: heading straight for the grasp position from the start box's corners hits a plate."""
    start = np.array(shaft_cfg.start.position) + np.array(corner) * shaft_cfg.start.noise
    assert run_from(shaft_cfg, start, straight_at_goal, 150) == {"success": False, "collision": True, "done": True}


def test_zero_action_times_out(shaft_cfg):
    env = make_env(merged(shaft_cfg, {"max_steps": 4}), num_envs=1, seed=0)
    try:
        td = env.rollout(10, break_when_any_done=True)
        assert td.shape[-1] == 4 and bool(td["next", "truncated"][..., -1, 0]) and not bool(td["next", "success"].any())
    finally:
        env.close()


def test_ring_real_clearance_is_two_millimetres():
    """The held ring slides down the peg when centred and touches it (a failure) when 2.5 mm off its axis."""
    cfg = env_config("ring_real")
    env = make_env(cfg, num_envs=1)
    assert isinstance(env, ShaftEnv)
    geometry = env.geometry
    env.close()
    assert geometry.scene.held[0].inner_radius - geometry.scene.target.size[0] == pytest.approx(0.002, abs=1e-5)
    peg = geometry.target_position
    above = np.array([peg[0], peg[1], 0.115]) - np.array(cfg.tool_offset)  # the ring's centre 1.5 cm above the peg top
    down = lambda env, td: torch.tensor([[0.0, 0.0, -0.1]])  # noqa: E731  (2.5 cm/s)
    assert run_from(cfg, above, down, 60) == {"success": True, "collision": False, "done": True}
    assert run_from(cfg, above + [0.0025, 0.0, 0.0], down, 60) == {"success": False, "collision": True, "done": True}


def test_bad_task_names_the_value(shaft_cfg):
    spec = plain(shaft_cfg, resolve=True)
    bad = {**spec, "start": {**spec["start"], "noise": 0.3}}
    with pytest.raises(ValueError, match="env.start.position"):
        make_env(OmegaConf.create(bad), num_envs=1)
    bad = {**spec, "goal": {**spec["goal"], "depth": [0.01, -0.01]}}
    with pytest.raises(ValueError, match="env.goal.depth"):
        make_env(OmegaConf.create(bad), num_envs=1)
    bad = {**spec, "robot": {"scene": spec["scene"]}}
    with pytest.raises(ValueError, match="env.robot"):
        make_env(OmegaConf.create(bad), num_envs=1)


def test_real_robot_config_composes_and_names_an_unreachable_robot(tmp_path):
    """`robot@env.robot=ur5e_real`: the ur_rtde backend behind the safety layer; no robot here, so building
    the env fails at connect with a message naming the host."""
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base=None):
        cfg = compose(
            "config",
            overrides=[
                "env=shaft",
                "robot@env.robot=ur5e_real",
                "env.robot.backend.host=127.0.0.1",
                "env.robot.backend.connect_timeout=0.5",
                f"env.robot.log.path={tmp_path / 's.jsonl'}",
            ],
        )
    assert cfg.env.robot._target_.endswith("SafeRobot") and cfg.env.robot.backend.host == "127.0.0.1"
    assert list(cfg.env.robot.limits.low) == [-0.35, -0.70, 0.03]
    from dpiil_rl.robots.interface import RobotUnavailable

    with pytest.raises(RobotUnavailable, match="UR5e at 127.0.0.1 cannot be reached: cannot open the RTDE port 30004"):
        make_env(cfg.env, num_envs=1, seed=0)
