import hashlib

from dpiil_rl.study.archive import archive_study
from dpiil_rl.study.study_runs import load_study
from tests.study.synthetic_runs import write_study


def test_an_archived_study_recomputes_the_same_numbers_and_keeps_no_bulk(tmp_path):
    write_study(tmp_path / "runs")
    before = {(r.method, r.seed): r.summary for r in load_study(tmp_path / "runs")}
    archived = archive_study(tmp_path / "runs", tmp_path / "docs")
    assert archived and all(
        (d / "episodes.jsonl.gz").exists() and not (d / "episodes.jsonl").exists() for d in archived
    )
    after = {(r.method, r.seed): r.summary for r in load_study(tmp_path / "docs")}
    assert after == before
    digest = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in (tmp_path / "docs").rglob("*.gz")}
    archive_study(tmp_path / "runs", tmp_path / "docs")  # again: byte for byte the same files
    assert digest == {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in (tmp_path / "docs").rglob("*.gz")}
