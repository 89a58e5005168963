"""The arm tasks' scripted careful person: reaches the shaft and threads the ring on the simulated UR5e,
slows where the clearance is small, recovers from any state, and takes over (HG-DAgger) when it should."""

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from dpiil_rl.envs.shaft import ShaftEnv
from dpiil_rl.envs.shaft_task import STATE_SLICES
from dpiil_rl.experts.base import ExpertSource
from dpiil_rl.experts.scripted import ScriptedExpert
from dpiil_rl.experts.shaft_scripted import ShaftScriptedPolicy
from dpiil_rl.training.factory import build_env, make_expert
from tests.conftest import ROOT, load_config, plain

EXPERT = load_config(ROOT / "configs" / "expert" / "scripted.yaml")


def scripted_policy(expert: ExpertSource) -> ShaftScriptedPolicy:
    """The funnel policy of the arm tasks' scripted expert."""
    assert isinstance(expert, ScriptedExpert) and isinstance(expert.policy, ShaftScriptedPolicy)
    return expert.policy


def env_config(name: str, *overrides: str):
    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        return compose("config", overrides=[f"env={name}", *overrides]).env


def run_episodes(cfg, num_envs: int, episodes: int, seed: int):
    """Episodes of the scripted expert alone: (success, collision, length) rows and per-step (tcp, speed)."""
    env = build_env(cfg, num_envs, seed=seed)
    expert = make_expert(EXPERT, env, seed=seed)
    rows, steps = [], []
    length = torch.zeros(num_envs, dtype=torch.long)
    td = env.reset()
    try:
        while len(rows) < episodes:
            td["action"] = expert.get_action(td)
            td, nxt = env.step_and_maybe_reset(td)
            length += 1
            speed = (td["next", "tcp_pos"] - td["tcp_pos"]).norm(dim=-1) / 0.05
            steps += list(zip(td["tcp_pos"].tolist(), speed.tolist()))
            for i in td["next", "done"].reshape(-1).nonzero().reshape(-1).tolist():
                rows.append((bool(td["next", "success"][i]), bool(td["next", "collision"][i]), int(length[i])))
                length[i] = 0
            td = nxt
    finally:
        env.close()
    return rows, steps


@pytest.fixture(scope="module")
def shaft_cfg():
    return env_config("shaft")


@pytest.fixture(scope="module")
def shaft_runs(shaft_cfg):
    return run_episodes(shaft_cfg, 2, 4, seed=11)


def test_reaches_the_shaft_without_contact(shaft_runs):
    rows, _ = shaft_runs
    assert all(ok and not hit for ok, hit, _ in rows), rows  # measured: 100 of 100 (seed 0), 54 steps on average
    assert all(30 <= length < 100 for _, _, length in rows), rows


def test_slower_in_the_channel_than_in_the_open(shaft_runs, shaft_cfg):
    _, steps = shaft_runs
    plate_top = 0.14
    channel = [v for (x, _, z), v in steps if abs(x - 0.5) < 0.02 and z < plate_top + 0.02]
    open_ = [v for (x, _, z), v in steps if x < 0.42 and z > 0.17]
    assert channel and open_
    assert np.mean(channel) < 0.5 * np.mean(open_), (np.mean(channel), np.mean(open_))


@pytest.mark.parametrize(
    "start",
    [(0.49, 0.03, 0.13), (0.40, 0.0, 0.12), (0.60, -0.12, 0.30)],
    ids=["in-channel-off-axis", "low-before-the-plate", "beyond-the-channel-high"],
)
def test_recovers_from_off_route_states(shaft_cfg, start):
    cfg = OmegaConf.merge(shaft_cfg, {"start": {"position": list(start), "noise": 0.0}})
    rows, _ = run_episodes(cfg, 1, 1, seed=2)
    assert rows[0][:2] == (True, False), rows


def test_funnel_rises_before_moving_sideways_near_an_obstacle(shaft_cfg):
    env = build_env(shaft_cfg, 1, seed=0)
    try:
        policy = scripted_policy(make_expert(EXPERT, env, seed=0))
        obs = env.reset()["observation"].clone()
        tcp = STATE_SLICES["tcp"]
        obs[0, tcp] = torch.tensor([0.42, 0.0, 0.12])  # fingers 0.7 cm from the near plate, 2.5 cm below its top
        low = policy.command(obs)[0]
        assert low[2] > 0.04 and low[0] == 0.0  # straight up, not into the plate
        obs[0, tcp] = torch.tensor([0.508, 0.0, 0.13])  # in the channel, 8 mm off the axis (beyond the aligned band)
        inside = policy.command(obs)[0]
        assert inside[0] < 0 and abs(inside[2]) < 1e-6  # re-centres at constant height
        g = torch.Generator().manual_seed(0)
        start = env.reset()["observation"]  # in the open, 20 cm before the channel
        fast = torch.stack([policy(start, g) for _ in range(200)]).std(0).mean()
        slow = torch.stack([policy(obs, g) for _ in range(200)]).std(0).mean()
        assert slow < 0.5 * fast  # signal-dependent noise: steadier where slow
    finally:
        env.close()


def test_threads_the_ring_on_the_real_robot_setting():
    rows, _ = run_episodes(env_config("ring_real"), 2, 2, seed=4)
    assert all(ok and not hit and length < 200 for ok, hit, length in rows), rows  # measured: 10 of 10, ~134 steps


def test_hg_dagger_takeover_rule(shaft_cfg):
    env = build_env(shaft_cfg, 1, seed=3)
    try:
        expert = make_expert(EXPERT, env, seed=3)
        td = env.reset()
        own = scripted_policy(expert).command(td["observation"])
        free, held = torch.zeros(1, 1, dtype=torch.bool), torch.ones(1, 1, dtype=torch.bool)
        td["policy_action"] = own.clone()
        assert not bool(expert.wants_control(td, free)) and not bool(expert.wants_control(td, held))
        td["policy_action"] = -own
        assert bool(expert.wants_control(td, free))  # heading the other way
        narrow = td["observation"].clone()
        narrow[0, STATE_SLICES["tcp"]] = torch.tensor([0.5, 0.0, 0.13])  # in the channel
        td["observation"], td["policy_action"] = narrow, scripted_policy(expert).command(narrow)
        assert bool(expert.wants_control(td, free))  # it does the narrow part itself
    finally:
        env.close()


def test_bad_expert_settings_name_the_value(shaft_cfg):
    env = build_env(shaft_cfg, 1, seed=0)
    env.close()
    assert isinstance(env.base_env, ShaftEnv)
    geometry = env.base_env.geometry
    spec = {k: v for k, v in plain(shaft_cfg.expert).items() if k != "_target_"}
    with pytest.raises(ValueError, match="speed_min = 0.9"):
        ShaftScriptedPolicy(geometry, **{**spec, "speed_min": 0.9})
    with pytest.raises(ValueError, match="aim = "):
        ShaftScriptedPolicy(geometry, **{**spec, "aim": [0.0, 0.0, 0.05]})
    with pytest.raises(ValueError, match="gates.plates.half_width"):
        ShaftScriptedPolicy(
            geometry, **{**spec, "gates": {"plates": {"height": 0.04, "half_width": [0.01], "band": 0.0}}}
        )
