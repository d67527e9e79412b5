"""Cone kinematics of the eLPAS: spring length, energy, actuator force, disturbance moment.

Closed forms from the 3-D geometry in parameters.md (pivot O at the origin,
wishbone angle ``alpha``, arm angle ``gamma``; ``b = a + r sin(gamma)``)::

    L^2   = r^2 + h^2 + 2 a^2 (1 - cos a) + 2 a r sin(g) (1 - cos a) - 2 h b sin(a)
    F_s   = F_s0 + C_a (L0 - L),          L0 = sqrt(h^2 + r^2)   (compression spring)
    U     = F_s0 (L0 - L) + C_a (L0 - L)^2 / 2                    (spring energy, U(L0) = 0)

Generalised forces follow by virtual work (``dU/dL = -F_s``):

* ``T_gamma = -dU/dgamma = F_s dL/dgamma = F_s r cos(g) (a (1 - cos a) - h sin a) / L``
  -- the moment the spring exerts on the arm, positive in the +gamma direction.
  It is zero at ``alpha = 0`` for every gamma (the cone); parameters.md writes the
  same closed form with the opposite sign, i.e. the holding moment the drive
  must supply (``M_d = -T_gamma``).
* ``F_act = -dU/dx_ext`` with the suspension extension ``x_ext = -l sin(alpha)``:
  ``F_act = F_s b (h cos a - a sin a) / (L l cos a)``, the force pushing the body
  (at O) and the wheel (at the tip) apart.  ``alpha > 0`` compresses the
  suspension (the tip moves up by ``l sin alpha``).
* effective stiffness ``k_eff = dF_act / d(l sin alpha)`` (positive: the force
  grows with compression), analytic.

All functions are batched: ``gamma`` and ``alpha`` are arrays broadcastable
against each other and the ``(n,)`` parameters; results have the broadcast shape.
The public functions check the angle ranges (``ValueError`` naming the argument
and bound); the ``*_unchecked`` core used inside the right-hand side does not.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.params import ConeGeometry


class SpringState(NamedTuple):
    """Spring quantities at one configuration (all arrays of the broadcast shape)."""

    L: np.ndarray  # spring length (m)
    dL_dgamma: np.ndarray  # m/rad
    dL_dalpha: np.ndarray  # m/rad
    F_s: np.ndarray  # spring compression force (N)
    U: np.ndarray  # spring energy (J)
    F_act: np.ndarray  # actuator force (N)
    T_gamma: np.ndarray  # spring moment on the arm (N m)


@register_jitable
def rest_length(c: ConeGeometry) -> np.ndarray | float:
    """Cone length ``L0 = sqrt(h^2 + r^2)`` (m) at which the spring force is ``F_s0``."""
    return np.sqrt(c.h**2 + c.r**2)


def check_angles(c: ConeGeometry, gamma: np.ndarray | float | None = None,
                 alpha: np.ndarray | float | None = None, slack: float = 1e-9) -> None:
    """Raise ``ValueError`` if gamma or alpha is non-finite or outside its range."""
    for name, value, bound in (("gamma", gamma, c.gamma_max), ("alpha", alpha, c.alpha_max)):
        if value is None:
            continue
        v = np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{name}: must be finite, got {value!r}")
        lim = np.asarray(bound) + slack
        if np.any(np.abs(v) > lim):
            worst = float(np.max(np.abs(v)))
            raise ValueError(
                f"{name}: outside the range [-{np.degrees(np.max(bound)):.4g}, "
                f"{np.degrees(np.max(bound)):.4g}] deg (|{name}| up to {np.degrees(worst):.4g} deg)"
            )


@register_jitable
def spring_unchecked(c: ConeGeometry, gamma: np.ndarray, alpha: np.ndarray) -> SpringState:
    """All spring quantities without range checks (used in the right-hand side)."""
    sg, cg = np.sin(gamma), np.cos(gamma)
    sa, ca = np.sin(alpha), np.cos(alpha)
    b = c.a + c.r * sg
    L2 = c.r**2 + c.h**2 + 2.0 * c.a**2 * (1.0 - ca) + 2.0 * c.a * c.r * sg * (1.0 - ca) - 2.0 * c.h * b * sa
    L = np.sqrt(L2)
    dL_dgamma = c.r * cg * (c.a * (1.0 - ca) - c.h * sa) / L
    dL_dalpha = b * (c.a * sa - c.h * ca) / L
    dL = rest_length(c) - L
    F_s = c.F_s0 + c.C_a * dL
    U = c.F_s0 * dL + 0.5 * c.C_a * dL**2
    F_act = F_s * b * (c.h * ca - c.a * sa) / (L * c.l * ca)
    T_gamma = F_s * dL_dgamma
    return SpringState(L, dL_dgamma, dL_dalpha, F_s, U, F_act, T_gamma)


def effective_stiffness_unchecked(c: ConeGeometry, gamma: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``dF_act / d(l sin alpha)`` (N/m) without range checks.

    With ``A = b (h - a tan alpha) / l`` one has ``F_act = F_s A / L``, ``dF_s = -C_a dL``, so
    ``dF_act/dalpha = (-C_a L' A + F_s A') / L - F_s A L' / L^2``, ``A' = -a b / (l cos^2 alpha)``.
    """
    s = spring_unchecked(c, gamma, alpha)
    ca = np.cos(alpha)
    b = c.a + c.r * np.sin(gamma)
    A = b * (c.h - c.a * np.tan(alpha)) / c.l
    dA = -c.a * b / (c.l * ca**2)
    dF = (-c.C_a * s.dL_dalpha * A + s.F_s * dA) / s.L - s.F_s * A * s.dL_dalpha / s.L**2
    return dF / (c.l * ca)


