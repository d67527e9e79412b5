"""The truth benchmark's reports on stored results: a join that leaves cases out, and two runs compared."""

from __future__ import annotations

import json
import math

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
    assert "cases that fitted more candidates: 1" in text


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


def test_swap_reach_reads_each_replacement_against_round_one_of_the_same_replay():
    from benchmarks.swap_reach import replacements

    def cand(rnd: int, name: str, val: float, reason: str, accepted: bool = False) -> dict:
        return {"round": rnd, "name": name, "val_score": val, "reason": reason, "accepted": accepted}

    case = {"candidates": [
        cand(1, "hysteresis", 0.1, "passes all criteria"),
        cand(1, "coulomb_friction", 0.3, "passes, but another candidate validates better"),
        cand(1, "hysteresis", 0.02, "on shooting windows: passes all criteria"),
        cand(1, "coulomb_friction", 0.01, "on shooting windows: passes, but another candidate validates better"),
        cand(2, "coulomb_friction", 0.001, "replaces hysteresis beside stribeck_friction (validation ...)", True),
        cand(2, "coulomb_friction", 0.002, "on shooting windows: from runner-up hysteresis: replaces hysteresis "
             "beside viscous_friction (validation ...)"),
        cand(2, "backlash", 0.002, "replaces coulomb_friction beside viscous_friction (validation ...)"),
    ]}
    got = replacements(case)
    assert got[:2] == [("hysteresis", "coulomb_friction", 0.1, 0.3, True),
                       ("hysteresis", "coulomb_friction", 0.02, 0.01, False)]
    old, new, s_old, s_new, kept = got[2]  # a look-alike round one did not fit
    assert (old, new, s_old, kept) == ("coulomb_friction", "backlash", 0.3, False) and math.isnan(s_new)


def test_truth_refusals_lists_only_candidates_that_one_rule_refused_near_the_noise_floor():
    from benchmarks.truth_refusals import best_passer, refused_only_by

    case = {"noise_floor_nrmse": 1e-4, "candidates": [
        {"round": 1, "name": "backlash", "val_score": 2e-4, "reason": "parameter at a bound"},
        {"round": 2, "name": "backlash", "val_score": 2e-4,
         "reason": "from runner-up hysteresis: parameter at a bound"},
        {"round": 1, "name": "backlash", "val_score": 9e-4, "reason": "parameter at a bound"},  # far above the floor
        {"round": 1, "name": "backlash", "val_score": 2e-4, "reason": "CI includes absent; parameter at a bound"},
        {"round": 1, "name": "hysteresis", "val_score": 2e-4, "reason": "parameter at a bound"},
    ]}
    got = refused_only_by(case, "parameter at a bound", 3.0, "backlash")
    assert [(c["round"], c["val_score"]) for c in got] == [(1, 2e-4), (2, 2e-4)]
    case["candidates"].append({"round": 1, "name": "transmission_compliance", "val_score": 6e-4,
                               "reason": "passes all criteria"})
    assert best_passer(case, got[0]) == 6e-4 and math.isnan(best_passer(case, got[1]))  # round 2: none passed
    assert len(refused_only_by(case, "parameter at a bound", 3.0, None)) == 3


def test_rule_reach_polish_finds_a_later_round_without_a_passer_whose_best_fit_beat_the_model_before():
    from benchmarks.rule_reach import reachable

    def cand(rnd: int, name: str, val: float, reason: str) -> dict:
        return {"round": rnd, "name": name, "val_score": val, "reason": reason}

    before = [cand(1, "stribeck_friction", 0.02, "passes all criteria"),
              cand(1, "coulomb_friction", 0.03, "passes, but another candidate validates better")]
    beaten = cand(2, "coulomb_friction", 0.001, "parameter at a bound")
    assert reachable({"candidates": [*before, beaten]})
    assert not reachable({"candidates": [*before, cand(2, "coulomb_friction", 0.05, "parameter at a bound")]})
    # a round with a passer is the old rule's (the best passer's refit), not the polish's
    assert not reachable({"candidates": [*before, beaten, cand(2, "viscous_friction", 0.01, "passes all criteria")]})
    # a runner-up's branch starts from that runner-up's own round-one fit
    branch = cand(2, "viscous_friction", 0.025, "from runner-up coulomb_friction: CI includes absent")
    assert reachable({"candidates": [*before, branch]})
    assert not reachable({"candidates": [before[0], cand(1, "coulomb_friction", 0.02, "passes, but ..."), branch]})
    # each replay on its own: a round on shooting windows is read against round one on the windows
    windowed = cand(2, "hysteresis", 0.001, "on shooting windows: CI includes absent")
    assert not reachable({"candidates": [*before, windowed]})
    assert reachable({"candidates": [*before, cand(1, "x", 0.002, "on shooting windows: passes all criteria"),
                                     windowed]})


