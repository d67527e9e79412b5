"""Sensor-side processing shared by the environments: noise settings, velocity estimates, I^2 t protection.

The sensor *models* (quantisers, noise) are those of :mod:`vsa_gym.physics.sensors`;
this module only holds what a drive's firmware does with them.

* Velocity estimate: backward difference of successive quantised angles over the
  control step, smoothed by a first-order low-pass (cut-off ``f_c``)::

      v_raw = (theta_k - theta_{k-1}) / dt,    v_k = v_{k-1} + (1 - exp(-2 pi f_c dt)) (v_raw - v_{k-1})

* I^2 t over-current protection of each motor (as in the drives' firmware): the
  heating state ``h`` obeys ``dh/dt = i^2 - I_nom^2`` and stays >= 0; the drive
  trips when ``h > (I_max^2 - I_nom^2) t_trip`` -- i.e. after ``t_trip`` seconds at
  the amplifier's peak current.  A trip ends the episode as a failure.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba.extending import register_jitable

NoiseSpec = bool | float | Mapping[str, float] | None


def resolve_noise(spec: NoiseSpec, defaults: Mapping[str, float]) -> dict[str, float]:
    """Per-channel noise standard deviations from the ``sensor_noise`` argument.

    ``None``/``False``/``0``: no additive noise (the quantisers stay: they are the sensors);
    ``True``: the nominal levels ``defaults``; a float: ``defaults`` scaled by it;
    a mapping: per-channel standard deviations (unknown channel names raise).
    """
    if spec is None or spec is False:
        return {k: 0.0 for k in defaults}
    if spec is True:
        return dict(defaults)
    if isinstance(spec, Mapping):
        unknown = set(spec) - set(defaults)
        if unknown:
            raise ValueError(f"sensor_noise: unknown channel(s) {sorted(unknown)}; channels: {sorted(defaults)}")
        out = {k: 0.0 for k in defaults}
        for k, v in spec.items():
            v = float(v)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"sensor_noise[{k!r}] must be a finite standard deviation >= 0, got {v!r}")
            out[k] = v
        return out
    scale = float(spec)
    if not np.isfinite(scale) or scale < 0:
        raise ValueError(f"sensor_noise scale must be finite and >= 0, got {spec!r}")
    return {k: scale * v for k, v in defaults.items()}


def add_noise(values: np.ndarray, sigma: float, rngs: list[np.random.Generator], rows: np.ndarray) -> np.ndarray:
    """``values`` (``(len(rows), ...)``) plus white noise drawn row by row from each row's generator."""
    if sigma == 0.0:
        return values
    out = np.array(values, dtype=np.float64, copy=True)
    for j, i in enumerate(rows):
        out[j] = out[j] + sigma * rngs[int(i)].standard_normal(out[j].shape)
    return out


def lowpass_gain(f_c: float, dt: float) -> float:
    """Discrete first-order low-pass gain ``1 - exp(-2 pi f_c dt)``."""
    return float(1.0 - np.exp(-2.0 * np.pi * f_c * dt))


@register_jitable  # also callable from the environments' compiled steps
def update_velocity(prev_angle: np.ndarray, angle: np.ndarray, v_prev: np.ndarray, dt: float,
                    gain: float) -> np.ndarray:
    """One step of the filtered backward-difference velocity estimate (module docstring)."""
    return v_prev + gain * ((angle - prev_angle) / dt - v_prev)


@register_jitable  # also callable from the environments' compiled steps
def i2t_update(h: np.ndarray, i_rms_sq: np.ndarray, i_nom: np.ndarray | float, dt: float) -> np.ndarray:
    """Advance the I^2 t heating state ``h`` (A^2 s) with the mean squared current over the step."""
    return np.maximum(h + (i_rms_sq - np.asarray(i_nom) ** 2) * dt, 0.0)


@register_jitable  # also callable from the environments' compiled steps
def i2t_limit(i_max: np.ndarray | float, i_nom: np.ndarray | float, t_trip: float) -> np.ndarray:
    """Trip threshold ``(I_max^2 - I_nom^2) t_trip`` (A^2 s)."""
    return (np.asarray(i_max) ** 2 - np.asarray(i_nom) ** 2) * t_trip
