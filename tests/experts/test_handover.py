"""The hand-over protocol on its own: sync, follow while held, stop on release, policy, device loss."""

import pytest

from dpiil_rl.experts.handover import TRANSITIONS, Handover, HandoverEvent, HandoverMachine


def test_sync_follow_release_resync():
    m = HandoverMachine()
    assert m.fire(HandoverEvent.FOLLOW_START) is Handover.STOPPED  # B without A: nothing moves
    assert m.fire(HandoverEvent.SYNC) is Handover.SYNCED
    assert m.fire(HandoverEvent.FOLLOW_START) is Handover.FOLLOWING and m.moving
    assert m.fire(HandoverEvent.FOLLOW_END) is Handover.STOPPED and not m.moving
    assert m.fire(HandoverEvent.FOLLOW_START) is Handover.STOPPED  # released: must sync again
    m.fire(HandoverEvent.SYNC)
    assert m.fire(HandoverEvent.FOLLOW_START) is Handover.FOLLOWING


@pytest.mark.parametrize("state", list(Handover))
def test_device_loss_always_stops(state):
    m = HandoverMachine(state)
    assert m.fire(HandoverEvent.DEVICE_LOST) is Handover.STOPPED


def test_policy_only_from_rest_and_back_to_stopped():
    m = HandoverMachine(Handover.FOLLOWING)
    assert m.fire(HandoverEvent.POLICY_START) is Handover.FOLLOWING  # Y while driving is ignored
    m = HandoverMachine()
    assert m.fire(HandoverEvent.POLICY_START) is Handover.POLICY
    assert m.fire(HandoverEvent.FOLLOW_START) is Handover.POLICY
    assert m.fire(HandoverEvent.POLICY_END) is Handover.STOPPED


def test_only_following_moves_and_table_is_closed():
    for (state, event), new in TRANSITIONS.items():
        assert isinstance(state, Handover) and isinstance(event, HandoverEvent) and isinstance(new, Handover)
    assert [s for s in Handover if HandoverMachine(s).moving] == [Handover.FOLLOWING]
