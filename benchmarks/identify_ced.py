"""CED (coupled electric drives, CE8) under the official split: identify on both training parts, score once on
test 1 (u11) and test 2 (u12), next to the published figures.

    python benchmarks/identify_ced.py [--out out/identify_ced] [--max-nfev 25] [--candidates a,b]  # identify + score
    python benchmarks/identify_ced.py --filter-hz 25      # the same with another assumed sensor low-pass corner
    python benchmarks/identify_ced.py --convert ../shared/data/real/ced    # (re)build vsa_gym/data/ced/

The shipped records (``vsa_gym/data/ced/``) are made by :func:`convert` from ``ced_unif.csv``:

- ``ced_train``: the training parts (samples 0-399) of (u11, z11) and (u12, z12), one after the other, as two
  ``segments`` (each replayed from rest: both experiments start with the belt at rest).  Fit: the first 80 %
  of the rows (all of u11 and u12 samples 0-239), validation: u12 samples 240-399.
- ``ced_test_1`` / ``ced_test_2``: samples 400-499 of each experiment.  The state at sample 400 is fitted to
  the first n = 10 samples (``initial_state.fit_window``), which are not scored (``skip_samples``): the RMS
  is over test samples 10..99, the benchmark's metric with the n of the PyPI loader 1.0.1.

The model (sidecar ``model``): the generic drive with m = 1 (speed in sensor units, au), a first-order drive
``tau_e dF/dt = k_u u - F``, viscous friction ``b`` (the motors' back-EMF damping) and a compliant belt
``k_c, c_c`` between the motor side ``frac_m`` and the pulley; the sensor is ``|v|`` followed by a first-order
12 Hz low-pass (a measurement effect, ``filter_hz``).  Starting values come from the providers' reference
Wiener model (eq. 9: alpha = 7.2 1/s, w0 = 21.2 rad/s, xi = 0.12, static gain 1.83); all six are refitted.

The last line printed is an oracle, not a result (:func:`joint_oracle`): the identified model refitted on both
test parts at once, and what that parameter set costs on the training record beside the trained one.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from vsa_gym.identify.pipeline import Identifier
from vsa_gym.identify.record import FORMAT, SHIPPED_DIR, Record, load_record, sidecar_path, write_record

DT = 0.02
N_TRAIN = 400
N_INIT = 10  # state-initialisation window of the test parts (nonlinear-benchmarks 1.0.1)
ADC_STEP = 20.0 / 4095  # z lies on the grid of a 12-bit converter over +-10 V (data README)
#: published test RMS (Champneys et al. 2024, via the data README): (test 1, test 2)
PUBLISHED = {"LTI SS": (0.224, 0.384), "pNARX": (0.10, 0.141), "best published (SOTA)": (0.115, 0.074)}

_ALPHA, _W0, _XI, _GAIN = 7.2, 21.2, 0.12, 1.83  # providers' eq. (9) model, continuous-time equivalent


def _meta(experiment: str, description: str, **extra: object) -> dict:
    m_red = 0.25  # frac_m = 0.5, m = 1
    return {
        "format": FORMAT, "device": "drive", "experiment": experiment, "description": description,
        "source": "nonlinearbenchmark.org CED (Wigren & Schoukens 2017, DATAUNIF.MAT); converted from "
                  "../shared/data/real/ced/ced_unif.csv by benchmarks/identify_ced.py --convert",
        "time": {"column": "t", "unit": "s"},
        "inputs": {"u": {"quantity": "voltage", "unit": "V", "sensor": "sum of the two motor voltages"}},
        "outputs": {"z": {"quantity": "speed_abs", "unit": "au", "resolution": ADC_STEP, "quantizer": "round",
                          "filter_hz": 12.0,
                          "sensor": "pulse counter (blind to the sign of the pulley speed), analogue low-pass and "
                                    "anti-aliasing filter (about 12 Hz), 12-bit ADC; arbitrary units"}},
        "replay": "open_loop",
        "model": {
            "motion": "rotational",
            "units": {"position": "au s", "force": "au/s"},
            "params": {"m": 1.0, "b": _ALPHA, "k_u": _GAIN * _ALPHA, "tau_e": 0.01, "k_c": _W0**2 * m_red,
                       "c_c": 2 * _XI * _W0 * m_red, "frac_m": 0.5, "v_eps": 0.01},
            "free": {"b": [0.5, 50.0], "k_u": [0.5, 100.0], "tau_e": [0.005, 0.5], "k_c": [10.0, 1000.0],
                     "c_c": [0.0, 20.0], "frac_m": [0.05, 0.95]},
            "note": "m = 1: the pulley speed is in sensor units (au); drive lag tau_e, back-EMF damping b, "
                    "compliant belt k_c, c_c between the motors (frac_m) and the spring-held pulley. Starting "
                    "values from the providers' Wiener model eq. (9); all six refitted.",
        },
        **extra,
    }


def convert(src: str | Path, dst: str | Path = SHIPPED_DIR / "ced") -> list[Path]:
    """Build the shipped CED records from the data folder's ``ced_unif.csv`` (see the module docstring)."""
    d = pd.read_csv(Path(src) / "ced_unif.csv")
    if len(d) != 500 or not np.allclose(np.diff(d["t_s"]), DT):
        raise ValueError(f"{src}/ced_unif.csv: expected 500 rows at {DT} s")
    dst = Path(dst)
    u = [d["u11_V"].to_numpy(), d["u12_V"].to_numpy()]
    z = [d["z11_au"].to_numpy(), d["z12_au"].to_numpy()]
    n2 = 2 * N_TRAIN
    train = pd.DataFrame({"t": np.round(np.arange(n2) * DT, 6), "u": np.concatenate([x[:N_TRAIN] for x in u]),
                          "z": np.concatenate([x[:N_TRAIN] for x in z])})
    meta = _meta("ced_unif_train", "CED (CE8) uniform-input experiments, official training parts: rows 0-399 are "
                 "(u11, z11) samples 0-399, rows 400-799 are (u12, z12) samples 0-399 (u12 = u11 + 0.5 V); "
                 "two independent experiments (segments), each starting at rest.",
                 segments=[0, N_TRAIN], initial_state={"position": 0.0, "velocity": 0.0},
                 split={"fit": [0.0, 0.8], "validation": [0.8, 1.0]})
    out = [write_record(dst / "ced_train.csv", train, meta)]
    for i in (1, 2):
        test = pd.DataFrame({"t": np.round((N_TRAIN + np.arange(100)) * DT, 6), "u": u[i - 1][N_TRAIN:],
                             "z": z[i - 1][N_TRAIN:]})
        meta = _meta(f"ced_unif_test_{i}", f"CED (CE8) official test {i}: (u1{i}, z1{i}) samples 400-499; the "
                     f"state is fitted to the first {N_INIT} samples, which are not scored.",
                     initial_state={"position": 0.0, "fit_window": N_INIT}, skip_samples=N_INIT,
                     split={"fit": [0.0, 0.1], "test": [0.1, 1.0]})
        out.append(write_record(dst / f"ced_test_{i}.csv", test, meta))
    return out


