"""Friction components: LuGre (with Stribeck steady state) and Coulomb + viscous.

LuGre model (eLPAS eqs. 5-7; Canudas de Wit et al. 1995), written at the shaft
where the relative speed ``omega`` is measured::

    g(omega)  = F_c + (F_s - F_c) exp(-(omega / omega_s)^2)       Stribeck curve (N m)
    beta      = g(omega) / s0                                      bristle limit (rad)
    dz/dt     = omega - |omega| z / beta                           bristle deflection
    M_fric    = s0 z + s1 dz/dt + s2 omega                         friction moment (N m)

Steady state (``dz/dt = 0``): ``z = beta sign(omega)`` and
``M_ss(omega) = g(omega) sign(omega) + s2 omega``.  Below the break-away level
the bristles behave as a spring of stiffness ``s0`` (presliding).

Stiffness at speed.  The bristle equation is linear in ``z`` with rate
``lambda(omega) = |omega| s0 / g(omega)``, which reaches ~3e4 1/s at the eLPAS
motor's top speed: far outside explicit RK4's stability region at a 0.25 ms
substep.  :func:`exponential_rk4` therefore treats the stiff linear part of selected
state components exactly (exponential time differencing, ETDRK4, with the rate
frozen at the start of each substep) and the remaining, non-stiff part with
the RK4 stages.  With ``omega`` frozen this is the exact exponential update
``z -> z_ss + (z - z_ss) exp(-lambda h)``; the stages add the fourth-order
correction for the variation of ``omega`` within the substep.  It is stable for
any ``lambda h`` and is checked against a Radau reference in the device tests.

The pointwise functions are ``register_jitable``: they run as plain numpy and
inside numba-compiled device cores alike (parameters then come as the named
tuples of :meth:`~vsa_gym.physics.parameters.ParameterSet.as_tuple`).

Shapes: parameters are floats or ``(n,)`` arrays; ``omega`` and ``z`` are
``(n,)`` arrays (or anything broadcastable to them).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numba.extending import register_jitable

# the ETDRK4 step lives with the other integrators (integrate.py); re-exported here for existing importers
from vsa_gym.physics.integrate import exponential_rk4, phi_functions  # noqa: F401
from vsa_gym.physics.parameters import ParameterSet, param


@dataclasses.dataclass(frozen=True)
class LuGreParams(ParameterSet):
    """LuGre friction parameters, at the shaft where ``omega`` is measured.

    A generic component: no defaults (a device declares its friction as a subclass that sets them, with their
    source, e.g. :class:`vsa_gym.devices.elpas.params.ElpasFriction`).
    """

    s0: float = param(symbol="s_0", unit="N m/rad", source="friction identification of the device", tag="proposed",
                      lower=0.0, strict_lower=True, doc="bristle (presliding) stiffness")
    s1: float = param(symbol="s_1", unit="N m s/rad", source="friction identification of the device", tag="proposed",
                      lower=0.0, doc="bristle damping")
    s2: float = param(symbol="s_2", unit="N m s/rad", source="friction identification of the device", tag="proposed",
                      lower=0.0, doc="viscous friction coefficient")
    F_c: float = param(symbol="F_c", unit="N m", source="friction identification of the device", tag="proposed",
                       lower=0.0, strict_lower=True, doc="Coulomb friction level")
    F_s: float = param(symbol="F_s", unit="N m", source="friction identification of the device", tag="proposed",
                       lower=0.0, strict_lower=True, doc="static (stiction) friction level")
    omega_s: float = param(symbol="omega_s", unit="rad/s", source="friction identification of the device",
                           tag="proposed",
                           lower=0.0, strict_lower=True, doc="Stribeck velocity")


@dataclasses.dataclass(frozen=True)
class CoulombViscousParams(ParameterSet):
    """Smoothed Coulomb + viscous friction ``M = F_c tanh(omega / omega_eps) + b omega``."""

    F_c: float = param(0.0, symbol="F_c", unit="N m", source="generic component", tag="proposed",
                       lower=0.0, doc="Coulomb friction level")
    b: float = param(0.0, symbol="b", unit="N m s/rad", source="generic component", tag="proposed",
                     lower=0.0, doc="viscous coefficient")
    omega_eps: float = param(1e-3, symbol="omega_eps", unit="rad/s", source="regularisation",
                             tag="numerics", lower=0.0, strict_lower=True,
                             doc="velocity scale of the tanh regularisation of sign(omega)")


@register_jitable
def stribeck(p: LuGreParams, omega: np.ndarray) -> np.ndarray:
    """``g(omega) = F_c + (F_s - F_c) exp(-(omega/omega_s)^2)`` in N m, shape of ``omega``."""
    return p.F_c + (p.F_s - p.F_c) * np.exp(-((omega / p.omega_s) ** 2))


@register_jitable
def bristle_rate(p: LuGreParams, omega: np.ndarray) -> np.ndarray:
    """Rate of the linear bristle dynamics ``lambda = |omega| s0 / g(omega)`` in 1/s."""
    return np.abs(omega) * p.s0 / stribeck(p, omega)


@register_jitable
def bristle_derivative(p: LuGreParams, omega: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``dz/dt = omega - |omega| z / beta`` (eq. 6) in rad/s."""
    return omega - bristle_rate(p, omega) * z


@register_jitable
def lugre_moment(p: LuGreParams, omega: np.ndarray, z: np.ndarray, zdot: np.ndarray) -> np.ndarray:
    """``M_fric = s0 z + s1 dz/dt + s2 omega`` (eq. 5) in N m, opposing ``omega``."""
    return p.s0 * z + p.s1 * zdot + p.s2 * omega


def steady_state_moment(p: LuGreParams, omega: np.ndarray) -> np.ndarray:
    """Steady sliding friction ``g(omega) sign(omega) + s2 omega`` in N m."""
    omega = np.asarray(omega, dtype=np.float64)
    return stribeck(p, omega) * np.sign(omega) + p.s2 * omega


def steady_state_bristle(p: LuGreParams, omega: np.ndarray) -> np.ndarray:
    """Steady bristle deflection ``z_ss = beta sign(omega) = g(omega) sign(omega) / s0`` in rad."""
    return stribeck(p, omega) * np.sign(omega) / p.s0


def coulomb_viscous_moment(p: CoulombViscousParams, omega: np.ndarray) -> np.ndarray:
    """``F_c tanh(omega / omega_eps) + b omega`` in N m."""
    return p.F_c * np.tanh(omega / p.omega_eps) + p.b * omega
