"""The ring task's scripted careful person: threads the ring on real simulations, slows near the peg."""

import pytest
import torch

from dpiil_rl.envs.ring import RingEnv
from dpiil_rl.envs.ring_task import RING_STAGES, RingState, handle_position
from dpiil_rl.experts.base import ExpertSource
from dpiil_rl.experts.ring_scripted import Phase, RingScriptedPolicy
from dpiil_rl.experts.scripted import ScriptedExpert
from dpiil_rl.training.factory import build_env, make_expert
from tests.conftest import ROOT, load_config, plain


def scripted_policy(expert: ExpertSource) -> RingScriptedPolicy:
    """The state-machine policy of the ring task's scripted expert."""
    assert isinstance(expert, ScriptedExpert) and isinstance(expert.policy, RingScriptedPolicy)
    return expert.policy


@pytest.fixture(scope="module")
def episodes():
    cfg = load_config(ROOT / "configs" / "env" / "ring.yaml")
    env = build_env(cfg, 2, seed=11)  # two simulations in two worker processes
    expert = make_expert(load_config(ROOT / "configs" / "expert" / "scripted.yaml"), env, seed=5)
    policy = scripted_policy(expert)
    rows, speeds = [], {p: [] for p in Phase}
    stages: list[list[int]] = [[], []]  # the env's stage at every step of the episode in progress
    td = env.reset()
    expert.reset(torch.ones(2, dtype=torch.bool))
    length = torch.zeros(2, dtype=torch.long)
    try:
        while len(rows) < 4:
            td["action"] = expert.get_action(td)
            phase = policy.phase.clone()
            td, nxt = env.step_and_maybe_reset(td)
            length += 1
            step = (td["next", "eef_pos"] - td["eef_pos"]).norm(dim=-1)
            for i in range(2):
                speeds[Phase(int(phase[i]))].append(float(step[i]))
                stages[i].append(int(td["next", "stage"][i]))
            done = td["next", "done"].reshape(2)
            for i in done.nonzero().reshape(-1).tolist():
                rows.append((bool(td["next", "success"][i]), int(length[i]), stages[i]))
                length[i] = 0
                stages[i] = []
            if bool(done.any()):
                expert.reset(done)
            td = nxt
    finally:
        env.close()
    return rows, speeds


def test_threads_the_ring(episodes):
    rows, _ = episodes
    assert sum(ok for ok, _, _ in rows) >= 3, rows  # measured: 100 of 100 (make bench, bench/results.json)
    assert all(length < 200 for ok, length, _ in rows if ok)


def test_a_threaded_episode_passes_every_stage_in_order(episodes):
    rows, _ = episodes
    for ok, _, stages in rows:
        if not ok:
            continue
        assert sorted(set(stages)) == list(range(len(RING_STAGES))), stages  # reach, grasped, lifted, at_peg, threaded
        first_visit = [stages.index(k) for k in range(len(RING_STAGES))]
        assert first_visit == sorted(first_visit), stages
        assert stages[-1] == RING_STAGES.index("threaded") and max(stages[:-1]) < stages[-1], stages


def test_slower_where_clearance_is_small(episodes):
    _, speeds = episodes
    mean = {p: sum(v) / len(v) for p, v in speeds.items() if v}
    assert mean[Phase.INSERT] < 0.6 * mean[Phase.TRANSPORT], mean  # over the peg vs carrying it in the open
    assert mean[Phase.DESCEND] < mean[Phase.REACH], mean


def test_bad_expert_settings_name_the_value():
    from dpiil_rl.envs.ring_task import RingGeometry
    from dpiil_rl.experts.ring_scripted import RingScriptedPolicy

    spec = {
        k: v for k, v in plain(load_config(ROOT / "configs" / "env" / "ring.yaml"))["expert"].items() if k != "_target_"
    }
    with pytest.raises(ValueError, match="transport_z = 0.9"):
        RingScriptedPolicy(RingGeometry(), **{**spec, "transport_z": 0.9})
    with pytest.raises(ValueError, match="speed_min = 0.8"):
        RingScriptedPolicy(RingGeometry(), **{**spec, "speed_min": 0.8, "speed_max": 0.5})


