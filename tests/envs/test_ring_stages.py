"""How far a ring episode got: the stage of a state, from the 51-D state alone (no simulation)."""

import math

import pytest
import torch

from dpiil_rl.envs.ring_task import (
    GRIPPER_CLOSED_QPOS,
    GRIPPER_EMPTY_QPOS,
    RING_STAGES,
    STATE_DIM,
    STATE_SLICES,
    RingGeometry,
    ring_stage,
)

G = RingGeometry()
REST_Z = G.table_z + G.ring_half_height


def state(ring=(0.0, 0.0, REST_Z), eef=(0.0, 0.2, 1.0), finger=0.0, yaw=0.0):
    """A 51-D state with the ring at ``ring`` (turned by ``yaw``), the gripper at ``eef``, first finger at
    ``finger``."""
    obs = torch.zeros(STATE_DIM)
    obs[STATE_SLICES["RoundNut_pos"]] = torch.tensor(ring)
    obs[STATE_SLICES["RoundNut_quat"]] = torch.tensor([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    obs[STATE_SLICES["robot0_eef_pos"]] = torch.tensor(eef)
    obs[STATE_SLICES["robot0_gripper_qpos"]][0] = finger
    return obs


def handle(ring, yaw=0.0):
    return (ring[0] + G.handle_offset * math.cos(yaw), ring[1] + G.handle_offset * math.sin(yaw), ring[2])


def stage_name(obs, success=False):
    return RING_STAGES[int(ring_stage(obs.unsqueeze(0), torch.tensor([success]), G)[0])]


def test_stages_in_the_order_a_threading_passes_them():
    on_table = (0.0, 0.0, REST_Z)
    held_finger = (GRIPPER_CLOSED_QPOS + GRIPPER_EMPTY_QPOS) / 2
    assert stage_name(state(ring=on_table)) == "reach"
    assert stage_name(state(ring=on_table, eef=handle(on_table, 0.7), finger=held_finger, yaw=0.7)) == "grasped"
    lifted = (0.0, 0.0, 1.0)
    assert stage_name(state(ring=lifted, eef=handle(lifted), finger=held_finger)) == "lifted"
    over_peg = (G.round_peg_xy[0] + 0.02, G.round_peg_xy[1], 0.97)
    assert stage_name(state(ring=over_peg, eef=handle(over_peg), finger=held_finger)) == "at_peg"
    assert stage_name(state(ring=over_peg), success=True) == "threaded"


@pytest.mark.parametrize(
    "finger, eef_offset, why",
    [
        (0.0, 0.0, "gripper open"),
        (0.52, 0.0, "fingers shut on nothing"),
        ((GRIPPER_CLOSED_QPOS + GRIPPER_EMPTY_QPOS) / 2, 0.06, "closed beside the handle"),
    ],
)
def test_not_grasped(finger, eef_offset, why):
    ring = (0.0, 0.0, REST_Z)
    h = handle(ring)
    assert stage_name(state(ring=ring, eef=(h[0], h[1] + eef_offset, h[2]), finger=finger)) == "reach", why


def test_a_ring_pushed_past_the_peg_on_the_table_is_not_at_the_peg():
    beside = (G.round_peg_xy[0], G.round_peg_xy[1] + 0.01, REST_Z)
    assert stage_name(state(ring=beside)) == "reach"
    far = (G.round_peg_xy[0] + 0.05, G.round_peg_xy[1], 1.0)
    assert stage_name(state(ring=far)) == "lifted"
