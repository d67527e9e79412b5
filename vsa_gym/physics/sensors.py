"""Sensor models, kept apart from the physics (measurement = f(true state)).

* Incremental encoder (vsaUT-II eq. 8): ``p = floor(theta * N / 2 pi)``, reported as
  ``p * 2 pi / N`` -- a floor quantiser with ``N`` pulses per revolution (2000 for the
  HEDL 5540 in quadrature).
* Absolute magnetic encoder (AS5043, 10 bit): a uniform quantiser of step
  ``2 pi / 2^bits`` applied to the angle plus its gain-mismatch error.  A mismatch of
  the sine/cosine channel gains gives an angle error periodic in twice the angle;
  it is modelled as ``e(theta) = A_gm sin(2 theta)`` with ``A_gm = 0.15 deg``
  (paper, after the AS5043 error model it cites).
* Additive white noise for any analog channel (current, force), off by default.

Every sensor has ``enabled``: when false the sensor returns the true value, so
tests and identification can separate measurement effects from physics.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.parameters import ParameterSet, param


@register_jitable
def floor_quantize(x: Any, step: float) -> Any:
    """``floor(x / step) step``: what an incremental encoder (or any floor quantiser) reads; ``step = 0``: exact.

    Jitable: the environments' compiled sensing and the numpy sensors and record generators call the same
    function, on scalars or arrays.
    """
    if step == 0.0:
        return x
    return np.floor(x / step) * step


@register_jitable
def round_quantize(x: Any, step: float) -> Any:
    """``round(x / step) step``: a rounding quantiser (an absolute encoder, an ADC); ``step = 0``: exact."""
    if step == 0.0:
        return x
    return np.round(x / step) * step


@register_jitable
def absolute_encoder_angle(theta: Any, step: float, gain_mismatch: float) -> Any:
    """An absolute magnetic encoder's reading: ``theta + A_gm sin(2 theta)`` rounded to ``step``; ``step = 0``:
    exact."""
    if step == 0.0:
        return theta
    return round_quantize(theta + gain_mismatch * np.sin(2.0 * theta), step)


@dataclasses.dataclass(frozen=True)
class IncrementalEncoder(ParameterSet):
    """Quadrature incremental encoder, eq. (8) of the vsaUT-II paper (a floor quantiser); the resolution has no
    default (the device's encoder sets it, e.g. :class:`vsa_gym.devices.vsaut2.params.HEDL5540Encoder`)."""

    pulses_per_rev: float = param(symbol="N_enc", unit="1/rev", source="encoder datasheet",
                                  tag="catalog", lower=1.0, doc="pulses per revolution (quadrature)")
    enabled: bool = True

    def measure(self, theta: np.ndarray) -> np.ndarray:
        """Quantised angle ``floor(theta N / 2 pi) 2 pi / N`` (rad); shape of ``theta``."""
        if not self.enabled:
            return np.asarray(theta, dtype=np.float64)
        return floor_quantize(np.asarray(theta), 2.0 * np.pi / self.pulses_per_rev)

    @property
    def resolution(self) -> float | np.ndarray:
        return 2.0 * np.pi / self.pulses_per_rev


@dataclasses.dataclass(frozen=True)
class AbsoluteEncoder(ParameterSet):
    """Absolute magnetic encoder with gain-mismatch error (a rounding quantiser); resolution and error have no
    default (the device's encoder sets them, e.g. :class:`vsa_gym.devices.vsaut2.params.AS5043Encoder`)."""

    bits: float = param(symbol="b", unit="bit", source="encoder datasheet", tag="catalog", lower=1.0,
                        doc="resolution in bits (0.35 deg/step for 10 bit)")
    gain_mismatch: float = param(symbol="A_gm", unit="rad", source="encoder datasheet",
                                 tag="catalog", lower=0.0, doc="amplitude of the gain-mismatch angle error")
    enabled: bool = True

    def measure(self, theta: np.ndarray) -> np.ndarray:
        """Quantised angle with gain-mismatch error (rad); shape of ``theta``."""
        theta = np.asarray(theta, dtype=np.float64)
        if not self.enabled:
            return theta
        return absolute_encoder_angle(theta, 2.0 * np.pi / 2.0**self.bits, self.gain_mismatch)

    @property
    def resolution(self) -> float | np.ndarray:
        return 2.0 * np.pi / 2.0**self.bits


@dataclasses.dataclass(frozen=True)
class AnalogSensor(ParameterSet):
    """An analog channel with additive Gaussian noise (standard deviation ``sigma``)."""

    sigma: float = param(0.0, symbol="sigma", unit="signal unit", source="user choice", tag="proposed",
                         lower=0.0, doc="noise standard deviation")
    enabled: bool = True

    def measure(self, value: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        value = np.asarray(value, dtype=np.float64)
        if not self.enabled or rng is None or np.all(np.asarray(self.sigma) == 0.0):
            return value
        return value + self.sigma * rng.standard_normal(value.shape)