def _errors(result, theta: dict[str, float], rec: Record) -> np.ndarray:
    """Measured minus replayed z over the whole record ``rec`` at parameters ``theta``."""
    tad = result.adapter.for_record(rec)
    y = tad.simulate({k: np.array([v]) for k, v in theta.items()}, 1)[:, 0, 0]
    return tad.measured[:, 0] - y


def ced_records(filter_hz: float | None = None) -> tuple[Record, dict[int, Record]]:
    """The shipped training record and the two test records; ``filter_hz`` replaces the sensor's assumed
    low-pass corner (12 Hz) in all three, to see how much the test figures depend on that assumption."""
    def load(name: str) -> Record:
        path = SHIPPED_DIR / "ced" / f"{name}.csv"
        meta = json.loads(sidecar_path(path).read_text())
        if filter_hz is not None:
            meta["outputs"]["z"]["filter_hz"] = float(filter_hz)
        return load_record(path, meta=meta)
    return load("ced_train"), {i: load(f"ced_test_{i}") for i in (1, 2)}


def test_rms(result, rec: Record) -> dict[str, float]:
    """Test RMS of the nominal and the identified model on one test record (samples n..99)."""
    mask = rec.masks()["test"]
    return {label: float(np.sqrt(np.mean(_errors(result, fm.theta(), rec)[mask] ** 2)))
            for label, fm in (("nominal", result.nominal), ("identified", result.final))}


def _part_rms(result, theta: dict[str, float], rec: Record) -> dict[str, float]:
    """RMS of the replay at ``theta`` on each part of ``rec`` (fit, validation; test: the scored samples)."""
    e = _errors(result, theta, rec)
    return {part: float(np.sqrt(np.mean(e[m] ** 2))) for part, m in rec.masks().items() if m.any()}


