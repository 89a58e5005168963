"""``make sync``: never breaks without a server; syncs only with a key and a reachable server."""

import socket

import pytest

from dpiil_rl.loggers.wandb_sync import plan_sync, sync


def _fake_offline_run(root):
    run = root / "study" / "aperture" / "dpiil_ucb" / "seed_0" / "wandb" / "offline-run-20260101_000000-abc"
    run.mkdir(parents=True)
    (run / "run-abc.wandb").write_bytes(b"")
    return run


def test_without_server_lists_and_changes_nothing(tmp_path, monkeypatch, capsys):
    _fake_offline_run(tmp_path)
    monkeypatch.delenv("WANDB_API_KEY", raising=False)
    monkeypatch.setenv("WANDB_BASE_URL", "http://127.0.0.1:9")  # discard port: nothing listens
    monkeypatch.setenv("HOME", str(tmp_path))  # no ~/.netrc
    assert sync(tmp_path) == 0
    out = capsys.readouterr().out
    assert "1 offline wandb run(s)" in out and "nothing uploaded" in out and "WANDB_API_KEY" in out


def test_with_key_and_reachable_server_it_would_sync(tmp_path, monkeypatch):
    _fake_offline_run(tmp_path)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    try:
        monkeypatch.setenv("WANDB_BASE_URL", f"http://127.0.0.1:{server.getsockname()[1]}")
        monkeypatch.setenv("WANDB_API_KEY", "x" * 40)
        plan = plan_sync(tmp_path)
        assert plan.can_sync and len(plan.runs) == 1
    finally:
        server.close()


def test_missing_folder_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope"):
        plan_sync(tmp_path / "nope")
