"""Seeded "measured" vsaUT-II records with one hidden effect (tests, benchmark, examples).

:func:`make_vsaut2_record` runs one of the paper's experiments on the core through
:class:`~vsa_gym.devices.vsaut2.adapter.Vsaut2Adapter` with one catalogue effect of
random realistic magnitude (or none: a negative control), then measures it as the
device does: the output angle ``r`` through the AS5043 (10 bit, rounding, gain
mismatch), the frame angle through the HEDL 5540 on the frame motor (eq. 8, floor,
2000 pulses/rev / 226.9), each with white noise below one count.

Experiments (paper Sec. III):

* ``free_oscillation`` -- Fig. 10: pivot at K = 0.7 N m/rad, output released from 0.2 rad,
  frame motor short-circuited, 4.5 s;
* ``constant_current`` -- Fig. 9: 0.5 A on the frame motor for 0.5 s from q2 = -0.4 rad, then 0 A, 1 s;
* ``torque_sweep`` -- Fig. 11 done dynamically: one period of a 0.25 Hz sine of external torque of
  :data:`SWEEP_TORQUE` N m at the low stiffness :data:`SWEEP_K` (K = 1 N m/rad at phi = 0) with the
  frame motor held by a PD voltage loop, 4 s.  The deflection reaches about 0.46 rad, where the
  lever's torque ``K/2 sin(2 phi)`` is far from linear: a spring-stiffness drift scales the torque
  axis of that curve, an AS5043 gain error its deflection axis, so the two are told apart by
  the curve's shape (in the linear range they are look-alikes, both scale the deflection).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vsa_gym.devices.vsaut2.adapter import Vsaut2Adapter
from vsa_gym.devices.vsaut2.effects import LIBRARY as VSAUT2_LIBRARY
from vsa_gym.devices.vsaut2.lever import pivot_for_stiffness
from vsa_gym.devices.vsaut2.params import AS5043Encoder, HEDL5540Encoder, VsaUT2Params
from vsa_gym.identify.effects import draw_planted_effect
from vsa_gym.identify.library import main_parameters, signed_effects, synthetic_ranges
from vsa_gym.identify.record import FORMAT, Record, load_record, write_record
from vsa_gym.identify.recovery import SyntheticBench
from vsa_gym.physics.sensors import floor_quantize, round_quantize

EXPERIMENTS: tuple[str, ...] = ("free_oscillation", "constant_current", "torque_sweep")

#: realistic magnitude ranges per experiment and effect, and the effects whose sign is drawn too (declared in the
#: vsaUT-II's effect library, :mod:`vsa_gym.devices.vsaut2.effects`)
RANGES: dict[str, dict[str, dict[str, tuple[float, float]]]] = {
    exp: synthetic_ranges(VSAUT2_LIBRARY, exp) for exp in EXPERIMENTS}
SIGNED = signed_effects(VSAUT2_LIBRARY)

#: the torque-deflection sweep: stiffness setting (N m/rad at phi = 0) and torque amplitude (N m)
SWEEP_K = 1.0
SWEEP_TORQUE = 0.4

#: white noise before quantisation, in counts of each encoder
NOISE_COUNTS = 0.3


def experiment_meta(experiment: str, params: VsaUT2Params | None = None) -> tuple[dict[str, Any], pd.DataFrame]:
    """Sidecar and input table (outputs zero) of one experiment."""
    p = VsaUT2Params() if params is None else params
    as5043 = AS5043Encoder()
    hedl = HEDL5540Encoder()
    r_out = {"quantity": "r", "unit": "rad", "sensor": "AS5043 10 bit", "quantizer": "round",
             "resolution": float(as5043.resolution)}
    q2_out = {"quantity": "q2", "unit": "rad", "sensor": "HEDL 5540 via GP42C and belt", "at": "motor",
              "quantizer": "floor", "resolution": float(hedl.resolution / p.frame_ratio)}
    base = {"format": FORMAT, "device": "vsaut2", "time": {"column": "t", "unit": "s"},
            "model": {"params": {}, "free": {}, "r_sensor": "AS5043"},
            "split": {"fit": [0.0, 0.6], "validation": [0.6, 0.8], "test": [0.8, 1.0]}}
    if experiment == "free_oscillation":
        dt, dur = 1e-3, 4.5
        q1 = min(float(pivot_for_stiffness(p.lever, 0.7)), float(p.q1_max))
        meta = {**base, "experiment": "free_oscillation_K_min",
                "description": "synthetic Fig. 10: release from 0.2 rad at K = 0.7 N m/rad, frame motor shorted",
                "inputs": {"u1": {"quantity": "voltage_pivot", "unit": "V", "sensor": "amplifier command"},
                           "u2": {"quantity": "voltage_frame", "unit": "V", "sensor": "amplifier command"}},
                "outputs": {"r": r_out}, "initial_state": {"q1": q1, "r": 0.2, "q2": 0.0}}
        t = np.round(np.arange(int(round(dur / dt))) * dt, 9)
        table = pd.DataFrame({"t": t, "u1": 0.0, "u2": 0.0, "r": 0.0})
    elif experiment == "constant_current":
        dt, dur = 1e-3, 1.0
        meta = {**base, "experiment": "constant_current_q2",
                "description": "synthetic Fig. 9: 0.5 A on the frame motor for 0.5 s, current-mode amplifier",
                "inputs": {"i2ref": {"quantity": "current_frame", "unit": "A", "sensor": "current reference"}},
                "outputs": {"q2": q2_out}, "initial_state": {"q1": 0.0, "q2": -0.4, "r": -0.4}}
        t = np.round(np.arange(int(round(dur / dt))) * dt, 9)
        table = pd.DataFrame({"t": t, "i2ref": np.where(t < 0.5, 0.5, 0.0), "q2": 0.0})
    elif experiment == "torque_sweep":
        dt, dur = 1e-3, 4.0
        q1 = float(pivot_for_stiffness(p.lever, SWEEP_K))
        meta = {**base, "experiment": "torque_deflection_sweep",
                "description": f"synthetic Fig. 11: 0.25 Hz external torque sine of {SWEEP_TORQUE} N m at "
                               f"K = {SWEEP_K} N m/rad (deflection into the lever's nonlinear range), frame motor held",
                "inputs": {"tau": {"quantity": "external_torque", "unit": "N m", "sensor": "load cell x arm"}},
                "outputs": {"r": r_out}, "initial_state": {"q1": q1, "r": 0.0, "q2": 0.0}}
        meta["model"] = {**meta["model"], "frame_hold": {"kp": 50.0, "kd": 0.2}}
        t = np.round(np.arange(int(round(dur / dt))) * dt, 9)
        table = pd.DataFrame({"t": t, "tau": SWEEP_TORQUE * np.sin(2 * np.pi * 0.25 * t), "r": 0.0})
    else:
        raise ValueError(f"unknown experiment {experiment!r}; one of {EXPERIMENTS}")
    return meta, table


def draw_effect(experiment: str, effect: str | None, rng: np.random.Generator) -> dict[str, float]:
    if effect is None:
        return {}
    if effect not in RANGES[experiment]:
        raise ValueError(f"no realistic range for {effect!r} in {experiment!r}; have {sorted(RANGES[experiment])}")
    return draw_planted_effect(effect, RANGES[experiment][effect], effect in SIGNED, rng)


def make_vsaut2_record(seed: int, experiment: str = "free_oscillation", effect: str | None = "random",
                       path: str | Path | None = None) -> tuple[Record, dict[str, Any]]:
    """A seeded record with one hidden effect (``"random"``: drawn from :data:`RANGES`; ``None``: none).

    With ``path`` the CSV and its sidecar are written there too.  Returns the checked
    record and the truth ``{"effect", "params"}``.
    """
    rng = np.random.default_rng(seed)
    if effect == "random":
        effect = str(rng.choice(sorted(RANGES[experiment])))
    meta, table = experiment_meta(experiment)
    meta["experiment"] = f"{meta['experiment']}_seed{seed}_{effect or 'none'}"
    rec = load_record("synthetic_vsaut2.csv", meta=meta, table=table)
    truth = draw_effect(experiment, effect, rng)
    ad = Vsaut2Adapter(rec)
    y = ad.simulate({k: np.array([v]) for k, v in truth.items()}, 1)[:, 0, :]
    for j, s in enumerate(ad.outputs):
        spec = meta["outputs"][s.column]
        step = float(spec["resolution"])
        yj = y[:, j] - ad.measurement[j].bias + NOISE_COUNTS * step * rng.standard_normal(y.shape[0])
        table[s.column] = (floor_quantize if spec["quantizer"] == "floor" else round_quantize)(yj, step)
    if path is not None:
        write_record(path, table, meta)
        rec = load_record(path)
    else:
        rec = load_record("synthetic_vsaut2.csv", meta=meta, table=table)
    return rec, {"effect": effect, "params": truth}


def _identify_case(experiment: str, effect: str | None, seed: int) -> tuple[Any, dict[str, Any]]:
    """The recovery bench's case: ``Identifier()`` on the record's own fit/validation parts."""
    from vsa_gym.identify.pipeline import Identifier

    rec, truth = make_vsaut2_record(seed, experiment, effect)
    return Identifier().fit(rec).result_, truth


#: the vsaUT-II's synthetic-recovery bench (:mod:`vsa_gym.identify.recovery`): every ``RANGES`` entry
BENCH = SyntheticBench(catalogue=lambda: [(exp, eff) for exp, effs in RANGES.items() for eff in effs],
                       negative_experiments=lambda: list(EXPERIMENTS), identify_case=_identify_case,
                       main=main_parameters(VSAUT2_LIBRARY))

__all__ = ["BENCH", "EXPERIMENTS", "RANGES", "SWEEP_K", "SWEEP_TORQUE", "draw_effect", "experiment_meta",
           "make_vsaut2_record"]
