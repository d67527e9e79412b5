"""The truth benchmark's reports on stored results: a join that leaves cases out, and two runs compared."""

from __future__ import annotations

import json

import pytest

from benchmarks.identify_truth import main as truth_main
from benchmarks.truth_compare import compare


def _case(seed: int, kind: str, named: list[str], recovered: bool, seconds: float, fitted: int) -> dict:
    effects = ["coulomb_friction"] if kind == "single" else []
    cands = [{"name": f"c{i}", "val_score": 0.1 if i < fitted else float("nan")} for i in range(4)]
    return {"seed": seed, "index": seed % 1000, "kind": kind, "effects": effects, "named": named,
            "recovered": recovered, "seconds": seconds, "candidates": cands}


def test_compare_names_changed_cases_and_splits_the_time_ratio():
    old = {1: _case(1, "single", ["viscous_friction"], False, 10.0, 2), 2: _case(2, "single", ["coulomb_friction"],
                                                                              True, 10.0, 2)}
    new = {1: _case(1, "single", ["coulomb_friction"], True, 30.0, 3), 2: _case(2, "single", ["coulomb_friction"],
                                                                             True, 12.0, 2)}
    text = "\n".join(compare(old, new))
    assert "changed: 1" in text and "1 planted coulomb_friction: named viscous_friction (recovered False)" in text
    assert "the 1 cases that fitted more candidates 3.00; the other 1 1.20" in text


def test_join_excludes_the_given_case_seeds(tmp_path):
    rows = [{**_case(5000 + i, "single", ["coulomb_friction"] if i else [], bool(i), 1.0, 1),
             "rel_error": {}, "error": None, "ambiguous": [], "ambiguous_truth": False, "extra": [], "missed": [],
             "improved": True, "seconds_per_20s_1kHz": 1.0, "scenario": "x", "samples": 1000} for i in range(3)]
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "results.json").write_text(json.dumps({"summary": {}, "cases": rows}))
    assert truth_main(["--join", str(tmp_path / "a"), "--exclude", "5000", "--out", str(tmp_path / "j")]) == 0
    summary = json.loads((tmp_path / "j" / "results.json").read_text())["summary"]
    assert summary["excluded"] == [5000]
    assert {r["seed"] for r in json.loads((tmp_path / "j" / "results.json").read_text())["cases"]} == {5001, 5002}
    with pytest.raises(SystemExit, match="not in the joined results"):
        truth_main(["--join", str(tmp_path / "a"), "--exclude", "9", "--out", str(tmp_path / "k")])
