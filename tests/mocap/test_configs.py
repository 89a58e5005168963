"""configs/mocap/*.yaml instantiate to working sources (Hydra ``_target_``), with only the overrides a user gives."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from hydra.utils import instantiate
from omegaconf import OmegaConf

from dpiil_rl.mocap.natnet import NatNetMocap
from dpiil_rl.mocap.replay import ReplayMocap
from dpiil_rl.mocap.trajectory import HandTrajectory, save_trajectory
from tests.mocks.natnet_sender import Body, MockMotive, pack_frame

CONFIGS = Path(__file__).resolve().parents[2] / "configs" / "mocap"


def test_natnet_yaml_streams_from_motive_in_the_robot_frame() -> None:
    cfg = OmegaConf.load(CONFIGS / "natnet.yaml")
    with MockMotive(natnet_version=(4, 1)) as motive:
        cfg.merge_with({"multicast": False, "local_interface": "127.0.0.1", "command_port": motive.command_port})
        source = instantiate(cfg)
        assert isinstance(source, NatNetMocap)
        with source:
            motive.send(pack_frame(1, [Body(1, (0.0, 1.0, 0.0))]))  # 1 m up in Motive's Y-up frame
            deadline = time.monotonic() + 2.0
            while source.latest() is None and time.monotonic() < deadline:
                time.sleep(0.002)
            pose = source.latest()
            assert pose is not None
            np.testing.assert_allclose(pose.position, [0.0, 0.0, 1.0], atol=1e-6)  # 1 m up along the robot's z


def test_replay_yaml_plays_a_file(tmp_path: Path) -> None:
    path = save_trajectory(
        tmp_path / "hand.csv", HandTrajectory(np.array([0.0, 0.01]), np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))
    )
    cfg = OmegaConf.load(CONFIGS / "replay.yaml")
    cfg.path = str(path)
    source = instantiate(cfg)
    assert isinstance(source, ReplayMocap) and not source.loop
    with source:
        assert source.latest() is not None