def joint_oracle(result, train: Record, tests: dict[int, Record]) -> dict:
    """The identified model's free parameters refitted on both test parts at once (scored samples only, the
    state windows as in the test records): an oracle, not a result.  Says whether one parameter set of the
    identified structure can reach the test figures, and what those parameters cost on the training record
    beside the trained ones."""
    fm = result.final
    lo = np.array([s.lower for s in fm.specs])
    hi = np.array([s.upper for s in fm.specs])
    x0 = np.clip(fm.values, lo, hi)

    def theta(x: np.ndarray) -> dict[str, float]:
        return dict(zip(fm.keys, map(float, x), strict=True))

    def residual(x: np.ndarray) -> np.ndarray:
        return np.concatenate([_errors(result, theta(x), rec)[rec.masks()["test"]] for rec in tests.values()])

    sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=np.maximum(np.abs(x0), 1e-6), diff_step=1e-3,
                        max_nfev=400)
    return {"params": theta(sol.x), "test_rms": {i: _part_rms(result, theta(sol.x), rec)["test"]
                                                 for i, rec in tests.items()},
            "train_rms": _part_rms(result, theta(sol.x), train),
            "trained_train_rms": _part_rms(result, fm.theta(), train)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--convert", default=None, help="data folder holding ced_unif.csv: rebuild the shipped records")
    ap.add_argument("--out", default="out/identify_ced")
    ap.add_argument("--max-nfev", type=int, default=25, help="evaluations per fit (the CLI's default is 25)")
    ap.add_argument("--candidates", default=None, help="comma-separated effects to consider (default: the catalogue)")
    ap.add_argument("--filter-hz", type=float, default=None,
                    help="replace the sensor's assumed low-pass corner (12 Hz) in all three records")
    args = ap.parse_args()
    if args.convert:
        for p in convert(args.convert):
            print(f"wrote {p}")
        return
    t0 = time.perf_counter()
    train, tests = ced_records(args.filter_hz)
    cands = args.candidates.split(",") if args.candidates else None
    res = Identifier(max_nfev=args.max_nfev, candidates=cands).fit(train, tests[2]).result_
    scores = {i: test_rms(res, rec) for i, rec in tests.items()}
    statements = res.statements()
    theta = res.final.theta()
    if "coulomb_friction.F_c" in theta:  # the friction as a dead band of the summed drive voltage
        statements.insert(1, f"Equivalent dead band of the drive voltage: F_c / k_u = "
                             f"{theta['coulomb_friction.F_c'] / theta['base.k_u']:.3f} V")
    if "coulomb_friction.v_t" in theta:  # freed: the friction builds up over a speed range instead of a sign
        statements.insert(2, f"The friction builds up as F_c tanh(v / v_t) over v_t = "
                             f"{theta['coulomb_friction.v_t']:.3g} au/s (held value: the model's v_eps = "
                             f"{train.meta['model']['params']['v_eps']:.3g} "
                             f"au/s), so the pulley creeps below the dead band instead of sticking")
    frac = theta["base.frac_m"]
    statements.append(f"Candidates: {', '.join(str(c) for c in cands) if cands else 'the whole catalogue'}")
    statements.append(f"Refitted drive and belt: tau_e = {theta['base.tau_e']:.3f} s, "
                      f"b / m = {theta['base.b']:.2f} 1/s, "
                      f"belt mode sqrt(k_c / m_r) = {np.sqrt(theta['base.k_c'] / (frac * (1 - frac))):.1f} rad/s, "
                      f"damping ratio {theta['base.c_c'] / (2 * np.sqrt(theta['base.k_c'] * frac * (1 - frac))):.3f}")
    print("\n".join(statements))
    print(res.candidates_frame().to_string(index=False))
    lines = ["| model | test 1 (u11) | test 2 (u12) |", "|---|---|---|",
             f"| nominal: lagged drive + compliant belt, sensor abs(v) + 12 Hz low-pass (this workbench) | "
             f"{scores[1]['nominal']:.3f} | {scores[2]['nominal']:.3f} |",
             f"| identified: + {' + '.join(e['name'] for e in res.effects) or 'nothing'} (this workbench) | "
             f"{scores[1]['identified']:.3f} | {scores[2]['identified']:.3f} |"]
    lines += [f"| {k} (published) | {a} | {b} |" for k, (a, b) in PUBLISHED.items()]
    orc = joint_oracle(res, train, tests)
    lines += ["", "Oracle, not a result: the same model refitted on both test parts at once: test 1 "
              f"{orc['test_rms'][1]:.3f}, test 2 {orc['test_rms'][2]:.3f}; on the training record (fit / validation "
              f"part) {orc['train_rms']['fit']:.3f} / {orc['train_rms']['validation']:.3f} against the trained "
              f"model's {orc['trained_train_rms']['fit']:.3f} / {orc['trained_train_rms']['validation']:.3f}"]
    print("\n".join(lines))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "ced.md").write_text("\n".join(statements) + "\n\n" + "\n".join(lines) + "\n")
    (out / "ced.json").write_text(json.dumps({"statements": statements, "effects": res.effects,
                                              "test_rms": scores, "final_params": res.final.theta(),
                                              "joint_oracle": orc,
                                              "nominal_params": res.nominal.theta()}, indent=2) + "\n")
    print(f"[{time.perf_counter() - t0:.1f} s] wrote {out}/ced.md, ced.json")


if __name__ == "__main__":
    main()
