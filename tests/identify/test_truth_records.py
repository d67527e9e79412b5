"""Identification through the CLI on records of the independent truth simulator (tests/truthsim).

The simulator shares no code with the fitted drive model: exact stiction, L/R or current-loop
amplifiers, quantised encoders.  The full case set is ``python -m benchmarks.identify_truth``
(docs/identification.md).  These are two cases of its *tuning* set (base seed 20250, the set the
selection thresholds were chosen on): CI-sized regression checks that the CLI path names a planted
effect with its magnitude and keeps a nominal record clean, not evidence of recovery rates, which
come from the held-out sets (``--seed 11``, ``--seed 7``).
"""

from __future__ import annotations

import json

import pytest

from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.cli import main

BASE = 20250 * 1000  # the benchmark's default case seeds: base seed * 1000 + index


def _identify(tmp_path, seed: int, effects: tuple[str, ...]) -> tuple[dict, dict]:
    csv = write_case(draw_case(seed, effects), tmp_path)
    out = tmp_path / "out.json"
    assert main(["identify", str(csv), "--json", str(out)]) == 0
    truth = json.loads(csv.with_name(csv.stem + ".truth.json").read_text())
    return json.loads(out.read_text()), truth


def test_planted_coulomb_friction_is_named_alone_within_15_percent(tmp_path):
    res, truth = _identify(tmp_path, BASE + 0, ("coulomb_friction",))
    assert [e["name"] for e in res["effects"]] == ["coulomb_friction"], res["statements"]
    got = res["effects"][0]["parameters"]["F_c"]
    assert got == pytest.approx(truth["main"]["coulomb_friction"], rel=0.15)
    assert res["metrics"]["after"]["q"]["rmse"] < res["metrics"]["before"]["q"]["rmse"]


def test_nominal_truth_record_names_nothing(tmp_path):
    res, _ = _identify(tmp_path, BASE + 60, ())
    assert res["effects"] == [] and res["ambiguous"] == [], res["statements"]
    assert res["replay"]
