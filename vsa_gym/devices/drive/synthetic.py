"""Seeded "measured" records from a truth model with one hidden effect (for tests and the benchmark).

:func:`make_drive_record` simulates the generic drive with one catalogue effect of
random magnitude (or none: a negative control) through the same adapter the
pipeline uses, then adds the sensor's quantisation and white noise.  It returns the
checked :class:`~vsa_gym.identify.record.Record` and the truth (effect, parameters).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from vsa_gym.devices.drive.adapter import DriveAdapter
from vsa_gym.devices.drive.effects import LIBRARY as DRIVE_LIBRARY
from vsa_gym.devices.drive.effects import SYNTHETIC
from vsa_gym.identify.effects import draw_planted_effect
from vsa_gym.identify.library import signed_effects, synthetic_ranges
from vsa_gym.identify.record import FORMAT, Record, load_record
from vsa_gym.physics.sensors import floor_quantize

#: realistic magnitude ranges per effect of the drive, and the effects whose sign is drawn too (declared in the
#: drive's effect library, :mod:`vsa_gym.devices.drive.effects`)
DRIVE_RANGES: dict[str, dict[str, tuple[float, float]]] = synthetic_ranges(DRIVE_LIBRARY, SYNTHETIC)
SIGNED = signed_effects(DRIVE_LIBRARY)
DRIVE_EFFECTS: tuple[str, ...] = tuple(DRIVE_RANGES)

ENCODER_STEP = 1e-5  # m
NOISE_STD = 2e-5  # m


def drive_meta(experiment: str = "synthetic_drive") -> dict[str, Any]:
    """Sidecar of a synthetic drive record: a 2 kg axis, 20 N s/m, 10 N/V, position encoder."""
    return {
        "format": FORMAT, "device": "drive", "experiment": experiment,
        "description": "synthetic record: generic drive (2 kg, 20 N s/m, 10 N/V), voltage multisine, open loop",
        "time": {"column": "t", "unit": "s"},
        "inputs": {"u": {"quantity": "voltage", "unit": "V", "sensor": "amplifier command"}},
        "outputs": {"x": {"quantity": "position", "unit": "m", "sensor": "linear encoder 10 um + noise",
                          "resolution": ENCODER_STEP, "quantizer": "floor"}},
        "replay": "open_loop",
        "model": {"motion": "translational", "params": {"m": 2.0, "b": 20.0, "k_u": 10.0, "v_eps": 2e-3},
                  "free": {}},
        "initial_state": {"position": 0.0, "velocity": 0.0},
        "split": {"fit": [0.0, 0.6], "validation": [0.6, 0.8], "test": [0.8, 1.0]},
    }


def _input(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    freqs = np.array([0.4, 0.7, 1.1, 1.9, 3.1, 5.3])
    amps = rng.uniform(0.4, 1.0, freqs.size) / np.sqrt(freqs)
    ph = rng.uniform(0, 2 * np.pi, freqs.size)
    u = (amps[:, None] * np.sin(2 * np.pi * freqs[:, None] * t[None, :] + ph[:, None])).sum(0)
    return 2.0 * u / np.max(np.abs(u))


def draw_effect(effect: str | None, rng: np.random.Generator) -> dict[str, float]:
    """A random magnitude of ``effect`` from :data:`DRIVE_RANGES` (see :func:`draw_planted_effect`)."""
    return draw_planted_effect(effect, DRIVE_RANGES[effect] if effect else {}, effect in SIGNED, rng)


def make_drive_record(seed: int, effect: str | None = "random", duration: float = 4.0, dt: float = 1e-3,
                      ) -> tuple[Record, dict[str, Any]]:
    """A seeded record with one hidden effect (``"random"``: drawn from :data:`DRIVE_EFFECTS`; ``None``: none)."""
    rng = np.random.default_rng(seed)
    if effect == "random":
        effect = str(rng.choice(DRIVE_EFFECTS))
    t = np.round(np.arange(int(round(duration / dt))) * dt, 9)
    u = _input(rng, t)
    meta = drive_meta(f"synthetic_drive_seed{seed}_{effect or 'none'}")
    table = pd.DataFrame({"t": t, "u": u, "x": np.zeros_like(t)})
    rec = load_record("synthetic.csv", meta=meta, table=table)
    truth = draw_effect(effect, rng)
    ad = DriveAdapter(rec)
    # the truth before the sensor's quantiser (the adapter's model of the quantiser bias is taken out)
    y = ad.simulate({k: np.array([v]) for k, v in truth.items()}, 1)[:, 0, 0] - ad.measurement[0].bias
    y = y + NOISE_STD * rng.standard_normal(y.shape)
    y = floor_quantize(y, ENCODER_STEP)
    table["x"] = y
    rec = load_record("synthetic.csv", meta=meta, table=table)
    return rec, {"effect": effect, "params": truth}
