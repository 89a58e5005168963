from typing import Any

import pytest
import torch
from tensordict import TensorDict

from dpiil_rl.methods.thrifty_dagger import ThriftyGate
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.success_critic import CriticTargets, SuccessCritic
from dpiil_rl.modules.threshold import FixedThreshold, QuantileThreshold
from tests.mocks.constant_expert import ConstantExpert, ConstantPerson

LOW, HIGH = torch.tensor([-1.0, -1.0]), torch.tensor([1.0, 1.0])


def _critic() -> SuccessCritic:
    torch.manual_seed(0)
    return SuccessCritic(LOW, HIGH, LOW, HIGH, hidden=[64, 64])


def test_critic_learns_where_the_robot_failed_by_temporal_differences():
    # two-step episodes: from x < 0 the first step (any action) leads to s' = (x, 0.5), from where the
    # policy's action succeeds only when x > 0 (to the right); left of 0 it collides
    g = torch.Generator().manual_seed(0)
    x = torch.rand(4000, 1, generator=g) * 2 - 1
    s0 = torch.cat([x, torch.zeros_like(x)], -1)
    s1 = torch.cat([x, torch.full_like(x, 0.5)], -1)
    a = torch.zeros(4000, 2)
    ok = (x > 0).float()
    obs, act = torch.cat([s0, s1]), torch.cat([a, a])
    nxt = torch.cat([s1, s1])
    success = torch.cat([torch.zeros_like(ok), ok])
    done = torch.cat([torch.zeros_like(ok), torch.ones_like(ok)])
    critic = _critic()
    critic.fit(
        obs,
        act,
        nxt,
        torch.zeros_like(act),
        success,
        done,
        FitSettings(steps=1500, batch_size=256, lr=3e-3),
        CriticTargets(gamma=0.9, tau=0.05, positive_fraction=0.1),
        g,
    )
    q = critic(torch.tensor([[0.6, 0.0], [-0.6, 0.0], [0.6, 0.5], [-0.6, 0.5]]), torch.zeros(4, 2)).reshape(-1)
    assert q[2] > 0.8 and q[3] < 0.2  # one step from the end: success / failure
    assert 0.7 < q[0] < 1.0 and q[1] < 0.25  # one step earlier: discounted (γ = 0.9) success / failure


def _gate(expert_action):
    gate = ThriftyGate(_critic(), ConstantExpert(expert_action), FixedThreshold(1e-3), QuantileThreshold(0.8))
    gate.chi.fill_(1e-3)
    gate.chi_risk.fill_(0.9)
    gate.chi_back.fill_(0.9)
    gate.delta_back.fill_(0.01)
    return gate


def _td(var, action, first):
    return TensorDict(
        {
            "observation": torch.zeros(1, 2),
            "policy_action": torch.tensor([action]),
            "action_var": torch.tensor([[var]]),
            "is_init": torch.tensor([[first]]),
        },
        batch_size=[1],
    )


def test_novelty_hands_over_and_control_returns_only_when_the_robot_agrees_with_the_expert():
    gate = _gate([0.5, 0.0])
    assert not bool(gate(_td(1e-4, [0.5, 0.0], True))["expert_mode"])  # familiar state: robot drives
    assert bool(gate(_td(5e-3, [0.5, 0.0], False))["expert_mode"])  # novel: expert takes over
    td = gate(_td(1e-4, [-0.5, 0.0], False))  # familiar again, but the robot disagrees with the expert
    assert bool(td["expert_mode"]) and "queried_expert_action" in td.keys()
    assert not bool(gate(_td(1e-4, [0.45, 0.0], False))["expert_mode"])  # agrees (gap 0.0025 < δ): hands back


def test_with_a_person_control_returns_only_once_they_drive_and_agree():
    person = ConstantPerson([0.0, 0.0], driving=False)
    gate = _gate([0.0, 0.0])
    gate.expert = person
    assert bool(gate(_td(5e-3, [0.02, 0.0], True))["expert_mode"])  # novel: asks the person
    # familiar again and the slow policy "agrees" with the person's still device (gap 4e-4 < δ), but they
    # have not taken the robot yet: the robot keeps waiting for them
    assert bool(gate(_td(1e-4, [0.02, 0.0], False))["expert_mode"])
    person.driving = True  # they drive, commanding what the policy proposes: hand back
    assert not bool(gate(_td(1e-4, [0.02, 0.0], False))["expert_mode"])


