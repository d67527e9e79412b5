"""Lever arm with two antagonistic springs and a moving pivot (vsaUT-II Sec. II-D, eq. 6).

Geometry (derived in ``parameters.md``): the output engages the lever at radius
``l``; the pivot sits at ``q1`` from the output end; the springs act at the other
end.  With deflection ``phi = r - q2`` and lever ratio ``rho = (l - q1) / q1`` the
spring end moves by ``x = l rho sin(phi)`` and the two springs (rate ``k`` each,
pretension cancelling) store::

    U_s   = k x^2 = k l^2 rho^2 sin^2(phi)
    tau   = -dU/dphi = -k l^2 rho^2 sin(2 phi)         (torque on the output; +tau on the frame)
    K     = 2 k l^2 rho^2 cos(2 phi)                    (eq. 6, output stiffness)
    F_q1  = -dU/dq1 = 2 k l^3 (l - q1) sin^2(phi) / q1^3   (generalised force on the pivot)

``F_q1`` vanishes at ``phi = 0``: stiffness changes cost no spring work there.

Limits, both as stiff, energy-consistent penalty contacts (damped only while engaged):

* spring travel ``|x| <= x_max`` (``U = K_x (|x| - x_max)^2 / 2``, forces by the chain rule
  through ``x(q1, phi)``, so the pivot feels the stop too);
* mechanical end stops on the deflection ``|phi| <= phi_max``.

The stops are smooth penalty contacts (:mod:`vsa_gym.physics.contact`), so the
forces are smooth in the state (no kink on touching a stop).

At ``q1 -> 0`` the lever becomes rigid (``rho -> inf``).  The lever ratio is evaluated
at ``max(q1, q1_min)``; with ``q1_min = 1 mm`` the lever is 100x stiffer than the belt,
so the series stiffness is within 1 % of the belt-limited 948 N m/rad.

Shapes: arguments broadcast to ``(n,)``.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.contact import two_sided_stop
from vsa_gym.physics.kernels import select
from vsa_gym.physics.parameters import ParameterSet, param

#: Smoothing widths of the stops (m, rad) -- numerics, see :mod:`vsa_gym.physics.contact`.
CONTACT_EPS_X = 2e-4
CONTACT_EPS_PHI = 2e-3


@dataclasses.dataclass(frozen=True)
class LeverParams(ParameterSet):
    """Lever, springs and their limits."""

    k: float = param(1886.0, symbol="k", unit="N/m", source="vsaUT-II Sec. III-A", tag="paper",
                     lower=0.0, strict_lower=True, doc="rate of each extension spring")
    l: float = param(0.0620, symbol="l", unit="m",
                     source="calibrated: no-load stiffness variation time 0.78 s (Table IV row 4), "
                            "see vsa_gym.devices.vsaut2.calibration", tag="proposed",
                     lower=0.0, strict_lower=True, doc="lever length")
    q1_min: float = param(1.0e-3, symbol="q1_min", unit="m",
                          source="lever 100x stiffer than the belt there", tag="numerics",
                          lower=0.0, strict_lower=True, doc="smallest pivot distance used in rho")
    x_max: float = param(0.01004, symbol="x_max", unit="m",
                         source="sqrt(E_max / k), E_max = 0.19 J (Table IV row 10)", tag="derived",
                         lower=0.0, strict_lower=True, doc="spring travel limit at the spring end")
    K_x: float = param(3.772e4, symbol="K_x", unit="N/m", source="stop stiffness, 20 k", tag="proposed",
                       lower=0.0, doc="spring-travel stop stiffness")
    D_x: float = param(20.0, symbol="D_x", unit="N s/m", source="stop damping", tag="proposed",
                       lower=0.0, doc="spring-travel stop damping")
    phi_max: float = param(0.6999, symbol="phi_max", unit="rad",
                           source="40.1 deg, Table IV row 13 (max deflection at min stiffness)",
                           tag="derived", lower=0.0, strict_lower=True, doc="deflection end stop")
    K_phi: float = param(200.0, symbol="K_phi", unit="N m/rad", source="end-stop stiffness", tag="proposed",
                         lower=0.0, doc="deflection end-stop stiffness")
    D_phi: float = param(0.5, symbol="D_phi", unit="N m s/rad", source="end-stop damping", tag="proposed",
                         lower=0.0, doc="deflection end-stop damping")


class LeverForces(NamedTuple):
    """Generalised forces of the lever element (all ``(n,)``)."""

    tau_phi: np.ndarray  # torque on the output along +phi (N m); the frame gets -tau_phi
    F_q1: np.ndarray  # force on the pivot along +q1 (N)
    energy: np.ndarray  # stored energy: springs + stop penetration (J)
    p_diss: np.ndarray  # power dissipated in the stops (W, >= 0)
    x: np.ndarray  # spring-end travel (m)


def lever_ratio(p: LeverParams, q1: np.ndarray) -> np.ndarray:
    """``rho = (l - q1) / q1`` evaluated at ``max(q1, q1_min)``."""
    qc = np.maximum(q1, p.q1_min)
    return (p.l - qc) / qc


def spring_stiffness(p: LeverParams, q1: np.ndarray, phi: np.ndarray | float = 0.0) -> np.ndarray:
    """Output stiffness of the springs alone, eq. (6): ``2 k l^2 rho^2 cos(2 phi)`` (N m/rad)."""
    rho = lever_ratio(p, q1)
    return 2.0 * p.k * (p.l * rho) ** 2 * np.cos(2.0 * np.asarray(phi))


def pivot_for_stiffness(p: LeverParams, K: np.ndarray) -> np.ndarray:
    """Inverse of eq. (6) at ``phi = 0``: pivot position giving spring stiffness ``K`` (m)."""
    K = np.asarray(K, dtype=np.float64)
    if np.any(K <= 0):
        raise ValueError(f"stiffness must be > 0 N m/rad, got {K}")
    lrho = np.sqrt(K / (2.0 * p.k))
    return p.l * p.l / (p.l + lrho)  # from l (l - q1)/q1 = lrho


@register_jitable
def lever_forces(
    p: LeverParams, q1: np.ndarray, phi: np.ndarray, q1_dot: np.ndarray, phi_dot: np.ndarray
) -> LeverForces:
    """Spring forces, stop contacts, stored energy and stop dissipation."""
    qc = np.maximum(q1, p.q1_min)
    active = q1 > p.q1_min
    rho = (p.l - qc) / qc
    drho = select(active, -p.l / (qc * qc), 0.0)  # d rho / d q1
    s, c = np.sin(phi), np.cos(phi)
    x = p.l * rho * s
    dx_dphi = p.l * rho * c
    dx_dq1 = p.l * s * drho
    x_dot = dx_dphi * phi_dot + dx_dq1 * q1_dot

    # springs: U = k x^2; smooth penalty stops on the spring travel and the deflection
    stop_x = two_sided_stop(x, x_dot, -p.x_max, p.x_max, p.K_x, p.D_x, CONTACT_EPS_X)
    stop_phi = two_sided_stop(phi, phi_dot, -p.phi_max, p.phi_max, p.K_phi, p.D_phi, CONTACT_EPS_PHI)
    dU_dx = 2.0 * p.k * x - stop_x.force
    tau_phi = -dU_dx * dx_dphi + stop_phi.force
    F_q1 = -dU_dx * dx_dq1
    energy = p.k * x * x + stop_x.energy + stop_phi.energy
    p_diss = stop_x.p_diss + stop_phi.p_diss
    return LeverForces(tau_phi, F_q1, energy, p_diss, x)
