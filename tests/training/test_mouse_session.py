"""A whole interactive training session on the aperture task with a (scripted) person on the mouse,
closing the window half-way through and continuing later."""

import json

from dpiil_rl.records.run_files import read_jsonl
from tests.conftest import run_script, smoke_overrides


def test_closing_the_window_pauses_and_the_same_command_continues(tmp_path, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    run_dir = tmp_path / "run"
    common = [
        "logger=none",
        "expert=mouse",
        "expert._target_=tests.mocks.scripted_person.ScriptedMousePerson",
        "expert.realtime=false",
        "expert.sound=false",
        "protocol.iterations=1",
        "protocol.demo_episodes=2",
    ]
    first = run_script("train", *smoke_overrides(run_dir, *common, "+expert.quit_after_steps=230"))
    assert "session paused" in first.stdout
    assert (run_dir / "checkpoints" / "pause" / "state.pt").exists() and not (run_dir / "summary.json").exists()
    before = read_jsonl(run_dir / "episodes.jsonl")
    assert [e["phase"] for e in before[:2]] == ["demo", "demo"]
    kept_interactive = [e for e in before if e["phase"] == "interactive"]

    second = run_script("train", *smoke_overrides(run_dir, *common))
    assert "resuming" in second.stdout and "interactive success" in second.stdout
    after = read_jsonl(run_dir / "episodes.jsonl")
    demos = [e for e in after if e["phase"] == "demo"]
    assert len(demos) == 2 and all(e["success"] and e["expert_steps"] > 0 for e in demos)  # the person's own demos
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["expert_actions"] == sum(e["expert_steps"] for e in after if e["phase"] != "eval")
    assert after[: len(before)] == before  # nothing collected before the pause is lost or redone
    assert [e["episode"] for e in after] == list(range(len(after)))
    interactive = [e for e in after if e["phase"] == "interactive"]
    assert interactive[: len(kept_interactive)] == kept_interactive
    pairs = sum(e["expert_steps"] for e in interactive)
    assert 40 <= pairs < 40 + 200  # one quota for the iteration, across the pause (the last episode finishes)
    assert not (run_dir / "checkpoints" / "pause").exists()
    assert sorted({e["iteration"] for e in after if e["phase"] == "eval"}) == [0, 1]


def test_closing_the_window_in_the_first_demo_pauses_with_nothing_saved_and_continues(tmp_path, monkeypatch):
    """Closed before any expert-labelled episode finished: the buffers are empty (torchrl cannot dump an empty
    storage), the pause still saves and the same command starts the demos again. ThriftyDAgger's gate consults
    the person (switch-back): the end-of-run maps copy the gate but share the person's window."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    run_dir = tmp_path / "run"
    common = [
        "logger=none",
        "expert=mouse",
        "expert._target_=tests.mocks.scripted_person.ScriptedMousePerson",
        "expert.realtime=false",
        "expert.sound=false",
        "protocol.iterations=1",
        "protocol.demo_episodes=2",
        "method=thrifty_dagger",
    ]  # two buffers: the dataset and ThriftyDAgger's experience
    first = run_script("train", *smoke_overrides(run_dir, *common, "+expert.quit_after_steps=5"))
    assert "session paused" in first.stdout and "Traceback" not in first.stderr
    pause = run_dir / "checkpoints" / "pause"
    assert (pause / "buffer.empty").exists() and read_jsonl(run_dir / "episodes.jsonl") == []
    second = run_script("train", *smoke_overrides(run_dir, *common))
    assert "resuming" in second.stdout and "interactive success" in second.stdout
    demos = [e for e in read_jsonl(run_dir / "episodes.jsonl") if e["phase"] == "demo"]
    assert len(demos) == 2 and all(e["success"] for e in demos)


def test_hg_dagger_with_a_person_who_takes_over_by_pressing_on_the_robot(tmp_path, monkeypatch):
    """HG-DAgger is human-gated: the person (not a risk) decides when to grab the robot and when to let go."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    run_dir = tmp_path / "run"
    run_script(
        "train",
        *smoke_overrides(
            run_dir,
            "logger=none",
            "expert=mouse",
            "method=hg_dagger",
            "expert._target_=tests.mocks.scripted_person.ScriptedMousePerson",
            "expert.realtime=false",
            "expert.sound=false",
            "+expert.takes_over=true",
            "protocol.iterations=1",
            "protocol.demo_episodes=2",
        ),
    )
    summary = json.loads((run_dir / "summary.json").read_text())
    interactive = [e for e in read_jsonl(run_dir / "episodes.jsonl") if e["phase"] == "interactive"]
    assert interactive and summary["interventions"] == sum(e["interventions"] for e in interactive) > 0  # it grabbed
    assert sum(e["expert_steps"] for e in interactive) < sum(e["length"] for e in interactive)  # ... and let go
