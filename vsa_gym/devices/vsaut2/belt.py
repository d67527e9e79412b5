"""Timing belt between two pulleys as a linear compliance (vsaUT-II Sec. III-E).

The input pulley (``z_in`` = 22 teeth, on the gearhead) and the output pulley
(``z_out`` = 32 teeth, radius ``r_op``, on the frame q2) are linked by a belt modelled
as a spring on the difference of their tangential displacements::

    r_ip    = r_op z_in / z_out
    delta   = r_ip theta_ip - r_op q2           (belt stretch, m)
    F_belt  = C_belt delta                       (N)
    tau_q2  = +r_op F_belt                       (torque on the frame)
    tau_ip  = -r_ip F_belt                       (torque on the input pulley)
    U_belt  = C_belt delta^2 / 2

``C_belt = K_max / r_op^2`` turns the measured maximum output stiffness 948 N m/rad
into a belt rate of 564 kN/m.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.parameters import ParameterSet, param


@dataclasses.dataclass(frozen=True)
class BeltParams(ParameterSet):
    """Timing-belt transmission."""

    C_belt: float = param(5.6395e5, symbol="C_belt", unit="N/m", source="K_max / r_op^2, Sec. III-E",
                          tag="derived", lower=0.0, strict_lower=True, doc="belt linear stiffness")
    r_op: float = param(41e-3, symbol="r_op", unit="m", source="vsaUT-II Sec. III-E", tag="paper",
                        lower=0.0, strict_lower=True, doc="output pulley radius")
    z_in: float = param(22.0, symbol="z_in", unit="-", source="vsaUT-II Sec. III-E", tag="paper",
                        lower=1.0, doc="input pulley teeth (on the gearhead)")
    z_out: float = param(32.0, symbol="z_out", unit="-", source="vsaUT-II Sec. III-E", tag="paper",
                         lower=1.0, doc="output pulley teeth (on the frame)")


def belt_ratio(p: BeltParams) -> float | np.ndarray:
    """Speed reduction from input pulley to frame, ``z_out / z_in`` (32/22 = 1.4545)."""
    return p.z_out / p.z_in


@register_jitable
def input_pulley_radius(p: BeltParams) -> float | np.ndarray:
    """``r_ip = r_op z_in / z_out`` (m)."""
    return p.r_op * p.z_in / p.z_out


def belt_stretch(p: BeltParams, theta_ip: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """``delta = r_ip theta_ip - r_op q2`` (m)."""
    return input_pulley_radius(p) * theta_ip - p.r_op * q2


@register_jitable
def belt_force(p: BeltParams, delta: np.ndarray) -> np.ndarray:
    """Linear belt force ``C_belt delta`` (N)."""
    return p.C_belt * delta


def belt_stiffness_at_frame(p: BeltParams) -> float | np.ndarray:
    """Rotational stiffness of the belt seen at the frame, ``C_belt r_op^2`` (N m/rad)."""
    return p.C_belt * p.r_op**2


def series_stiffness(K_spring: float | np.ndarray, K_belt: float | np.ndarray) -> float | np.ndarray:
    """Output stiffness of the lever springs in series with the belt, ``K_s K_b / (K_s + K_b)`` (N m/rad).

    Element-wise; ``K_spring`` is eq. (6) at the current deflection, ``K_belt`` is
    :func:`belt_stiffness_at_frame`.  The belt caps the output stiffness (the paper's 948 N m/rad).
    """
    return K_spring * K_belt / (K_spring + K_belt)
