import pytest
import torch
from omegaconf import OmegaConf
from torchrl.envs.utils import check_env_specs

from dpiil_rl.envs.aperture import ApertureEnv
from dpiil_rl.envs.aperture_geometry import ApertureGeometry, segment_rect_distance
from dpiil_rl.envs.factory import make_env


def test_check_env_specs(aperture_cfg):
    check_env_specs(make_env(aperture_cfg, num_envs=4, seed=0))
    check_env_specs(make_env(aperture_cfg, num_envs=1, seed=0))


def test_start_noise_and_partial_reset(aperture_cfg):
    env = make_env(aperture_cfg, num_envs=64, seed=1)
    td = env.reset()
    start = td["observation"]
    c = torch.tensor(aperture_cfg.start.center)
    assert (start - c).abs().max() <= aperture_cfg.start.noise + 1e-6
    assert (start - c).abs().max() > 0.5 * aperture_cfg.start.noise  # really perturbed
    td["action"] = torch.full((64, 2), 0.3)
    root = env.step(td)["next"].clone()
    moved = root["observation"].clone()
    mask = torch.zeros(64, 1, dtype=torch.bool)
    mask[:5] = True
    root["_reset"] = mask
    out = env.reset(root)
    assert torch.allclose(out["observation"][5:], moved[5:])  # untouched envs keep their state
    assert not torch.allclose(out["observation"][:5], moved[:5])


def _env_at(cfg, positions):
    env = make_env(cfg, num_envs=len(positions), seed=0)
    env.reset()
    env._position = torch.tensor(positions, dtype=torch.float32)
    return env


def test_wall_contact_fails_and_no_tunnelling(aperture_cfg):
    # first_wall spans y in [9.5, 10.5]; a max-speed step from y=9.0 to 10.0 ends inside the wall,
    # and a step along x from (2, 9.0) to (2.9, 9.0) passes at distance 0.5 > r: no contact.
    env = _env_at(aperture_cfg, [[2.0, 9.0], [2.0, 9.0], [2.0, 9.2]])
    td = env.reset()  # positions are overwritten by _env_at after reset: set them again
    env._position = torch.tensor([[2.0, 9.0], [2.0, 9.0], [2.0, 9.2]])
    td["action"] = torch.tensor([[0.0, 1.0], [0.9, 0.0], [0.0, 0.1]])
    nxt = env.step(td)["next"]
    assert nxt["collision"].squeeze(-1).tolist() == [True, False, True]  # 9.3 + 0.25 > 9.5: contact
    assert nxt["terminated"].squeeze(-1).tolist() == [True, False, True]


def test_thin_wall_cannot_be_tunnelled_through():
    geo = ApertureGeometry.from_mapping(
        {
            "arena": [0, 0, 10, 10],
            "goal": [8, 8, 9, 9],
            "start": {"center": [2, 2], "noise": 0.5},
            "agent_radius": 0.25,
            "max_speed": 5.0,
            "max_steps": 10,
            "barriers": {"thin": {"orientation": "vertical", "position": 5.0, "thickness": 0.01, "span": [0, 10]}},
        }
    )
    rects = geo.rectangles()
    p0 = torch.tensor([[4.0, 3.0], [4.0, 3.0], [4.0, 3.0]])
    p1 = torch.tensor([[6.0, 3.0], [4.8, 3.0], [4.74, 3.0]])  # across; stop 0.195 short; stop 0.255 short
    assert geo.segment_collides(p0, p1, rects).tolist() == [True, True, False]


def test_segment_distance_matches_dense_sampling():
    g = torch.Generator().manual_seed(0)
    rects = torch.tensor([[1.0, 1.0, 2.0, 3.0], [4.0, 0.0, 4.5, 5.0]])
    p0, p1 = torch.rand(200, 1, 2, generator=g) * 6, torch.rand(200, 1, 2, generator=g) * 6
    exact = segment_rect_distance(p0, p1, rects)
    t = torch.linspace(0, 1, 2001).reshape(1, -1, 1)
    pts = (p0 + t * (p1 - p0)).unsqueeze(-2)  # [200, 2001, 1, 2]
    dx = torch.clamp(torch.maximum(rects[:, 0] - pts[..., 0], pts[..., 0] - rects[:, 2]), min=0)
    dy = torch.clamp(torch.maximum(rects[:, 1] - pts[..., 1], pts[..., 1] - rects[:, 3]), min=0)
    sampled = torch.sqrt(dx**2 + dy**2).amin(1)
    assert torch.all(exact <= sampled + 1e-5)
    assert torch.allclose(exact, sampled, atol=6e-3)


def test_leaving_arena_and_goal(aperture_cfg):
    env = make_env(aperture_cfg, num_envs=2, seed=0)
    td = env.reset()
    env._position = torch.tensor([[0.3, 2.0], [15.0, 5.5]])
    td["action"] = torch.tensor([[-0.5, 0.0], [0.0, -0.8]])
    nxt = env.step(td)["next"]
    assert nxt["out_of_bounds"].squeeze(-1).tolist() == [True, False]
    assert nxt["success"].squeeze(-1).tolist() == [False, True]
    assert nxt["reward"].squeeze(-1).tolist() == [0.0, 1.0]


def test_timeout(aperture_cfg):
    aperture_cfg.max_steps = 3
    env = make_env(aperture_cfg, num_envs=1, seed=0)
    td = env.reset()
    for _ in range(3):
        td["action"] = torch.zeros(1, 2)
        td = env.step(td)
        nxt = td["next"]
        td = nxt.clone()
    assert bool(nxt["truncated"]) and bool(nxt["done"]) and not bool(nxt["terminated"])


def test_width_from_config_changes_the_walls(aperture_cfg):
    aperture_cfg.barriers.second_wall.aperture_width = 4.0
    env = make_env(aperture_cfg, num_envs=1, seed=0)
    assert isinstance(env, ApertureEnv)
    widths = dict(env.geometry.apertures())
    assert widths["second_wall"] == 4.0
    xs = sorted(r[2] for r in env.geometry.rectangles().tolist() if r[1] == 9.5 and r[0] >= 10)
    assert xs[0] == pytest.approx(13.0)


@pytest.mark.parametrize(
    "key,value,message",
    [
        ("barriers.second_wall.aperture_width", -1.5, "aperture_width = -1.5"),
        ("barriers.second_wall.aperture_width", 0.4, "narrower than the agent"),
        ("agent_radius", -0.25, "agent_radius = -0.25"),
        ("max_speed", 0.0, "max_speed = 0.0"),
        ("barriers.divider.orientation", "diagonal", "orientation = 'diagonal'"),
        ("arena", [0, 0, -1, 20], "env.arena"),
    ],
)
def test_bad_geometry_is_named(aperture_cfg, key, value, message):
    OmegaConf.update(aperture_cfg, key, value)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace("[", r"\[")):
        make_env(aperture_cfg, num_envs=1)
