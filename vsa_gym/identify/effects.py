"""The catalogue of candidate effects and the measurement model.

Each effect is a physical model extension (or a measurement-model term) with
bounded parameters and an "absent" value.  The device adapters
(:mod:`vsa_gym.identify.adapters`) say where an effect acts on their core and
scale the bounds to the record; the generic part lives here.

Measurement effects (``sensor_gain``, ``sensor_offset``, ``sensor_delay``) act on
the simulated output only -- :class:`MeasurementModel` -- and never touch the
physics parameters (as in mujoco.sysid).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

PHYSICS_EFFECTS: tuple[str, ...] = (
    "coulomb_friction", "stribeck_friction", "viscous_friction", "backlash", "transmission_compliance",
    "gearbox_efficiency", "hysteresis", "spring_stiffness_drift", "inertia_error", "force_offset",
)
MEASUREMENT_EFFECTS: tuple[str, ...] = ("sensor_gain", "sensor_offset", "sensor_delay")
CATALOGUE: tuple[str, ...] = PHYSICS_EFFECTS + MEASUREMENT_EFFECTS

DESCRIPTIONS: dict[str, str] = {
    "coulomb_friction": "Coulomb friction",
    "stribeck_friction": "Stribeck friction (steady-state static excess)",
    "viscous_friction": "viscous friction",
    "backlash": "backlash",
    "transmission_compliance": "transmission compliance",
    "gearbox_efficiency": "gearbox efficiency loss",
    "hysteresis": "hysteresis (Dahl)",
    "spring_stiffness_drift": "spring stiffness drift",
    "inertia_error": "inertia error",
    "force_offset": "constant force offset",
    "sensor_gain": "sensor gain error",
    "sensor_offset": "sensor offset",
    "sensor_delay": "sensor delay",
}


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """A fitted parameter: name, unit, bounds, the value meaning "absent", a typical magnitude."""

    name: str
    unit: str
    lower: float
    upper: float
    absent: float = 0.0
    typical: float = 1.0  # magnitude used to start fits and to scale the search
    main: bool = True  # the parameter whose CI must exclude "absent"
    tolerance: float = 0.0  # |value - absent| below this is within the nominal model's own uncertainty
    # (a datasheet inertia is good to a few per cent): a main parameter there is not named as an effect
    check_bound: bool = True  # a fit that leaves it at a bound rejects the effect (False: a shape parameter
    # whose bound is a physical limit, e.g. a lossless back-driven mesh)
    optional: bool = False  # a shape parameter held at ``absent`` (the model's default shape) unless freeing it
    # improves the validation error by the estimator's margin (a free shape can trade against the main
    # parameter where the data hold only their product)
    grid: int = 0  # points of the start grid over a shape's range (0: the estimator's default for an optional
    # shape, the typical value alone for one that is always fitted)
    dead_with: str = ""  # a switch (by name) that, on, leaves this shape out of the equations: held then

    @property
    def switch(self) -> bool:
        """An optional shape whose held default lies outside its fitted range: off at the default, on within
        the range (the drive's ``sticks``: 0 is friction that creeps, 1 friction that sticks)."""
        return self.optional and not self.lower <= self.absent <= self.upper

    @property
    def pinned(self) -> bool:
        """A range of one value (a switch with one "on" state): held there, never fitted."""
        return self.lower == self.upper

    def clip(self, v: float) -> float:
        return float(min(max(v, self.lower), self.upper))


@dataclasses.dataclass(frozen=True)
class EffectSpec:
    name: str
    location: str
    params: tuple[ParamSpec, ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{p.name}" for p in self.params)

    @property
    def description(self) -> str:
        return DESCRIPTIONS.get(self.name, self.name)

    @property
    def main_param(self) -> tuple[str, ParamSpec]:
        """The main parameter (the first marked ``main``): its key and spec."""
        return next((k, p) for k, p in zip(self.keys, self.params, strict=True) if p.main)


@dataclasses.dataclass(frozen=True)
class MeasurementModel:
    """Sensor terms applied to a simulated output: ``y = (1 + gain) x(t - delay) + offset``, then the
    sensor's structure: rectification ``|.|`` and a first-order low-pass of ``filter_hz`` (CED)."""

    rectify: bool = False
    filter_hz: float = 0.0
    bias: float = 0.0  # known mean error of the sensor, e.g. -resolution/2 of a floor quantiser (encoders)

    def apply(self, t: np.ndarray, x: np.ndarray, gain: np.ndarray | None = None, offset: np.ndarray | None = None,
              delay: np.ndarray | None = None) -> np.ndarray:
        """``x``: ``(T, n)`` simulated signal; per-row ``gain``, ``offset``, ``delay`` of shape ``(n,)``."""
        y = np.array(x, dtype=np.float64, copy=True)
        n = y.shape[1]
        if delay is not None:
            d = np.broadcast_to(delay, (n,))
            for i in range(n):
                if d[i] != 0.0:
                    y[:, i] = np.interp(t - d[i], t, x[:, i])
        if self.rectify:
            y = np.abs(y)
        if self.filter_hz > 0.0:
            dt = float(np.median(np.diff(t)))
            a = np.exp(-2 * np.pi * self.filter_hz * dt)
            from scipy.signal import lfilter

            y = lfilter([1 - a], [1, -a], y, axis=0, zi=(a * y[:1]))[0]
        if gain is not None:
            y = y * (1.0 + np.broadcast_to(gain, (n,)))
        if offset is not None:
            y = y + np.broadcast_to(offset, (n,))
        return y + self.bias


def sensor_specs(column: str, y_scale: float, dt: float, duration: float,
                 resolution: float = 0.0) -> dict[str, EffectSpec]:
    """Measurement effects on the output ``column`` (``y_scale``: a typical output amplitude).

    An offset below the sensor's ``resolution`` (one quantiser step) is within what the quantiser
    model can be off by, so it is not named; a delay below half a sample period is within the sample
    clock's own uncertainty (a sample stands for an interval of ``dt``), so it is not named either."""
    loc = f"sensor of {column}"
    return {
        "sensor_gain": EffectSpec("sensor_gain", loc, (ParamSpec("gain", "-", -0.3, 0.3, 0.0, 0.02, tolerance=0.01),)),
        "sensor_offset": EffectSpec("sensor_offset", loc,
                                    (ParamSpec("offset", "", -0.5 * y_scale, 0.5 * y_scale, 0.0, 0.02 * y_scale,
                                               tolerance=resolution),)),
        "sensor_delay": EffectSpec("sensor_delay", loc,
                                   (ParamSpec("delay", "s", 0.0, min(0.05 * duration, 50 * dt), 0.0, 2 * dt,
                                              tolerance=0.5 * dt),)),
    }


def draw_planted_effect(effect: str | None, ranges: Mapping[str, tuple[float, float]], signed: bool,
                        rng: np.random.Generator) -> dict[str, float]:
    """A random magnitude for each parameter of a planted ``effect`` (synthetic records).

    Each parameter ``k`` is drawn uniformly from ``ranges[k] = (lo, hi)``; when ``signed`` its sign
    is then flipped with probability 1/2.  Returns ``{"<effect>.<k>": value}`` (empty when ``effect``
    is None), the truth the identifier must recover.
    """
    if effect is None:
        return {}
    out = {}
    for k, (lo, hi) in ranges.items():
        v = float(rng.uniform(lo, hi))
        if signed and rng.random() < 0.5:
            v = -v
        out[f"{effect}.{k}"] = v
    return out
