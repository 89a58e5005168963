"""The ring task's TorchRL env on real robosuite / MuJoCo simulations (no mocks)."""

import subprocess
import sys

import pytest
import torch
from omegaconf import OmegaConf
from torchrl.envs.utils import check_env_specs

from dpiil_rl.envs.factory import make_env
from dpiil_rl.envs.ring_task import STATE_DIM, STATE_SLICES, RingGeometry
from tests.conftest import ROOT, load_config, merged, plain


@pytest.fixture(scope="module")
def ring_cfg():
    return load_config(ROOT / "configs" / "env" / "ring.yaml")


def _with(cfg, **changes):
    return merged(cfg, changes)


@pytest.fixture(scope="module")
def env(ring_cfg):
    env = make_env(ring_cfg, num_envs=1, seed=0)
    yield env
    env.close()


def test_check_env_specs(env):
    check_env_specs(env)
    assert env.observation_spec["observation"].shape[-1] == STATE_DIM == 51
    assert env.action_spec.shape[-1] == 6


def test_first_observation_has_the_ring_relative_state(env):
    obs = env.reset()["observation"][0]
    rel = obs[STATE_SLICES["RoundNut_to_robot0_eef_pos"]]
    assert rel.abs().sum() > 0.01  # robosuite leaves these at zero until the first step; the env computes them
    ring = obs[STATE_SLICES["RoundNut_pos"]]
    assert abs(float(ring[2]) - 0.83) < 0.003  # laid on the table (0.82 m) instead of dropped from 6 cm


def test_same_seed_same_start_and_partial_reset(ring_cfg):
    a = make_env(_with(ring_cfg, workers=0), num_envs=2, seed=7)
    b = make_env(_with(ring_cfg, workers=2), num_envs=2, seed=7)  # the same two episodes from worker processes
    try:
        ta, tb = a.reset(), b.reset()
        assert torch.allclose(ta["observation"], tb["observation"], atol=1e-5)
        assert not torch.allclose(ta["observation"][0], ta["observation"][1])  # two different ring placements
        ta["action"] = torch.zeros(2, 6)
        moved = a.step(ta)["next"].clone()
        moved["_reset"] = torch.tensor([[True], [False]])
        out = a.reset(moved)
        assert torch.equal(out["observation"][1], moved["observation"][1])  # the other env keeps its state
        assert int(out["step_count"][0]) == 0 and int(out["step_count"][1]) == 1
    finally:
        a.close()
        b.close()


def test_pressing_the_gripper_into_the_table_is_a_collision_and_horizon_ends(ring_cfg):
    env = make_env(ring_cfg, num_envs=1, seed=0)
    try:
        td = env.reset()
        hits, done_at = 0, None
        for t in range(ring_cfg.max_steps):
            td["action"] = torch.tensor([[0.0, 0.0, -1.0, 0.0, 0.0, -1.0]])  # straight down, gripper open
            td = env.step(td)
            hits += int(td["next", "collision"].item())
            if td["next", "done"].item():
                done_at = t + 1
                break
            td = td["next"]
        assert hits > 0
        assert (
            done_at == ring_cfg.max_steps
            and bool(td["next", "truncated"].item())
            and not bool(td["next", "success"].item())
        )
    finally:
        env.close()


def test_bad_geometry_names_the_value(ring_cfg):
    spec = plain(ring_cfg)
    spec["ring_inner_radius"] = 0.01
    with pytest.raises(ValueError, match="ring_inner_radius = 0.01"):
        make_env(OmegaConf.create(spec), num_envs=1)
    spec = plain(ring_cfg)
    spec["table_z"] = 0.9
    with pytest.raises(ValueError, match="table_z = 0.9"):
        make_env(OmegaConf.create(spec), num_envs=1)
    spec = plain(ring_cfg)
    spec["workers"] = -1
    with pytest.raises(ValueError, match="workers = -1"):
        make_env(OmegaConf.create(spec), num_envs=2)
    spec = plain(ring_cfg)
    spec["observation_bounds"].pop("robot0_joint_vel")
    with pytest.raises(ValueError, match="robot0_joint_vel"):
        RingGeometry.from_mapping(
            {k: v for k, v in spec.items() if k not in ("_target_", "name", "workers", "sim", "expert")}
        )


def test_the_aperture_task_never_loads_robosuite():
    # TorchRL 0.14's torchrl.envs imports its own MuJoCo envs (and so the mujoco bindings) whenever
    # mujoco is installed; what the lazy import saves is robosuite and every simulation.
    code = (
        "import sys, dpiil_rl.envs.ring, dpiil_rl.experts.ring_scripted\n"
        "from omegaconf import OmegaConf\n"
        "from dpiil_rl.envs.factory import make_env\n"
        "make_env(OmegaConf.load('configs/env/aperture.yaml'), num_envs=2).rollout(3)\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('robosuite', 'numba')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True)


@pytest.mark.parametrize("task", ["ring", "shaft"])
def test_building_a_robosuite_env_prints_none_of_its_import_notices(task):
    """robosuite's import-time warnings (macro file, robosuite_models, mink) would repeat in every worker."""
    code = (
        "from hydra import compose, initialize_config_dir\n"
        "from dpiil_rl.envs.factory import make_env\n"
        "with initialize_config_dir(config_dir='" + str(ROOT / "configs") + "', version_base='1.3'):\n"
        f"    cfg = compose('config', overrides=['env={task}']).env\n"
        "env = make_env(cfg, num_envs=1, seed=0)\n"
        "env.reset()\n"
        "env.close()\n"
        "print('built')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True, timeout=300
    )
    assert "built" in out.stdout
    for notice in ("No private macro file", "robosuite_models", "mink"):
        assert notice not in out.stdout + out.stderr


def test_every_step_says_the_stage_of_the_task(env):
    td = env.reset()
    assert env.stage_names == ("reach", "grasped", "lifted", "at_peg", "threaded")
    assert int(td["stage"]) == 0
    td["action"] = torch.zeros(1, 6)
    assert int(env.step(td)["next", "stage"]) == 0  # the ring lies on the table, the gripper is open
