"""The measured-data format: the checker names every problem, the CLI exits non-zero on any."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from vsa_gym.cli import main
from vsa_gym.devices.drive.synthetic import drive_meta
from vsa_gym.identify.record import RecordError, check_record, load_record, resolve, write_record


def _good(tmp_path):
    t = np.arange(200) * 1e-3
    table = pd.DataFrame({"t": t, "u": np.sin(t), "x": np.cos(t)})
    path = write_record(tmp_path / "rec.csv", table, drive_meta())
    return path, table, drive_meta()


def test_valid_record_round_trips(tmp_path):
    path, table, _ = _good(tmp_path)
    assert check_record(path) == []
    rec = load_record(path)
    assert rec.device == "drive" and len(rec) == 200 and rec.dt == pytest.approx(1e-3)
    np.testing.assert_allclose(rec.output("position"), table["x"], rtol=1e-11)
    assert main(["data", "check", str(path)]) == 0


def test_every_problem_is_named(tmp_path):
    path, table, meta = _good(tmp_path)
    bad = table.drop(columns=["x"])
    bad.loc[5, "u"] = np.nan
    bad.loc[10, "t"] = bad.loc[9, "t"]
    meta = json.loads(json.dumps(meta))
    meta["inputs"]["u"]["unit"] = "mV"
    meta["inputs"]["alpha"] = {"quantity": "alpha", "unit": "rad"}
    bad["alpha"] = 0.0
    bad.to_csv(path, index=False)
    path.with_suffix(".json").write_text(json.dumps(meta))
    problems = check_record(path)
    text = "\n".join(problems)
    assert "missing column 'x'" in text
    assert "not strictly increasing at row 10" in text
    assert "column 'u': 1 NaN / empty value(s), first at row 5" in text
    assert "wrong unit 'mV' for 'voltage'" in text
    assert "'alpha' is not an input of device 'drive'" in text
    assert len(problems) == 5
    assert main(["data", "check", str(path)]) == 1
    with pytest.raises(RecordError, match="missing column 'x'"):
        load_record(path)


def test_missing_sidecar_and_unknown_device(tmp_path):
    path, _, meta = _good(tmp_path)
    path.with_suffix(".json").unlink()
    assert "sidecar rec.json not found" in check_record(path)[0]
    meta = dict(meta, device="robot")
    path.with_suffix(".json").write_text(json.dumps(meta))
    assert "unknown device 'robot'" in check_record(path)[0]


def test_shipped_records_pass_the_checker():
    for name in ("emps",):
        fit, test = resolve(name)
        assert check_record(fit) == [] and check_record(test) == []


def test_infinite_and_text_values_are_named_as_such(tmp_path):
    path, table, _ = _good(tmp_path)
    bad = table.astype(object)
    bad.loc[7, "u"] = np.inf
    bad.loc[9, "x"] = "n/a?"
    bad.to_csv(path, index=False)
    text = "\n".join(check_record(path))
    assert "column 'u': 1 infinite value(s), first at row 7" in text
    assert "column 'x': 1 non-numeric value(s), first at row 9" in text
    assert "NaN" not in text


def test_missing_file_and_mistyped_shipped_name(tmp_path, capsys):
    missing = tmp_path / "my.csv"
    assert check_record(missing) == [f"file not found: {missing}"]
    assert main(["identify", str(missing)]) != 0
    assert "file not found" in capsys.readouterr().err
    (problem,) = check_record("emsp")
    assert "file not found: emsp" in problem and "did you mean emps?" in problem and "ced-1" in problem


def test_direct_drive_declaration_is_checked_and_drops_the_transmission_effects(tmp_path):
    """``model.transmission``: 'direct' (a linear motor) takes backlash, compliance and mesh loss out of the
    candidates; another value, or a direct drive given transmission parameters, is named as a problem."""
    from vsa_gym.identify.adapters import make_adapter

    path, table, meta = _good(tmp_path)
    transmission = {"backlash", "transmission_compliance", "gearbox_efficiency"}
    assert transmission <= set(make_adapter(load_record(path)).effects)  # 'geared' by default
    meta = json.loads(json.dumps(meta))
    meta["model"]["transmission"] = "direct"
    path.with_suffix(".json").write_text(json.dumps(meta))
    assert check_record(path) == []
    effects = set(make_adapter(load_record(path)).effects)
    assert not transmission & effects and {"coulomb_friction", "inertia_error"} <= effects
    meta["model"]["transmission"] = "belt"
    path.with_suffix(".json").write_text(json.dumps(meta))
    assert check_record(path) == ["model.transmission: 'belt' is not 'geared' or 'direct'"]
    assert main(["data", "check", str(path)]) == 1
    meta["model"]["transmission"] = "direct"
    meta["model"]["params"]["backlash"] = 1e-4
    path.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="'direct' but model.params gives transmission parameters backlash = 0.0001"):
        make_adapter(load_record(path))


def test_an_unknown_drive_parameter_is_named_with_the_fields(tmp_path, capsys):
    """A sidecar's ``model.params`` key the drive does not have (here ``x_c``, the stick travel that became the
    switch ``sticks``) is named, with the rename, by identify (which writes nothing) and by the checker."""
    path, _, meta = _good(tmp_path)
    meta = json.loads(json.dumps(meta))
    meta["model"]["params"]["x_c"] = 1e-7
    path.with_suffix(".json").write_text(json.dumps(meta))
    out = tmp_path / "out.json"
    assert main(["identify", str(path), "--json", str(out)]) != 0
    err = capsys.readouterr().err
    assert "unknown parameter(s) 'x_c' (x_c: now sticks" in err
    assert not out.exists()
    problems = check_record(path)  # the checker names it too, and nothing else
    assert len(problems) == 1 and "'x_c'" in problems[0]
    assert main(["data", "check", str(path)]) == 1