def test_calibration_sets_novelty_quantile_and_switch_back_gap():
    gate = ThriftyGate(_critic(), ConstantExpert([0.0, 0.0]), QuantileThreshold(0.8), QuantileThreshold(0.8))
    var = torch.linspace(0, 1, 101).reshape(-1, 1)
    td = TensorDict(
        {"action_var": var, "policy_action": torch.full((101, 2), 0.1), "expert_action": torch.zeros(101, 2)},
        batch_size=[101],
    )
    out = gate.calibrate(td)
    assert abs(out["chi"] - 0.8) < 1e-6 and abs(out["thrifty/delta_back"] - 0.02) < 1e-6
    risk = torch.linspace(0, 1, 101)
    out = gate.calibrate_risk(risk)
    assert abs(out["thrifty/chi_risk"] - 0.8) < 1e-6 and abs(out["thrifty/chi_back"] - 0.5) < 1e-6


def test_q_is_the_smallest_of_the_critics_networks():
    torch.manual_seed(3)
    critic = SuccessCritic(LOW, HIGH, LOW, HIGH, hidden=[8], q_networks=3)
    obs, act = torch.rand(5, 2), torch.rand(5, 2)
    each = torch.sigmoid(critic.logits(obs, act))
    assert each.shape == (3, 5, 1)
    assert torch.equal(critic(obs, act), each.amin(0))


def test_robot_step_thresholds_follow_the_states_the_robot_drove():
    gate = ThriftyGate(
        _critic(),
        ConstantExpert([0.0, 0.0]),
        FixedThreshold(1.0),
        FixedThreshold(1.0),
        threshold_source="robot_steps",
        target_rate=0.2,
    )
    gate.chi.fill_(1.0)
    gate.start_round(1, "interactive")
    var = torch.linspace(0.0, 1e-3, 40)
    for t, v in enumerate(var):  # one robot-driven episode of 40 steps: σ² grows
        gate(_td(float(v), [0.0, 0.0], t == 0))
    assert float(gate.chi) == 1.0  # not refreshed before the episode ends
    gate(_td(0.0, [0.0, 0.0], True))  # the next episode starts: χ_n = 0.8-quantile of the 40 robot-driven σ²
    assert abs(float(gate.chi) - float(torch.quantile(var.double(), 0.8))) < 1e-9
    state = gate.state_dict()
    other = ThriftyGate(
        _critic(), ConstantExpert([0.0, 0.0]), FixedThreshold(1.0), FixedThreshold(1.0), threshold_source="robot_steps"
    )
    other.load_state_dict(state)
    assert sum(t.numel() for t in other._robot_novelty) == 41  # the round's statistics survive a pause
    gate.start_round(2, "interactive")
    assert gate._robot_novelty == []


def test_bad_thrifty_options_are_named():
    from dpiil_rl.methods.thrifty_dagger import ThriftyDAgger

    critic = {
        "hidden": [8],
        "q_networks": 2,
        "gamma": 0.9999,
        "tau": 0.01,
        "positive_fraction": 0.1,
        "fit": {"steps": 5},
    }
    for key, value, message in (
        ("threshold_source", "data", "method.threshold_source = 'data'"),
        ("target_rate", 1.0, "method.target_rate = 1.0"),
        ("autonomous_rollouts", -1, "method.autonomous_rollouts = -1"),
    ):
        option: dict[str, Any] = {key: value}
        with pytest.raises(ValueError, match=message):
            ThriftyDAgger("thrifty_dagger", QuantileThreshold(0.8), QuantileThreshold(0.8), critic, **option)


def test_autonomous_rollouts_are_recorded_and_feed_the_critic(tmp_path):
    from hydra import compose, initialize_config_dir

    from dpiil_rl.records.metrics import run_summary
    from dpiil_rl.records.run_files import read_jsonl
    from dpiil_rl.training.factory import build_trainer
    from tests.conftest import ROOT

    with initialize_config_dir(str(ROOT / "configs"), version_base="1.3"):
        cfg = compose(
            "config",
            overrides=[
                "method=thrifty_dagger_authors",
                "experiment=smoke",
                "protocol.iterations=1",
                "method.autonomous_rollouts=3",
            ],
        )
    trainer = build_trainer(cfg, tmp_path)
    trainer.train()
    rows = read_jsonl(tmp_path / "episodes.jsonl")
    rollouts = [r for r in rows if r["phase"] == "rollout"]
    assert [r["iteration"] for r in rollouts] == [0, 0, 0]  # after the demos' refit; none after the last iteration
    assert all(r["expert_steps"] == 0 and r["expert_control_steps"] == 0 for r in rollouts)
    steps = sum(r["length"] for r in rows if r["phase"] in ("demo", "interactive", "rollout"))
    assert (
        trainer.experience is not None and len(trainer.experience) == steps
    )  # every executed transition, the rollouts' included
    assert run_summary(rows)["rollout_episodes"] == 3
