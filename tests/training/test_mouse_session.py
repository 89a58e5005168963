"""A whole interactive training session on the aperture task with a (scripted) person on the mouse."""

import json

from dpiil_rl.records.run_files import read_jsonl
from tests.conftest import run_script, smoke_overrides


def test_person_with_a_mouse_trains_the_robot(tmp_path, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    run_dir = tmp_path / "run"
    proc = run_script("train", *smoke_overrides(
        run_dir, "logger=none", "expert=mouse", "expert._target_=tests.mocks.scripted_person.ScriptedMousePerson",
        "expert.realtime=false", "expert.sound=false", "protocol.iterations=1", "protocol.demo_episodes=2"))
    assert "interactive success" in proc.stdout
    episodes = read_jsonl(run_dir / "episodes.jsonl")
    demos = [e for e in episodes if e["phase"] == "demo"]
    assert len(demos) == 2 and all(e["success"] for e in demos)  # the person's demonstrations pass both apertures
    assert all(e["expert_steps"] > 0 for e in demos)
    inter = [e for e in episodes if e["phase"] == "interactive"]
    assert inter and sum(e["expert_steps"] for e in inter) >= 40  # the quota is met with the person's pairs
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["expert_actions"] == sum(e["expert_steps"] for e in episodes if e["phase"] != "eval")
