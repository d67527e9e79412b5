"""Measured records: a CSV (or Parquet) table plus a JSON sidecar, loading and checking.

The format is documented in ``docs/measured-data.md``.  In short: the table has a
time column ``t`` (s, strictly increasing, uniformly sampled) and named signal
columns; the sidecar ``<table>.json`` names the device, the experiment, which
columns are inputs (they drive the replay) and which are outputs (they are
compared), their physical quantity, unit and sensor, the closed-loop controller
if any, the nominal model and its free parameters, the initial state and the
split into fit / validation / test parts.

:func:`check_record` returns every problem it finds (never stops at the first);
:func:`load_record` raises :class:`RecordError` listing them all.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vsa_gym.devices import device as device_spec
from vsa_gym.devices import devices

FORMAT = "vsa-gym/measured-data/1"
#: a drive sidecar's ``model.transmission``: a gear, screw or belt between motor and load, or none
TRANSMISSIONS: tuple[str, ...] = ("geared", "direct")
#: the devices a record may declare, and their input / output quantities with the allowed units
#: (:mod:`vsa_gym.devices`: each device declares its record schema once)
DEVICES: tuple[str, ...] = tuple(d.name for d in devices())
INPUTS: dict[str, dict[str, tuple[str, ...]]] = {d.name: dict(d.record.inputs) for d in devices()}
OUTPUTS: dict[str, dict[str, tuple[str, ...]]] = {d.name: dict(d.record.outputs) for d in devices()}

SHIPPED_DIR = Path(__file__).resolve().parent.parent / "data"
#: shipped record names -> (fit record, test record or None)
SHIPPED: dict[str, tuple[str, str | None]] = {
    "emps": ("emps/emps_train.csv", "emps/emps_test.csv"),
    "emps-train": ("emps/emps_train.csv", None),
    "emps-test": ("emps/emps_test.csv", None),
    # CED: fit on both official training parts (two segments), score once on test 2 (u12) or test 1 (u11)
    "ced": ("ced/ced_train.csv", "ced/ced_test_2.csv"),
    "ced-2": ("ced/ced_train.csv", "ced/ced_test_2.csv"),
    "ced-1": ("ced/ced_train.csv", "ced/ced_test_1.csv"),
    "ced-train": ("ced/ced_train.csv", None),
    "ced-test-1": ("ced/ced_test_1.csv", None),
    "ced-test-2": ("ced/ced_test_2.csv", None),
}


class RecordError(ValueError):
    """A record that does not pass :func:`check_record`; ``problems`` lists every finding."""

    def __init__(self, path: str, problems: list[str]) -> None:
        self.problems = problems
        super().__init__(f"{path}: {len(problems)} problem(s):\n  - " + "\n  - ".join(problems))


@dataclasses.dataclass(frozen=True)
class Signal:
    """One declared column."""

    column: str
    quantity: str
    unit: str
    sensor: str = ""
    resolution: float = 0.0  # quantisation step of the sensor (same unit), 0 = unknown / none


@dataclasses.dataclass
class Record:
    """A loaded, checked measured record."""

    path: str
    meta: dict[str, Any]
    t: np.ndarray
    data: pd.DataFrame
    inputs: dict[str, Signal]  # keyed by quantity
    outputs: dict[str, Signal]  # keyed by quantity

    @property
    def device(self) -> str:
        return str(self.meta["device"])

    @property
    def experiment(self) -> str:
        return str(self.meta.get("experiment", ""))

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.t)))

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def input(self, quantity: str) -> np.ndarray:
        return self.data[self.inputs[quantity].column].to_numpy(dtype=np.float64)

    def output(self, quantity: str) -> np.ndarray:
        return self.data[self.outputs[quantity].column].to_numpy(dtype=np.float64)

    @property
    def controller(self) -> dict[str, Any] | None:
        return self.meta.get("controller")

    @property
    def model(self) -> dict[str, Any]:
        return dict(self.meta.get("model", {}))

    def masks(self) -> dict[str, np.ndarray]:
        """Boolean masks of the fit / validation / test parts (``split`` in the sidecar, fractions of the record)."""
        split = self.meta.get("split", {"fit": [0.0, 0.7], "validation": [0.7, 1.0]})
        n = len(self)
        skip = int(self.meta.get("skip_samples", 0))
        out = {}
        for part, rng in split.items():
            if rng is None:
                continue
            a, b = int(round(rng[0] * n)), int(round(rng[1] * n))
            m = np.zeros(n, dtype=bool)
            m[max(a, skip):b] = True
            out[part] = m
        return out

    def to_frame(self) -> pd.DataFrame:
        return self.data.copy()


def sidecar_path(path: str | Path) -> Path:
    p = Path(path)
    return p.with_suffix(".json")


def missing_file_message(path: Path) -> str:
    """``file not found``, and the shipped names when ``path`` looks like a mistyped one (no folder, no suffix)."""
    msg = f"file not found: {path}"
    if path.parent == Path(".") and not path.suffix:
        close = difflib.get_close_matches(path.name.lower(), list(SHIPPED), n=3, cutoff=0.5)
        hint = f"did you mean {' or '.join(close)}? " if close else ""
        msg += f" (not a shipped record name either: {hint}shipped names are {', '.join(SHIPPED)})"
    return msg


def non_finite_summary(raw: pd.Series, values: np.ndarray) -> str:
    """How many values of a column are NaN or missing, infinite, or not numbers, each with its first row."""
    numeric = pd.to_numeric(raw, errors="coerce").notna().to_numpy() | raw.isna().to_numpy()
    kinds = (("infinite", np.isinf(values)), ("NaN / empty", np.isnan(values) & raw.isna().to_numpy()),
             ("non-numeric", ~numeric))
    return "; ".join(f"{int(m.sum())} {name} value(s), first at row {int(np.argmax(m))}"
                     for name, m in kinds if np.any(m))


def resolve(name_or_path: str) -> tuple[Path, Path | None]:
    """A file path, or a shipped record name (``emps``, ``ced-1``, ...) -> (fit record, test record)."""
    if name_or_path in SHIPPED:
        fit, test = SHIPPED[name_or_path]
        return SHIPPED_DIR / fit, (SHIPPED_DIR / test if test else None)
    return Path(name_or_path), None


def _read_table(path: Path) -> pd.DataFrame:
    if path.suffix.lower() in (".parquet", ".pq"):
        try:
            return pd.read_parquet(path)
        except ImportError as exc:
            raise RecordError(str(path), [f"Parquet needs pyarrow or fastparquet installed ({exc})"]) from exc
    return pd.read_csv(path)


def check_record(path: str | Path, table: pd.DataFrame | None = None,
                 meta: Mapping[str, Any] | None = None) -> list[str]:
    """Every problem of the record at ``path`` (empty list: the record is valid).

    ``table`` / ``meta`` may be given instead of being read from disk (the
    generator checks its records before writing them).
    """
    problems: list[str] = []
    path = Path(path)
    if table is None and not path.exists():
        return [missing_file_message(path)]
    if meta is None:
        sc = sidecar_path(path)
        if not sc.exists():
            return [f"sidecar {sc.name} not found next to {path.name}"]
        try:
            meta = json.loads(sc.read_text())
        except json.JSONDecodeError as exc:
            return [f"sidecar {sc.name} is not valid JSON: {exc}"]
    if table is None:
        try:
            table = _read_table(path)
        except Exception as exc:  # noqa: BLE001 -- any parse failure is a problem to report
            return [f"cannot read {path.name}: {exc}"]
    if not isinstance(meta, Mapping):
        return ["sidecar must be a JSON object"]
    if meta.get("format") != FORMAT:
        problems.append(f"sidecar 'format' must be {FORMAT!r}, got {meta.get('format')!r}")
    device = meta.get("device")
    if device not in DEVICES:
        problems.append(f"unknown device {device!r}; use one of {DEVICES}")
        return problems
    if not meta.get("experiment"):
        problems.append("sidecar 'experiment' is missing or empty")

    model = meta.get("model", {})
    if isinstance(model, Mapping) and "transmission" in model and (
            device != "drive" or model["transmission"] not in TRANSMISSIONS):
        problems.append(f"model.transmission: {model['transmission']!r} is not {' or '.join(map(repr, TRANSMISSIONS))}"
                        if device == "drive" else f"model.transmission is a drive field; device {device!r} has none")

    params = model.get("params", {}) if isinstance(model, Mapping) else {}
    problem = device_spec(device).record.params_problem(params if isinstance(params, Mapping) else {})
    if problem:
        problems.append(problem)

    # time
    tspec = meta.get("time", {"column": "t", "unit": "s"})
    tcol = tspec.get("column", "t")
    if tspec.get("unit", "s") != "s":
        problems.append(f"time column {tcol!r}: unit must be 's', got {tspec.get('unit')!r}")
    if tcol not in table.columns:
        problems.append(f"missing time column {tcol!r}")
    else:
        t = pd.to_numeric(table[tcol], errors="coerce").to_numpy(dtype=np.float64)
        if np.any(~np.isfinite(t)):
            problems.append(f"time column {tcol!r}: {non_finite_summary(table[tcol], t)}")
        else:
            dtv = np.diff(t)
            if np.any(dtv <= 0):
                k = int(np.argmax(dtv <= 0))
                problems.append(f"time column {tcol!r} is not strictly increasing at row {k + 1} "
                                f"(t = {t[k]:.9g} then {t[k + 1]:.9g})")
            elif dtv.size and np.max(np.abs(dtv - np.median(dtv))) > 0.01 * np.median(dtv):
                problems.append(f"time column {tcol!r}: sampling is not uniform (step varies by more than 1 %; "
                                "resample to a fixed step)")
        if len(table) < 10:
            problems.append(f"record has only {len(table)} rows")

    # signals
    declared: dict[str, str] = {}
    for role, catalogue in (("inputs", INPUTS[device]), ("outputs", OUTPUTS[device])):
        spec = meta.get(role)
        if not isinstance(spec, Mapping) or not spec:
            problems.append(f"sidecar '{role}' must map column names to {{quantity, unit, sensor}}")
            continue
        seen: set[str] = set()
        for col, s in spec.items():
            if not isinstance(s, Mapping):
                problems.append(f"{role} column {col!r}: expected an object with quantity and unit")
                continue
            q, unit = s.get("quantity"), s.get("unit")
            if q not in catalogue:
                kind = "an input" if role == "inputs" else "an output"
                problems.append(f"{role} column {col!r}: {q!r} is not {kind} of device {device!r} "
                                f"(allowed: {sorted(catalogue)})")
            elif unit not in catalogue[q]:
                problems.append(f"{role} column {col!r}: wrong unit {unit!r} for {q!r} (expected one of "
                                f"{list(catalogue[q])})")
            if q in seen:
                problems.append(f"{role}: quantity {q!r} declared twice")
            seen.add(str(q))
            declared[col] = role
            if col not in table.columns:
                problems.append(f"missing column {col!r} (declared in {role})")
                continue
            v = pd.to_numeric(table[col], errors="coerce").to_numpy(dtype=np.float64)
            if np.any(~np.isfinite(v)):
                problems.append(f"column {col!r}: {non_finite_summary(table[col], v)}")
    ins = {s.get("quantity") for s in (meta.get("inputs") or {}).values() if isinstance(s, Mapping)}
    if device in DEVICES:
        problem = device_spec(device).record.input_problem({str(q) for q in ins})
        if problem:
            problems.append(problem)

    ctrl = meta.get("controller")
    if ctrl is not None:
        if not isinstance(ctrl, Mapping) or "type" not in ctrl:
            problems.append("controller must be an object with a 'type'")
        else:
            for key in ("reference",):
                col = ctrl.get(key)
                if col is not None and col not in table.columns:
                    problems.append(f"controller {key} column {col!r} is missing")
    split = meta.get("split")
    if split is not None:
        if not isinstance(split, Mapping):
            problems.append("split must map part names to [start, end] fractions")
        else:
            for part, rng in split.items():
                if part not in ("fit", "validation", "test"):
                    problems.append(f"split part {part!r}: use fit, validation or test")
                if rng is None:
                    continue
                if (not isinstance(rng, list | tuple) or len(rng) != 2 or not 0 <= rng[0] < rng[1] <= 1):
                    problems.append(f"split part {part!r}: expected [start, end] fractions with 0 <= start < end <= 1,"
                                    f" got {rng!r}")
            if "fit" not in split:
                problems.append("split needs a 'fit' part")
    return problems


def load_record(path: str | Path, meta: Mapping[str, Any] | None = None,
                table: pd.DataFrame | None = None) -> Record:
    """Read and check a record; raises :class:`RecordError` naming every problem."""
    path = Path(path)
    problems = check_record(path, table=table, meta=meta)
    if problems:
        raise RecordError(str(path), problems)
    if meta is None:
        meta = json.loads(sidecar_path(path).read_text())
    if table is None:
        table = _read_table(path)
    tcol = meta.get("time", {}).get("column", "t")
    t = table[tcol].to_numpy(dtype=np.float64)

    def sig(spec: Mapping[str, Any]) -> dict[str, Signal]:
        return {s["quantity"]: Signal(col, s["quantity"], s["unit"], s.get("sensor", ""),
                                      float(s.get("resolution", 0.0))) for col, s in spec.items()}

    return Record(str(path), dict(meta), t, table, sig(meta["inputs"]), sig(meta["outputs"]))


def write_record(path: str | Path, table: pd.DataFrame, meta: Mapping[str, Any]) -> Path:
    """Write ``table`` (CSV, or Parquet by suffix) and its sidecar after checking them."""
    path = Path(path)
    problems = check_record(path, table=table, meta=meta)
    if problems:
        raise RecordError(str(path), problems)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() in (".parquet", ".pq"):
        table.to_parquet(path)
    else:
        table.to_csv(path, index=False, float_format="%.12g")
    sidecar_path(path).write_text(json.dumps(meta, indent=2) + "\n")
    return path
