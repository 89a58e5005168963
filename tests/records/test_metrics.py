from dpiil_rl.records.metrics import iteration_mean_success, iteration_metrics, run_summary


def _row(phase, k, success, length=10, expert=0, control=None, queries=None, collision=False):
    row = {
        "phase": phase,
        "iteration": k,
        "success": success,
        "collision": collision,
        "length": length,
        "expert_steps": expert,
        "interventions": 1 if control else 0,
    }
    if control is not None:
        row["expert_control_steps"] = control
    if queries is not None:
        row["expert_queries"] = queries
    return row


def test_effort_is_the_experts_share_of_interactive_steps_and_its_queries():
    rows = [
        _row("demo", 0, True, 80, 80, 80, 80),
        _row("interactive", 1, True, 40, 10, 10, 40),
        _row("interactive", 1, False, 60, 20, 5, 60),
        _row("eval", 1, True),
    ]
    s = run_summary(rows)
    assert (s["interactive_steps"], s["expert_control_steps"], s["expert_queries"]) == (100, 15, 100)
    assert s["expert_share"] == 0.15 and s["query_share"] == 1.0
    assert s["expert_actions"] == 110  # labels, demos included
    assert iteration_metrics(rows, 1)["expert_share"] == 0.15


def test_rows_made_before_the_effort_fields_give_none_not_a_wrong_number():
    rows = [_row("interactive", 1, True, 40, 10), _row("interactive", 1, True, 40, 10, 10, 10)]
    s = run_summary(rows)
    assert s["expert_share"] is None and s["expert_queries"] is None and s["interactive_steps"] == 80


def test_iteration_mean_weighs_each_iteration_once():
    # iteration 1: one success; iteration 2: the robot crashed 9 times in a row until the cap
    rows = [_row("interactive", 1, True)] + [_row("interactive", 2, False)] * 9 + [_row("interactive", 2, True)]
    assert run_summary(rows)["interactive_success"] == 2 / 11  # pooled over the 11 episodes
    assert iteration_mean_success(rows) == (1.0 + 0.1) / 2
    assert run_summary(rows)["interactive_success_iter_mean"] == (1.0 + 0.1) / 2


def test_rollouts_are_counted_apart():
    rows = [_row("interactive", 1, True), _row("rollout", 1, False, collision=True), _row("rollout", 1, True)]
    s = run_summary(rows)
    assert (s["rollout_episodes"], s["rollout_success"], s["rollout_collisions"]) == (2, 0.5, 1)
    assert s["interactive_episodes"] == 1 and "rollout_episodes" not in run_summary(rows[:1])
