import torch
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.collectors.stop_rules import EpisodeBudget, ExpertPairQuota
from dpiil_rl.data.buffer import buffer_contents, make_buffer
from dpiil_rl.training.factory import build_env
from tests.mocks.constant_expert import ConstantExpert
from tests.mocks.schedule_gate import ScheduleGate, ZeroActor

#            t: 0  1  2  3  4  5  6  7  8  9
SCHEDULE = [0, 1, 1, 0, 1, 0, 0, 1, 1, 1]  # 6 expert steps, 3 auto→expert switches


def _collector(aperture_cfg, tmp_path, num_envs=1, schedule=SCHEDULE, labels_every_step=True):
    aperture_cfg.max_steps = len(schedule)
    env = build_env(aperture_cfg, num_envs, seed=0)
    expert = ConstantExpert([0.1, 0.0], labels_every_step=labels_every_step)
    policy = TensorDictSequential([ZeroActor(), ScheduleGate([bool(s) for s in schedule]), ExpertSwitch(expert)])
    buffer = make_buffer(tmp_path, 1000)
    return InterventionCollector(env, policy, expert=expert, replay_buffer=buffer, keep_paths=True), buffer, expert


def test_stores_only_expert_frames_and_counts_interventions(aperture_cfg, tmp_path):
    collector, buffer, _ = _collector(aperture_cfg, tmp_path)
    (episode,) = list(collector.rollout(EpisodeBudget(1), "interactive", 1))
    r = episode.record
    assert (r["length"], r["expert_steps"], r["interventions"]) == (10, 6, 3)
    assert r["timeout"] and not r["success"] and not r["collision"]
    data = buffer_contents(buffer)
    assert data.shape[0] == 6
    assert torch.allclose(data["expert_action"], torch.tensor([0.1, 0.0]).expand(6, 2))
    assert torch.allclose(data["speed"], torch.full((6, 1), 0.01), atol=1e-6)  # ‖Δpos‖² of the expert's steps
    assert (data["iteration"] == 1).all()
    # the path shows the agent moved only in expert mode
    assert episode.positions is not None and episode.expert_mode is not None  # the collector keeps paths
    steps = episode.positions[1:] - episode.positions[:-1]
    moved = steps.norm(dim=-1) > 0
    assert moved.tolist() == [bool(s) for s in SCHEDULE]
    assert episode.expert_mode.tolist() == [bool(s) for s in SCHEDULE]


def test_expert_at_first_step_is_an_intervention_in_every_episode(aperture_cfg, tmp_path):
    collector, _, expert = _collector(aperture_cfg, tmp_path, schedule=[1, 1, 0, 1])
    episodes = list(collector.rollout(EpisodeBudget(3), "interactive", 1))
    assert [e.record["interventions"] for e in episodes] == [2, 2, 2]
    assert expert.resets >= 3


def test_quota_finishes_the_episode_in_progress(aperture_cfg, tmp_path):
    collector, buffer, _ = _collector(aperture_cfg, tmp_path)
    episodes = list(collector.rollout(ExpertPairQuota(8), "interactive", 2))
    assert len(episodes) == 2  # 6 pairs after the first episode (< 8): a second one runs to its end
    assert len(buffer) == 12
    assert [e.record["episode"] for e in episodes] == [0, 1]


def test_batched_env_runs_exactly_the_budget(aperture_cfg, tmp_path):
    collector, buffer, _ = _collector(aperture_cfg, tmp_path, num_envs=3)
    episodes = list(collector.rollout(EpisodeBudget(5), "interactive", 1))
    assert len(episodes) == 5
    assert all(e.record["expert_steps"] == 6 and e.record["interventions"] == 3 for e in episodes)
    assert len(buffer) == 30


def test_person_like_source_is_only_asked_while_in_control(aperture_cfg, tmp_path):
    collector, buffer, expert = _collector(aperture_cfg, tmp_path, schedule=[0, 0, 1, 1, 0], labels_every_step=False)
    (episode,) = list(collector.rollout(EpisodeBudget(1), "interactive", 1))
    assert expert.calls == 2 and len(buffer) == 2 and episode.record["interventions"] == 1


def test_a_staged_task_records_the_furthest_stage_reached():
    from torchrl.envs.utils import check_env_specs

    from tests.mocks.staged_env import StagedEnv

    env = StagedEnv(schedule=[0, 1, 2, 1, 0], stages=("reach", "grasped", "lifted"), num_envs=2)
    check_env_specs(env)
    policy = TensorDictSequential([ZeroActor(), ScheduleGate([False] * 5), ExpertSwitch(None)])
    episodes = list(InterventionCollector(env, policy).rollout(EpisodeBudget(3), "eval", 0))
    assert [e.record["stage"] for e in episodes] == ["lifted"] * 3  # the furthest, not where it ended
    assert [e.record["stage_index"] for e in episodes] == [2] * 3


