"""Run a drawn case and write it as a user would: the measured table, its sidecar and, apart, the truth.

Record (``docs/measured-data.md``, ``device: "drive"``)::

    <stem>.csv         t [s], u [V or A] (drive command, an input), ref [m or rad] (closed loop), q (position)
    <stem>.json        the sidecar, written from datasheet knowledge only (nominal model, sensor, controller)
    <stem>.truth.json  planted effects with all their parameters, the true plant and the scenario

The sidecar's nominal ``model.params`` are what a user would take from datasheets: ``m`` the total
inertia at the load including the reflected rotor inertia (before any inertia error), ``b`` the
nominal mechanical viscous friction plus, for a voltage drive, the back-EMF damping ``K^2/R``,
``k_u`` the force at the load per input unit (``K/R`` voltage drive, ``K G_a`` current amplifier),
``tau_e`` the electrical (``L/R``) or current-loop (``1/(2 pi f_bw)``) time constant, ``frac_m`` the
reflected rotor share of ``m`` (axes with a rotor), ``v_eps`` 1e-3 of the design's peak speed.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from tests.truthsim.integrate import SimResult, initial_state, simulate

if TYPE_CHECKING:
    from tests.truthsim.scenarios import Case

FORMAT = "vsa-gym/measured-data/1"
SPLIT = {"fit": [0.0, 0.6], "validation": [0.6, 0.8], "test": [0.8, 1.0]}


def run(case: Case, n_sub: int | None = None) -> SimResult:
    """Simulate ``case`` (its seeded sensor noise included); ``n_sub`` overrides the sub-steps per sample."""
    P = case.P()
    n, dt = case.n, case.dt
    s = case.sensor
    noise = np.random.default_rng([case.seed, 104729]).standard_normal(n) * s["noise_counts"]
    sensor = (1 if s["at"] == "motor" else 0, s["gain"], s["offset"], s["delay"], s["resolution"],
              0 if s["quantizer"] == "floor" else 1)
    x0 = initial_state(P, case.x0, case.gap0)
    kw: dict[str, Any] = {"sensor": sensor, "noise": noise, "x0": x0, "n_sub": n_sub,
                          "v_max": 2.0 * case.design["v_peak"]}
    if case.loop == "closed":
        assert case.controller is not None and case.ref is not None
        c = case.controller
        return simulate(P, dt, n, ref=case.ref, controller=(c["kp"], c["kv"], c["saturation"]), **kw)
    return simulate(P, dt, n, u=case.u, **kw)


def _units(case: Case) -> tuple[str, str]:
    return ("rad", "N m") if case.motion == "rotational" else ("m", "N")


def _description(case: Case) -> str:
    d = case.design
    if case.axis == "ball_screw":
        axis = (f"{'vertical ' if case.vertical else ''}ball-screw axis, lead {1e3 * d['lead']:.1f} mm, "
                f"moving mass {d['m_nominal']:.3g} kg at the load (incl. rotor)")
    elif case.axis == "gear_motor":
        axis = f"gear motor, ratio {d['ratio']:.1f}:1, inertia {d['m_nominal']:.3g} kg m^2 at the load (incl. rotor)"
    else:
        axis = f"linear motor, moving mass {d['m_nominal']:.3g} kg"
    amp = ("DC motor in voltage drive" if case.amplifier == "voltage"
           else f"current amplifier ({d['f_bw']:.0f} Hz current loop)")
    exp = (f"closed-loop PD ({case.excitation} reference)" if case.loop == "closed"
           else f"open-loop {case.excitation} command")
    return f"{axis}; {amp}; {exp}; {case.rate:g} Hz. Independent truth simulator (tests.truthsim)."


def sidecar(case: Case) -> dict[str, Any]:
    """The sidecar a user would write for this experiment (no planted effect in it)."""
    lin, _ = _units(case)
    s = case.sensor
    inputs: dict[str, Any] = {"u": {"quantity": case.command, "unit": "V" if case.command == "voltage" else "A",
                                    "sensor": "amplifier command" if case.loop == "open" else "controller output"}}
    if case.loop == "closed":
        inputs["ref"] = {"quantity": "reference", "unit": lin, "sensor": "position reference of the loop"}
    meta: dict[str, Any] = {
        "format": FORMAT, "device": "drive", "experiment": f"truthsim_{case.seed}",
        "description": _description(case),
        "time": {"column": "t", "unit": "s"},
        "inputs": inputs,
        "outputs": {"q": {"quantity": "position", "unit": lin, "sensor": s["description"],
                          "resolution": s["resolution"], "quantizer": s["quantizer"], "at": s["at"]}},
    }
    if case.loop == "closed" and case.replay == "closed_loop":
        c = case.controller
        assert c is not None
        meta["controller"] = {"type": "pd_cascade", "kp": c["kp"], "kv": c["kv"], "saturation": c["saturation"],
                              "reference": "ref", "output": "u"}
    meta["replay"] = case.replay
    meta["model"] = {"motion": case.motion, "params": dict(case.nominal), "free": {}}
    if case.axis == "linear_motor":  # a user knows a direct drive has no transmission, and says so
        meta["model"]["transmission"] = "direct"
    meta["initial_state"] = {"position": case.x0, "velocity": 0.0}
    # the amplifier starts from rest (zero current) with the record; half the users say so
    # (initial_state.force, docs/measured-data.md), half leave the identifier's default
    if np.random.default_rng([case.seed, 7919, 2]).random() < 0.5:
        meta["initial_state"]["force"] = 0.0
    meta["split"] = {k: list(v) for k, v in SPLIT.items()}
    return meta


def truth(case: Case, sim: SimResult, seconds: float) -> dict[str, Any]:
    """Planted effects (all parameters, main first), the true plant and the scenario."""
    from tests.truthsim.plant import PAR_NAMES
    from tests.truthsim.scenarios import MAIN

    P = case.P()
    sc = {"axis": case.axis, "motion": case.motion, "vertical": case.vertical, "amplifier": case.amplifier,
          "command": case.command, "rate": case.rate, "duration": case.duration, "loop": case.loop,
          "replay": case.replay, "excitation": case.excitation, "sensor": dict(case.sensor),
          "controller": case.controller, "x0": case.x0, "gap0": case.gap0, "summary": case.summary()}
    return {
        "format": "truthsim/1", "seed": case.seed, "effects": list(case.effects),
        "planted": case.planted, "main": {e: case.planted[e][MAIN[e]] for e in case.effects},
        "scenario": sc, "physics": {k: float(P[i]) for i, k in enumerate(PAR_NAMES)},
        "nominal": case.nominal, "design": case.design,
        "simulation": {"n_sub": sim.n_sub, "events": sim.events, "overflows": sim.overflows, "seconds": seconds,
                       "stuck_fraction": float(np.mean(sim.modes[:, 0] == 0)),
                       "position_range": [float(np.min(sim.y)), float(np.max(sim.y))]},
    }


def run_case(case: Case) -> tuple[pd.DataFrame, dict[str, Any], dict[str, Any]]:
    """Simulate ``case``: (measured table, sidecar, truth).  Raises ``RuntimeError`` on a non-finite run."""
    t0 = time.perf_counter()
    sim = run(case)
    seconds = time.perf_counter() - t0
    cols: dict[str, np.ndarray] = {"t": sim.t, "u": sim.u}
    if case.loop == "closed":
        assert case.ref is not None
        cols["ref"] = case.ref
    cols["q"] = sim.y
    table = pd.DataFrame(cols)
    if not np.all(np.isfinite(table.to_numpy())):
        raise RuntimeError(f"truthsim case {case.seed} {case.effects}: non-finite simulation ({case.summary()})")
    return table, sidecar(case), truth(case, sim, seconds)


def stem(case: Case) -> str:
    """File stem: the seed and an opaque digest of the planted set (names do not leak into the record)."""
    digest = hashlib.sha1(",".join(sorted(case.effects)).encode()).hexdigest()[:8]
    return f"truthsim_{case.seed}_{digest}"


def write_record(directory: Path, case: Case, table: pd.DataFrame, meta: dict[str, Any],
                 tru: dict[str, Any]) -> Path:
    """Write ``<stem>.csv``, ``<stem>.json`` and ``<stem>.truth.json`` into ``directory``; returns the CSV path."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{stem(case)}.csv"
    table.to_csv(path, index=False, float_format="%.12g")
    path.with_suffix(".json").write_text(json.dumps(meta, indent=2) + "\n")
    (directory / f"{stem(case)}.truth.json").write_text(json.dumps(tru, indent=2, default=_jsonable) + "\n")
    return path


def read_truth(csv: Path) -> dict[str, Any]:
    """The ``<stem>.truth.json`` written beside the record ``csv`` by :func:`write_record` (``main``: each planted
    effect's main parameter; ``planted``: all of their parameters)."""
    return json.loads(csv.with_name(csv.stem + ".truth.json").read_text())


def _jsonable(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o)}")


__all__ = ["read_truth", "run", "run_case", "sidecar", "stem", "truth", "write_record"]
