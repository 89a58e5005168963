import json

import pytest

from dpiil_rl.records.appends import DamagedRecord, recover_jsonl, trim_csv_log
from dpiil_rl.records.run_files import RunFiles


def _write(path, rows, tail=""):
    path.write_text("".join(json.dumps(r) + "\n" for r in rows) + tail)


@pytest.mark.parametrize("tail", ['{"episode": 3, "succ', '{"episode": 3}', "\x00\x00\x00\x00", '{"ep\n', "\x00\x00\n"])
def test_a_torn_last_line_is_dropped_and_said(tmp_path, capsys, tail):
    path = tmp_path / "episodes.jsonl"
    _write(path, [{"episode": 0}, {"episode": 1}], tail)
    assert recover_jsonl(path) == [{"episode": 0}, {"episode": 1}]
    assert path.read_text() == '{"episode": 0}\n{"episode": 1}\n'  # rewritten without it
    assert "dropped a torn last line" in capsys.readouterr().err
    assert recover_jsonl(path) == [{"episode": 0}, {"episode": 1}]  # and nothing more the second time
    assert capsys.readouterr().err == ""


def test_damage_before_the_last_line_names_the_file_the_line_and_the_way_out(tmp_path):
    path = tmp_path / "metrics.jsonl"
    path.write_text('{"iteration": 0}\n{"itera\n{"iteration": 2}\n')
    with pytest.raises(DamagedRecord, match=r"metrics.jsonl: line 2 is not a record .* overwrite=true"):
        recover_jsonl(path)


def test_run_files_resume_past_a_torn_line_and_refuse_lost_rows(tmp_path, capsys):
    files = RunFiles(tmp_path)
    for i in range(3):
        files.add_episode({"phase": "demo", "iteration": 0, "episode": i})
    with (tmp_path / "episodes.jsonl").open("a") as f:
        f.write('{"phase": "demo", "iter')
    again = RunFiles(tmp_path)
    assert len(again.episodes) == 3 and "torn" in capsys.readouterr().err
    again.truncate(2, 0)  # back to a checkpoint's row count
    assert [r["episode"] for r in RunFiles(tmp_path).episodes] == [0, 1]
    with pytest.raises(DamagedRecord, match="2 rows, but the checkpoint counts 5"):
        RunFiles(tmp_path).truncate(5, 0)


def test_csv_logs_lose_their_torn_tail_and_the_steps_after_the_checkpoint(tmp_path):
    log = tmp_path / "csv" / "run" / "scalars" / "eval_autonomous_success.csv"
    log.parent.mkdir(parents=True)
    log.write_text("0,0.5\n1,0.9\n2,1.0\n3,1")
    trim_csv_log(log, 2)
    assert log.read_text() == "0,0.5\n1,0.9\n"
