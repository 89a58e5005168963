"""A report says which machines its records come from (runs reproduce bit for bit on one CPU code path only)."""

from __future__ import annotations

import json
from pathlib import Path

from dpiil_rl.study.machines import code_note, machine_label, machines_note
from dpiil_rl.study.study_report import write_study_report
from dpiil_rl.study.study_runs import load_study
from tests.study.synthetic_runs import write_study

AVX512 = {"cpu": "CPU A", "torch_cpu_capability": "AVX512", "kernel_variables": {}}
AVX2 = {"cpu": "CPU B", "torch_cpu_capability": "AVX2", "kernel_variables": {"MKL_CBWR": "AVX2,STRICT"}}


def _set_machine(run_dir: Path, machine: dict | None) -> None:
    path = run_dir / "summary.json"
    summary = json.loads(path.read_text())
    if machine is not None:
        summary["machine"] = machine
    path.write_text(json.dumps(summary))


def test_label_names_cpu_capability_and_kernel_variables():
    assert machine_label(AVX512) == "CPU A (AVX512)"
    assert machine_label(AVX2) == "CPU B (AVX2, MKL_CBWR=AVX2,STRICT)"


def test_one_machine_is_named_without_a_warning(tmp_path):
    for run in write_study(tmp_path):
        _set_machine(run, AVX512)
    runs = load_study([tmp_path])
    assert machines_note(runs) == f"machines: {len(runs)} on CPU A (AVX512)"


def test_several_machines_and_unrecorded_runs_are_counted_and_flagged(tmp_path):
    runs_dirs = write_study(tmp_path)
    for i, run in enumerate(runs_dirs):
        _set_machine(run, [AVX512, AVX2, None][i % 3])
    note = machines_note(load_study([tmp_path]))
    n = len(runs_dirs)
    assert note is not None and note.startswith("machines: ")
    assert f"{len(range(0, n, 3))} on CPU A (AVX512)" in note
    assert f"{len(range(1, n, 3))} on CPU B (AVX2, MKL_CBWR=AVX2,STRICT)" in note
    assert f"{len(range(2, n, 3))} made before runs recorded their machine" in note
    assert "bit for bit on the same CPU code path only" in note
    out = write_study_report(tmp_path, tmp_path / "report")
    assert note in (Path(out["out_dir"]) / "results.md").read_text()


def test_no_note_when_no_run_records_its_machine(tmp_path):
    write_study(tmp_path)
    assert machines_note(load_study([tmp_path])) is None


def test_the_report_names_the_commits_its_runs_record(tmp_path):
    runs_dirs = write_study(tmp_path)
    codes = [
        {"version": "0.1.0", "commit": "a" * 40, "dirty": False},
        {"version": "0.1.0", "commit": "b" * 40, "dirty": True},
    ]
    for i, run in enumerate(runs_dirs):
        path = run / "summary.json"
        summary = json.loads(path.read_text())
        if i % 3 < 2:
            summary["code"] = codes[i % 3]
        path.write_text(json.dumps(summary))
    note = code_note(load_study([tmp_path]))
    n = len(runs_dirs)
    assert note is not None and f"{len(range(0, n, 3))} at aaaaaaa" in note
    assert f"{len(range(1, n, 3))} at bbbbbbb+dirty" in note
    assert f"{len(range(2, n, 3))} made before runs recorded their code" in note
    out = write_study_report(tmp_path, tmp_path / "report")
    assert note in (Path(out["out_dir"]) / "results.md").read_text()
