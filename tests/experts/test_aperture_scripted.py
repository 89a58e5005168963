import torch
from tensordict.nn import TensorDictSequential

from dpiil_rl.collectors.expert_switch import ExpertSwitch
from dpiil_rl.collectors.intervention import InterventionCollector, run_episodes
from dpiil_rl.envs.aperture import ApertureEnv
from dpiil_rl.experts.scripted import ScriptedExpert
from dpiil_rl.modules.gate import ConstantGate
from dpiil_rl.training.factory import build_env


def test_expert_succeeds_nearly_always_with_paper_like_length(aperture_cfg):
    env = build_env(aperture_cfg, 300, seed=7)
    expert = ScriptedExpert(env, seed=7)
    collector = InterventionCollector(
        env, TensorDictSequential([ConstantGate(True), ExpertSwitch(expert)]), expert=expert
    )
    with torch.no_grad():
        rows = [e.record for e in run_episodes(collector, 300, "demo", 0)]
    success = sum(r["success"] for r in rows) / len(rows)
    length = sum(r["length"] for r in rows if r["success"]) / max(1, sum(r["success"] for r in rows))
    assert success >= 0.98
    assert 70 <= length <= 95  # paper: ≈ 83 steps per demo (248 pairs in 3 demos)


def test_slow_and_steady_where_clearance_is_small(aperture_cfg):
    env = build_env(aperture_cfg, 1, seed=0)
    policy = ScriptedExpert(env).policy
    narrow = torch.tensor([[15.0, 10.0]])  # centre of the 1.5 cm aperture
    medium = torch.tensor([[5.0, 10.0]])  # centre of the 3.0 cm aperture
    open_ = torch.tensor([[10.0, 15.0]])  # open space above the walls
    speeds = [float(policy.nominal_speed(p)) for p in (narrow, medium, open_)]
    assert speeds[0] < speeds[1] < speeds[2]
    g = torch.Generator().manual_seed(0)
    spread = [float(torch.stack([policy(p, g) for _ in range(400)]).std(0).mean()) for p in (narrow, open_)]
    assert spread[0] < 0.5 * spread[1]  # signal-dependent noise: less variance when slow
    # speed is a smooth function of clearance: no jumps along a line into the aperture
    line = torch.stack([torch.full((200,), 15.0), torch.linspace(6.0, 9.2, 200)], -1)
    assert policy.nominal_speed(line).diff().abs().max() < 0.02


def test_expert_recovers_from_off_route_states(aperture_cfg):
    """A DAgger expert must label any state a learner reaches: start from scattered positions."""
    env = build_env(aperture_cfg, 64, seed=3)
    expert = ScriptedExpert(env, seed=3)
    td = env.reset()
    g = torch.Generator().manual_seed(0)
    starts = torch.cat(
        [
            torch.rand(32, 2, generator=g) * torch.tensor([8.0, 8.0]) + 1,  # start room
            torch.rand(32, 2, generator=g) * torch.tensor([18.0, 7.0]) + torch.tensor([1.0, 11.5]),
        ]
    )  # top
    base = env.base_env
    assert isinstance(base, ApertureEnv)
    base._position = starts
    td["observation"] = starts
    done = torch.zeros(64, dtype=torch.bool)
    success = torch.zeros(64, dtype=torch.bool)
    for _ in range(200):
        td["action"] = expert.get_action(td)
        td = env.step(td)
        nxt = td["next"]
        success |= nxt["success"].squeeze(-1) & ~done
        done |= nxt["done"].squeeze(-1)
        td = nxt.clone()
        if done.all():
            break
    assert success.float().mean() >= 0.95