def test_hg_dagger_takeover_rule():
    """The expert takes over when the learner strays and hands back when it agrees, away from the peg."""
    cfg = load_config(ROOT / "configs" / "env" / "ring.yaml")
    env = build_env(cfg, 1, seed=3)
    expert = make_expert(load_config(ROOT / "configs" / "expert" / "scripted.yaml"), env, seed=3)
    try:
        td = env.reset()
        expert.reset(torch.ones(1, dtype=torch.bool))
        own = scripted_policy(expert).command(td["observation"])
        free, held = torch.zeros(1, 1, dtype=torch.bool), torch.ones(1, 1, dtype=torch.bool)
        td["policy_action"] = own.clone()
        assert not bool(expert.wants_control(td, free))  # the learner does what the expert would
        assert not bool(expert.wants_control(td, held))  # ... so the expert hands back (far from the peg)
        wrong = own.clone()
        wrong[:, :3] = -own[:, :3].sign() * 0.8  # moving away from the handle
        td["policy_action"] = wrong
        assert bool(expert.wants_control(td, free))
        closing = own.clone()
        closing[:, 5] = 1.0  # closing the gripper while still reaching
        td["policy_action"] = closing
        assert bool(expert.wants_control(td, free))
    finally:
        env.close()


def test_takes_over_a_ring_the_robot_already_holds():
    """Handed control mid-task (its memory says REACH), the expert carries on instead of letting go."""
    cfg = load_config(ROOT / "configs" / "env" / "ring.yaml")
    env = build_env(cfg, 1, seed=21)
    expert = make_expert(load_config(ROOT / "configs" / "expert" / "scripted.yaml"), env, seed=21)
    policy = scripted_policy(expert)
    try:
        td = env.reset()
        expert.reset(torch.ones(1, dtype=torch.bool))
        for _ in range(200):
            td["action"] = expert.get_action(td)
            td = env.step(td)["next"]
            if int(policy.phase[0]) == Phase.TRANSPORT:
                break
        assert int(policy.phase[0]) == Phase.TRANSPORT
        expert.reset(torch.ones(1, dtype=torch.bool))  # a fresh expert: as if the robot had done the grasp
        command = policy.command(td["observation"])
        assert int(policy.phase[0]) in (Phase.LIFT, Phase.TRANSPORT) and float(command[0, 5]) == 1.0  # keeps holding
    finally:
        env.close()


def test_handed_control_over_the_handle_it_keeps_descending():
    """Over the handle, below the hover point, a fresh expert (memory says REACH) acts as one that descended
    there itself (no climb back to the hover point): the label of a state does not depend on who brought
    the gripper there."""
    cfg = load_config(ROOT / "configs" / "env" / "ring.yaml")
    env = build_env(cfg, 1, seed=21)
    expert = make_expert(load_config(ROOT / "configs" / "expert" / "scripted.yaml"), env, seed=21)
    policy = scripted_policy(expert)
    base = env.base_env
    assert isinstance(base, RingEnv)
    geometry = base.geometry
    try:
        td = env.reset()
        expert.reset(torch.ones(1, dtype=torch.bool))
        checked = down = 0
        for _ in range(120):
            own = policy.command(td["observation"])
            state = RingState(td["observation"])
            height = float(state.eef_pos[0, 2] - handle_position(state, geometry)[0, 2])
            if int(policy.phase[0]) == Phase.DESCEND and 0.015 < height < 0.06:
                saved = (policy.phase.clone(), policy.closing.clone())
                policy.reset(torch.ones(1, dtype=torch.bool))
                fresh = policy.command(td["observation"].clone())
                assert torch.allclose(fresh, own), (height, fresh, own)  # the same action, whatever its memory
                assert (
                    float(fresh[0, 2]) <= 0 and float(fresh[0, 5]) == -1.0
                )  # never up; open until at the grasp height
                policy.phase, policy.closing = saved
                policy._last_obs = None
                checked += 1
                down += float(fresh[0, 2]) < 0
            td["action"] = expert.get_action(td)
            td = env.step(td)["next"]
        assert checked >= 3 and down >= 1  # several steps of the descent were checked, and it went down
    finally:
        env.close()