def test_a_staged_path_gives_the_stage_each_step_was_decided_in():
    from tests.mocks.staged_env import StagedEnv

    env = StagedEnv(schedule=[0, 1, 2, 1, 0], stages=("reach", "grasped", "lifted"), num_envs=2)
    gate = [False, True, True, False, False]
    policy = TensorDictSequential([ZeroActor(), ScheduleGate(gate), ExpertSwitch(ConstantExpert([0.1, 0.0]))])
    episodes = list(InterventionCollector(env, policy, keep_paths=True).rollout(EpisodeBudget(3), "eval", 0))
    for episode in episodes:  # step t is decided in the state after t steps: the reset state (0), then schedule[t - 1]
        assert episode.stage is not None and episode.expert_mode is not None and episode.positions is not None
        assert episode.stage.tolist() == [0, 0, 1, 2, 1] and episode.expert_mode.tolist() == gate
        assert len(episode.stage) == len(episode.expert_mode) == len(episode.positions) - 1


def test_a_task_without_stages_records_none(aperture_cfg, tmp_path):
    collector, _, _ = _collector(aperture_cfg, tmp_path)
    (episode,) = list(collector.rollout(EpisodeBudget(1), "interactive", 1))
    assert "stage" not in episode.record and episode.stage is None


def test_bad_stage_names_are_named():
    import pytest

    from tests.mocks.staged_env import StagedEnv

    with pytest.raises(ValueError, match=r"stages = \['reach'\]"):
        StagedEnv(schedule=[0], stages=("reach",))


class _StopsAfter(ConstantExpert):
    """The session stops (Ctrl-C, a closed window) at the expert's ``calls``-th action."""

    def __init__(self, calls):
        super().__init__([0.1, 0.0])
        self.stop_at = calls

    def get_action(self, tensordict):
        if self.calls + 1 >= self.stop_at:
            raise KeyboardInterrupt("stopped")
        return super().get_action(tensordict)


def test_a_round_stopped_part_way_keeps_exactly_the_frames_of_the_episodes_it_handed_out(tmp_path):
    """Env 0's episode ends after 3 steps while env 1's is half-way; the round stops 2 steps later. Only
    env 0's 3 frames may be in the buffers: env 1's unfinished episode is run again on resume."""
    import pytest

    from tests.mocks.staged_env import StagedEnv

    env = StagedEnv(schedule=[0] * 6, stages=("reach", "done"), num_envs=2, lengths=[3, 6])
    expert = _StopsAfter(calls=6)
    policy = TensorDictSequential([ZeroActor(), ScheduleGate([True] * 6), ExpertSwitch(expert)])
    buffer, experience = make_buffer(tmp_path, 100), make_buffer(tmp_path, 100, "experience")
    collector = InterventionCollector(env, policy, expert=expert, replay_buffer=buffer, experience_buffer=experience)
    handed_out = []
    with pytest.raises(KeyboardInterrupt):
        for episode in collector.rollout(EpisodeBudget(4), "interactive", 1):
            handed_out.append(episode.record)
            assert len(buffer) == sum(r["expert_steps"] for r in handed_out)  # its frames are in as it is handed out
    assert [r["length"] for r in handed_out] == [3]
    assert len(buffer) == 3 and len(experience) == 3  # not env 1's 3 (or 4) steps of its unfinished episode


class _Requests(ScheduleGate):
    """The schedule decides who drives; a label is requested at every state and the expert is consulted on
    the ones listed in ``consult``."""

    def __init__(self, schedule, requests, consult):
        super().__init__(schedule)
        self.requests = torch.tensor(list(requests), dtype=torch.bool)
        self.consult = torch.tensor(list(consult), dtype=torch.bool)

    def forward(self, tensordict):
        from dpiil_rl.collectors.expert_switch import CONSULTED_KEY, LABEL_REQUEST_KEY

        tensordict = super().forward(tensordict)
        step = tensordict.get("step_count").clamp_max(len(self.schedule) - 1)
        tensordict.set(LABEL_REQUEST_KEY, self.requests[step])
        tensordict.set(CONSULTED_KEY, self.consult[step])
        return tensordict


def test_effort_counts_who_drove_what_was_labelled_and_what_the_expert_was_asked(aperture_cfg, tmp_path):
    drive = [0, 1, 1, 0, 0, 0]
    label = [0, 0, 0, 1, 1, 0]  # labels of two robot-driven states (a β-mixture labels them all)
    consult = [0, 0, 0, 0, 0, 1]  # one monitoring check
    aperture_cfg.max_steps = len(drive)
    env = build_env(aperture_cfg, 1, seed=0)
    expert = ConstantExpert([0.1, 0.0])
    gate = _Requests([bool(s) for s in drive], [bool(s) for s in label], [bool(s) for s in consult])
    buffer = make_buffer(tmp_path, 100)
    collector = InterventionCollector(
        env, TensorDictSequential([ZeroActor(), gate, ExpertSwitch(expert)]), expert=expert, replay_buffer=buffer
    )
    (episode,) = list(collector.rollout(EpisodeBudget(1), "interactive", 1))
    r = episode.record
    assert (r["expert_steps"], r["expert_control_steps"], r["expert_queries"]) == (4, 2, 5)
    data = buffer_contents(buffer)
    assert data["expert_drove"].tolist() == [True, True, False, False]  # the speed head learns the first two only
    assert (data["episode"] == r["episode"]).all()