def spring_state(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> SpringState:
    """All spring quantities at ``(gamma, alpha)`` (rad), range-checked."""
    check_angles(c, gamma, alpha)
    return spring_unchecked(c, np.asarray(gamma, dtype=np.float64), np.asarray(alpha, dtype=np.float64))


def actuator_force(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """``F_act(gamma, alpha)`` in N (force pushing body and wheel apart)."""
    return spring_state(c, gamma, alpha).F_act


def disturbance_moment(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """``T_gamma(gamma, alpha)`` in N m: spring moment on the arm (+gamma direction), at the arm."""
    return spring_state(c, gamma, alpha).T_gamma


def spring_length(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """Spring length ``L`` in m."""
    return spring_state(c, gamma, alpha).L


def spring_force(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """Spring compression force ``F_s`` in N."""
    return spring_state(c, gamma, alpha).F_s


def spring_energy(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """Spring energy ``U`` in J (zero at the cone length ``L0``)."""
    return spring_state(c, gamma, alpha).U


def effective_stiffness(c: ConeGeometry, gamma: np.ndarray | float, alpha: np.ndarray | float) -> np.ndarray:
    """``k_eff = dF_act / d(l sin alpha)`` in N/m (analytic)."""
    check_angles(c, gamma, alpha)
    return effective_stiffness_unchecked(c, np.asarray(gamma, dtype=np.float64),
                                         np.asarray(alpha, dtype=np.float64))


def secant_stiffness(c: ConeGeometry, gamma: np.ndarray | float, alpha_lo: float, alpha_hi: float) -> np.ndarray:
    """Stiffness as the paper measures it (Sec. 5.2): force difference between two alphas.

    ``(F_act(g, alpha_hi) - F_act(g, alpha_lo)) / (l sin alpha_hi - l sin alpha_lo)`` in N/m.
    """
    f_hi = actuator_force(c, gamma, alpha_hi)
    f_lo = actuator_force(c, gamma, alpha_lo)
    return (f_hi - f_lo) / (c.l * (np.sin(alpha_hi) - np.sin(alpha_lo)))