def test_rule_reach_low_rank_lists_cases_whose_round_one_had_no_passer_in_some_replay():
    from benchmarks.rule_reach import round_one_without_passer

    passed = {"round": 1, "name": "coulomb_friction", "val_score": 0.1, "reason": "passes all criteria",
              "accepted": True}
    refused = {"round": 1, "name": "backlash", "val_score": 0.5, "reason": "CI includes absent", "accepted": False}
    windows = {**refused, "reason": "on shooting windows: CI includes absent"}
    branch = {**refused, "round": 1, "reason": "from runner-up hysteresis: CI includes absent"}
    assert round_one_without_passer({"candidates": [refused]})
    assert not round_one_without_passer({"candidates": [passed, refused, branch]})
    assert round_one_without_passer({"candidates": [passed, refused, windows]})


def test_rule_reach_emf_share_lists_the_records_that_leave_the_back_emf_share_free(tmp_path):
    from benchmarks.rule_reach import emf_share_free
    from tests.truthsim.scenarios import draw_case, write_case
    from vsa_gym.identify.record import load_record

    for seed, effects, free in ((107020, ["gearbox_efficiency", "viscous_friction"], True),
                                (97049, ["coulomb_friction", "viscous_friction"], False)):
        spec = {"seed": seed, "effects": effects, "rate": None, "duration": None}
        assert emf_share_free(spec) is free, seed
        rec = load_record(write_case(draw_case(seed, tuple(effects)), tmp_path / str(seed)))
        # the share is free exactly where a voltage input drives a lagged model whose sidecar does not split b
        splits = "b_emf" in rec.model.get("params", {})
        lagged = float(rec.model["params"].get("tau_e", 0.0)) > 0.0
        assert free == ("voltage" in rec.inputs and lagged and not splits), seed


def test_substep_accuracy_shows_the_replay_converged_at_the_models_own_substeps(capsys) -> None:
    from benchmarks.substep_accuracy import main as substep_accuracy

    # the golden nominal truth record (200 Hz, a 0.18 ms current loop): the model's rule asks for 11 substeps
    # (h / tau_e 2.49, the lag's reach; 19 at the nonlinear modes' 1.5)
    assert substep_accuracy(["20250060", "", "--duration", "2", "--substeps", "1", "11", "38"]) == 0
    out = capsys.readouterr().out
    assert "the model's rule: 11 substeps" in out
    lines = {int(line.split()[0]): line for line in out.splitlines() if "substeps:" in line}
    assert "diverged" in lines[1]
    at_rule, finer = (float(lines[n].split("NRMSE")[1].split()[0]) for n in (11, 38))
    assert at_rule == pytest.approx(finer, rel=1e-3)


def test_compare_counts_moved_values_and_redone_cases_and_rule_reach_finds_refined_sticking_cases():
    from benchmarks.rule_reach import RULES

    def row(seed: int, seconds: float, f_s: float, sticks_on: str) -> dict:
        fitted = {"coulomb_friction": {"F_c": 1.0, "sticks": float(sticks_on == "coulomb")},
                  "stribeck_friction": {"F_s": f_s, "sticks": float(sticks_on == "stribeck")}}
        return {**_case(seed, "single", ["coulomb_friction"], True, seconds, 2), "fitted": fitted,
                "replay": "...; so it was refitted at 2x, and the held-out part is replayed so"}

    old = {1: row(1, 10.0, 2.0, "stribeck"), 2: row(2, 5.0, 2.0, "stribeck")}
    new = {1: row(1, 8.0, 2.002, "coulomb"), 2: row(2, 5.0, 2.0, "stribeck")}
    text = "\n".join(compare(old, new))
    assert "fitted values differ: 1" in text and "1: largest relative change 0.001 (stribeck_friction.F_s)" in text
    assert "cases whose time differs (redone): 1, 10.0 s before, 8.0 s after" in text
    assert RULES["sticking-restart"](old[1])
    assert not RULES["sticking-restart"]({**old[1], "replay": "open-loop replay of the whole record"})
    assert not RULES["sticking-restart"](row(3, 1.0, 2.0, "none"))
