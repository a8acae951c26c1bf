"""benchmarks/best_known.py: a benchmark run that beats the recorded best known becomes it."""

from __future__ import annotations

import json

import numpy as np

import benchmarks.best_known as golden


def test_a_better_run_is_adopted_and_written_back(tmp_path, monkeypatch):
    path = tmp_path / "best_known.json"
    record = {"value": 1.0, "design": {"a": 0.0, "b": 0.0}, "found_by": "cmaes seed 0", "relative_error": 0.01}
    path.write_text(json.dumps({"p": record}))
    monkeypatch.setattr(golden, "GOLDEN", path)
    monkeypatch.setattr(golden, "refined_value", lambda name, x: 1.1)  # no evaluation here
    records = json.loads(path.read_text())
    assert not golden.adopt(records, "p", 0.99, np.array([1.0, 2.0]), "de seed 1")  # worse: kept
    assert not golden.adopt(records, "p", 1.0, np.array([1.0, 2.0]), "de seed 1")  # a tie is not better
    assert golden.adopt(records, "p", 1.05, np.array([1.0, 2.0]), "de seed 1")
    written = json.loads(path.read_text())["p"]
    assert written["value"] == 1.05 and written["design"] == {"a": 1.0, "b": 2.0}
    assert written["found_by"] == "de seed 1"
    assert np.isclose(written["error"], 0.05) and np.isclose(written["relative_error"], 0.05 / 1.05)


def test_the_committed_records_name_their_searches():
    records = json.loads(golden.GOLDEN.read_text())
    assert set(records) == set(golden.PROBLEMS)
    for name, record in records.items():
        assert record["value"] >= max(s["value"] for s in record["searches"]), name
        assert record["found_by"] and len(record["design"]) >= 2, name
