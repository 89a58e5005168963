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


def test_a_saved_common_start_evaluation_is_archived_and_its_table_recomputed_without_checkpoints(tmp_path):
    import json

    from dpiil_rl.study.common_starts import evaluate_study

    write_study(tmp_path / "runs")
    run = sorted(p.parent for p in (tmp_path / "runs").rglob("summary.json"))[0]
    (run / "evaluations" / "common").mkdir(parents=True)
    result = {"episodes": 2, "seed": 7, "env_overrides": {}, "checkpoint": "iter_003", "success": 0.5}
    (run / "evaluations" / "common.json").write_text(json.dumps(result))
    rows = [{"episode": i, "success": i == 0} for i in range(2)]
    (run / "evaluations" / "common" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    (run / "evaluations" / "gate_trace_2ep.jsonl").write_text(json.dumps({"risk": [0.1]}) + "\n")
    archived = archive_study(tmp_path / "runs", tmp_path / "docs")
    copy = next(d for d in archived if d.name == run.name and d.parent.name == run.parent.name)
    assert (copy / "evaluations" / "common.json").exists()
    assert (copy / "evaluations" / "common" / "episodes.jsonl.gz").exists()
    assert (copy / "evaluations" / "gate_trace_2ep.jsonl.gz").exists()
    out = evaluate_study(tmp_path / "docs", episodes=2, seed=7, name="common", out_dir=tmp_path / "table")
    assert out["runs"] == 1 and out["reused"] == 1  # the record stands for the run; nothing is simulated
    assert len(out["skipped"]) == len(archived) - 1  # the others have neither a checkpoint nor an evaluation
    assert "| 50.0% (n=1) |" in out["markdown"]


def test_a_run_still_in_its_final_test_is_left_out_until_the_test_is_saved(tmp_path):
    """summary.json is written before the common-start test: a run in that test (or stopped during it) must not
    be archived with half a test, and is archived whole once the test is saved."""
    import json

    from omegaconf import OmegaConf

    write_study(tmp_path / "runs")
    run = sorted(p.parent for p in (tmp_path / "runs").rglob("summary.json"))[0]
    config = OmegaConf.load(run / ".hydra" / "config.yaml")
    OmegaConf.update(config, "protocol", {"final_eval_episodes": 2, "final_eval_seed": 7}, force_add=True)
    OmegaConf.save(config, run / ".hydra" / "config.yaml")
    name = "common_2ep_seed7"
    (run / "evaluations" / name).mkdir(parents=True)
    rows = [{"episode": 0, "success": True}]  # one of its two episodes so far, and no result file
    (run / "evaluations" / name / "episodes.jsonl").write_text(json.dumps(rows[0]) + "\n")
    pending: list = []
    archived = archive_study(tmp_path / "runs", tmp_path / "docs", pending=pending)
    target = tmp_path / "docs" / run.relative_to(tmp_path / "runs")
    assert pending == [run.resolve()] and not target.exists()
    assert len(archived) == len(list((tmp_path / "runs").rglob("summary.json"))) - 1

    rows.append({"episode": 1, "success": False})
    (run / "evaluations" / name / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    result = {"episodes": 2, "seed": 7, "env_overrides": {}, "checkpoint": None, "success": 0.5}
    (run / "evaluations" / f"{name}.json").write_text(json.dumps(result))
    pending = []
    archive_study(tmp_path / "runs", tmp_path / "docs", pending=pending)
    assert pending == [] and (target / "evaluations" / f"{name}.json").exists()
