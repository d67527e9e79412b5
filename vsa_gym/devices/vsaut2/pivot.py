"""Planetary straight-line pivot mechanism of the vsaUT-II (Sec. II-C, III-D).

A planet of pitch diameter ``D_p = D_r / 2`` rolls inside the ring; a point on its
pitch circle moves on a straight line.  The planet is driven through a connection
gear by the sun, so the carrier turns ``gamma`` times the sun angle (eq. 1)::

    gamma = 1 / (1 + (N_r / N_p) (N_c / N_s))                           (eq. 1)
    q1    = D_p (1 - cos(gamma theta_s))                                 (eq. 5)
    dq1/dtheta_s = D_p gamma sin(gamma theta_s)                          (eq. 4)

Inertia reflected to the sun shaft (derived; the planet spins at the carrier rate
relative to the ring for ``D_p = D_r/2``, so both planet terms scale with gamma^2)::

    I_sun,eq = I_s + gamma^2 (I_pc + I_p)

Shapes: arguments broadcast to ``(n,)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.parameters import ParameterSet, param


@dataclasses.dataclass(frozen=True)
class PivotParams(ParameterSet):
    """Straight-line pivot mechanism (vsaUT-II Sec. III-D)."""

    D_p: float = param(45.5e-3, symbol="D_p", unit="m", source="vsaUT-II Sec. III-D", tag="paper",
                       lower=0.0, strict_lower=True, doc="planet pitch diameter (D_r = 2 D_p)")
    N_r: float = param(60.0, symbol="N_r", unit="-", source="vsaUT-II Sec. III-D", tag="paper", lower=1.0,
                       doc="ring gear teeth")
    N_p: float = param(30.0, symbol="N_p", unit="-", source="vsaUT-II Sec. III-D", tag="paper", lower=1.0,
                       doc="planet gear teeth")
    N_c: float = param(31.0, symbol="N_c", unit="-", source="vsaUT-II Sec. III-D", tag="paper", lower=1.0,
                       doc="connection gear teeth")
    N_s: float = param(14.0, symbol="N_s", unit="-", source="vsaUT-II Sec. III-D", tag="paper", lower=1.0,
                       doc="sun gear teeth")
    I_p: float = param(3.0e-5, symbol="I_p", unit="kg m^2", source="vsaUT-II Sec. III-D", tag="paper",
                       lower=0.0, doc="planet gear inertia")
    I_s: float = param(2.4e-7, symbol="I_s", unit="kg m^2", source="vsaUT-II Sec. III-D", tag="paper",
                       lower=0.0, doc="sun gear inertia")
    I_pc: float = param(9.0e-5, symbol="I_pc", unit="kg m^2", source="vsaUT-II Sec. III-D", tag="paper",
                        lower=0.0, doc="displaced planet inertia at the carrier")


@register_jitable
def gear_ratio(p: PivotParams) -> float | np.ndarray:
    """Carrier / sun angle ratio ``gamma`` of eq. (1) (0.1842 for the vsaUT-II)."""
    return 1.0 / (1.0 + (p.N_r / p.N_p) * (p.N_c / p.N_s))


@register_jitable
def pivot_position(p: PivotParams, theta_s: np.ndarray) -> np.ndarray:
    """``q1 = D_p (1 - cos(gamma theta_s))`` in m (eq. 5)."""
    return p.D_p * (1.0 - np.cos(gear_ratio(p) * theta_s))


@register_jitable
def pivot_jacobian(p: PivotParams, theta_s: np.ndarray) -> np.ndarray:
    """``dq1/dtheta_s = D_p gamma sin(gamma theta_s)`` in m/rad (eq. 4)."""
    g = gear_ratio(p)
    return p.D_p * g * np.sin(g * theta_s)


def sun_angle_for(p: PivotParams, q1: np.ndarray) -> np.ndarray:
    """Inverse of eq. (5) on the first half-stroke: sun angle giving pivot position ``q1``."""
    q1 = np.asarray(q1, dtype=np.float64)
    if np.any((q1 < 0) | (q1 > 2 * p.D_p)):
        raise ValueError(f"q1 must lie in [0, 2 D_p] = [0, {2 * p.D_p:.4f}] m, got {q1}")
    return np.arccos(1.0 - q1 / p.D_p) / gear_ratio(p)


def sun_inertia(p: PivotParams) -> float | np.ndarray:
    """Inertia of the mechanism reflected to the sun shaft, ``I_s + gamma^2 (I_pc + I_p)`` (kg m^2)."""
    g = gear_ratio(p)
    return p.I_s + g * g * (p.I_pc + p.I_p)
