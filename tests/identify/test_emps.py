"""Real data: the EMPS axis.  From a rigid body with viscous friction only, the pipeline must name
Coulomb friction (and the force offset the data demand) and beat the published linear
state-space simulation RMS on the test record (5.53 mm)."""

from __future__ import annotations

import json

from vsa_gym.cli import main


def test_emps_names_coulomb_and_beats_linear_baseline(tmp_path):
    out = tmp_path / "emps.json"
    assert main(["identify", "emps", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    names = {e["name"]: e for e in res["effects"]}
    assert "coulomb_friction" in names
    fc = names["coulomb_friction"]["parameters"]["F_c"]
    assert 15.0 < fc < 26.0  # providers' IDIM-LS: 20.39 N
    lo, hi = names["coulomb_friction"]["ci"]["F_c"]
    assert lo > 0
    before, after = res["metrics"]["before"]["qm"], res["metrics"]["after"]["qm"]
    assert after["rmse"] < 5.53e-3 < before["rmse"]
    assert after["fit_percent"] > 90
