"""Seeded synthetic eLPAS rig records -- the paper's sine and step force tests -- with one hidden effect.

The truth is replayed through the same closed loop the identifier uses
(:class:`vsa_gym.devices.elpas.adapter.ElpasAdapter`: the paper's cascade, the 10 kHz
current loop, the compiled core) with one effect of random magnitude (or none: a
negative control), then the force sensor's white noise (5 N, the environments'
default) is added; ``gamma`` is the simulated motor encoder (2000 pulses/rev at the motor).

* ``"sine"``: ``F_ref = 2555 N + A sin(2 pi f t)`` with ``A`` in 500-700 N and ``f`` in 0.8-1.5 Hz,
  the hydropulse moving alpha slowly (:func:`hydropulse_alpha`);
* ``"step"``: a staircase of force levels in 1800-3300 N, one every 0.4 s, the same alpha motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from vsa_gym.devices.elpas.adapter import ElpasAdapter
from vsa_gym.devices.elpas.effects import LIBRARY as ELPAS_LIBRARY
from vsa_gym.devices.elpas.effects import RIG
from vsa_gym.identify.effects import draw_planted_effect
from vsa_gym.identify.library import main_parameters, signed_effects, synthetic_ranges
from vsa_gym.identify.record import FORMAT, Record, load_record
from vsa_gym.identify.recovery import SyntheticBench
from vsa_gym.physics.sensors import floor_quantize

#: realistic magnitude ranges per effect, and the effects whose sign is drawn too (declared in the eLPAS's effect
#: library, :mod:`vsa_gym.devices.elpas.effects`)
ELPAS_RANGES: dict[str, dict[str, tuple[float, float]]] = synthetic_ranges(ELPAS_LIBRARY, RIG)
SIGNED = signed_effects(ELPAS_LIBRARY)
FORCE_NOISE = 5.0  # N
GAMMA_STEP = 2 * np.pi / 2000 / 59.0  # rad, motor encoder seen at the arm


def elpas_meta(experiment: str) -> dict[str, Any]:
    """Sidecar of a synthetic rig force test (nominal eLPAS, the paper's cascade at 1 kHz)."""
    return {
        "format": FORMAT, "device": "elpas", "experiment": experiment,
        "description": "synthetic eLPAS hydropulse-rig force test "
                       "(closed loop, the paper's cascade), alpha moved slowly",
        "time": {"column": "t", "unit": "s"},
        "inputs": {"F_ref": {"quantity": "force_reference", "unit": "N", "sensor": "controller reference"},
                   "alpha": {"quantity": "alpha", "unit": "rad", "sensor": "hydropulse (imposed)"}},
        "outputs": {"F": {"quantity": "force", "unit": "N", "sensor": "force sensor, 5 N noise"},
                    "gamma": {"quantity": "gamma", "unit": "rad", "sensor": "motor encoder 2000 pulses/rev / N",
                              "resolution": GAMMA_STEP, "quantizer": "floor"}},
        "controller": {"type": "elpas_cascade"},
        "replay": "closed_loop",
        "model": {"params": {}},
        "split": {"fit": [0.0, 0.6], "validation": [0.6, 0.8], "test": [0.8, 1.0]},
    }


def force_reference(kind: str, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    if kind == "sine":
        A, f = rng.uniform(500.0, 700.0), rng.uniform(0.8, 1.5)
        return 2555.0 + A * np.sin(2 * np.pi * f * t)
    if kind == "step":
        n_lev = int(np.ceil(t[-1] / 0.4)) + 1
        levels = rng.uniform(1800.0, 3300.0, n_lev)
        return levels[np.minimum((t / 0.4).astype(int), n_lev - 1)]
    raise ValueError(f"kind must be 'sine' or 'step', got {kind!r}")


def hydropulse_alpha(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """The hydropulse moves the wishbone slowly: ``alpha = A sin(2 pi f t)``, A in 6-10 deg, f in 0.3-0.5 Hz
    (at alpha = 0 the cone spring keeps its length whatever gamma, so C_a would be invisible)."""
    A, f = np.deg2rad(rng.uniform(6.0, 10.0)), rng.uniform(0.3, 0.5)
    return A * np.sin(2 * np.pi * f * t)


def draw_effect(effect: str | None, rng: np.random.Generator) -> dict[str, float]:
    """A random magnitude of ``effect`` from :data:`ELPAS_RANGES` (see :func:`draw_planted_effect`)."""
    return draw_planted_effect(effect, ELPAS_RANGES[effect] if effect else {}, effect in SIGNED, rng)


def make_elpas_record(seed: int, effect: str | None = "random", kind: str = "sine", duration: float = 3.0,
                      dt: float = 1e-3, truth: dict[str, float] | None = None) -> tuple[Record, dict[str, Any]]:
    """A seeded rig record with one hidden effect (``"random"``: drawn from :data:`ELPAS_RANGES`; ``None``: none).

    ``truth`` (optional) fixes the effect's parameters instead of drawing them (e.g. the same
    device for the sine and the step test).
    """
    rng = np.random.default_rng(seed)
    if effect == "random":
        effect = str(rng.choice(list(ELPAS_RANGES)))
    t = np.round(np.arange(int(round(duration / dt))) * dt, 9)
    f_ref = force_reference(kind, rng, t)
    meta = elpas_meta(f"synthetic_elpas_{kind}_seed{seed}_{effect or 'none'}")
    alpha = hydropulse_alpha(rng, t)
    table = pd.DataFrame({"t": t, "F_ref": f_ref, "alpha": alpha, "F": np.zeros_like(t),
                          "gamma": np.zeros_like(t)})
    drawn = draw_effect(effect, rng)
    truth = drawn if truth is None else dict(truth)
    rec = load_record("synthetic.csv", meta=meta, table=table)
    ad = ElpasAdapter(rec)
    ad.quantised_feedback = True  # the truth: the controller sees the real encoders
    ad.gamma0 = float(ad._cascade().lookup(f_ref[:1])[0])  # at rest on the lookup of the first reference
    y = ad.simulate({k: np.array([v]) for k, v in truth.items()}, 1)[:, 0, :]
    table["F"] = y[:, 0] + FORCE_NOISE * rng.standard_normal(len(t))
    gamma = y[:, 1] - ad.measurement[1].bias  # undo the adapter's model of the quantiser, then quantise
    table["gamma"] = floor_quantize(gamma, GAMMA_STEP)
    meta["initial_state"] = {"gamma": ad.gamma0}
    rec = load_record("synthetic.csv", meta=meta, table=table)
    return rec, {"effect": effect, "params": truth}


ELPAS_DURATION = 1.5  # s, each force test of the recovery bench (fit and held-out)
ELPAS_IDENTIFIER: dict[str, int] = {"n_fit": 2, "max_nfev": 15}  # the bench's identifier settings


def _identify_case(experiment: str, effect: str | None, seed: int) -> tuple[Any, dict[str, Any]]:
    """The recovery bench's case: fit on a sine or step force test, score on the other kind of test of the same
    device (same planted parameters, another seed)."""
    from vsa_gym.identify.pipeline import Identifier

    held_out = {"sine": "step", "step": "sine"}[experiment]
    rec, truth = make_elpas_record(seed, effect, experiment, duration=ELPAS_DURATION)
    test, _ = make_elpas_record(seed + 1000, effect, held_out, duration=ELPAS_DURATION, truth=truth["params"])
    return Identifier(**ELPAS_IDENTIFIER).fit(rec, test).result_, truth


#: the eLPAS's synthetic-recovery bench (:mod:`vsa_gym.identify.recovery`)
BENCH = SyntheticBench(catalogue=lambda: [("sine", eff) for eff in ELPAS_RANGES],
                       negative_experiments=lambda: ["sine"], identify_case=_identify_case,
                       main=main_parameters(ELPAS_LIBRARY))

__all__ = ["BENCH", "ELPAS_DURATION", "ELPAS_IDENTIFIER", "ELPAS_RANGES", "elpas_meta", "make_elpas_record"]
