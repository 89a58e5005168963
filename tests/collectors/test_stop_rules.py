from dpiil_rl.collectors.stop_rules import ExpertPairQuota, RoundStats


def test_one_env_collects_until_the_quota_is_met():
    quota = ExpertPairQuota(200)
    quota.expected_per_episode = 83.0  # ignored with one env: nothing is in progress when it asks
    assert quota.may_start(RoundStats(episodes_started=2, episodes_finished=2, expert_pairs=199))
    assert not quota.may_start(RoundStats(episodes_started=3, episodes_finished=3, expert_pairs=200))


def test_side_by_side_episodes_count_what_episodes_in_progress_will_bring():
    quota = ExpertPairQuota(200)
    quota.expected_per_episode = 83.0  # demonstrations of the previous round: 83 pairs each
    started = 0
    while quota.may_start(RoundStats(episodes_started=started, expert_pairs=0)):
        started += 1
    assert started == 3  # 0, 83, 166 < 200: three demonstrations, not four, start side by side
    # once episodes finish, this round's own rate is used (here 20 pairs per episode)
    assert quota.may_start(RoundStats(episodes_started=5, episodes_finished=4, expert_pairs=80))
    assert not quota.may_start(RoundStats(episodes_started=8, episodes_finished=4, expert_pairs=130))


def test_episode_cap():
    assert not ExpertPairQuota(200, max_episodes=5).may_start(RoundStats(episodes_started=5))
