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
from collections.abc import Callable, Sequence

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.parameters import ParameterSet, param

Rhs = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclasses.dataclass(frozen=True)
class LuGreParams(ParameterSet):
    """LuGre friction parameters, at the shaft where ``omega`` is measured.

    Defaults: eLPAS Table 1 (friction at the motor shaft, before the reductor).
    """

    s0: float = param(15.0, symbol="s_0", unit="N m/rad", source="eLPAS Table 1", tag="paper",
                      lower=0.0, strict_lower=True, doc="bristle (presliding) stiffness")
    s1: float = param(0.1, symbol="s_1", unit="N m s/rad", source="eLPAS Table 1", tag="paper",
                      lower=0.0, doc="bristle damping")
    s2: float = param(0.0042, symbol="s_2", unit="N m s/rad", source="eLPAS Table 1", tag="paper",
                      lower=0.0, doc="viscous friction coefficient")
    F_c: float = param(0.2, symbol="F_c", unit="N m", source="eLPAS Table 1", tag="paper",
                       lower=0.0, strict_lower=True, doc="Coulomb friction level")
    F_s: float = param(0.555, symbol="F_s", unit="N m", source="eLPAS Table 1", tag="paper",
                       lower=0.0, strict_lower=True, doc="static (stiction) friction level")
    omega_s: float = param(11.8, symbol="omega_s", unit="rad/s", source="eLPAS Table 1", tag="paper",
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


@register_jitable
def phi_functions(zeta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``exp(zeta)`` and ``phi_k(zeta) = (exp(zeta) - sum_{j<k} zeta^j / j!) / zeta^k`` for k = 1, 2, 3.

    ``phi_3`` from its Taylor series for ``|zeta| < 0.1`` (truncation < 1e-11
    relative) and from the closed form elsewhere; ``phi_2 = 1/2 + zeta phi_3`` and
    ``phi_1 = 1 + zeta phi_2`` by the exact recurrence, so nothing cancels at
    ``zeta -> 0`` (``zeta = 0`` gives 1, 1/2, 1/6).
    """
    z = np.asarray(zeta, dtype=np.float64)
    ez = np.exp(z)
    small = np.abs(z) < 0.1
    zl = np.where(small, 1.0, z)
    series = 1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z * (1.0 / 720.0 + z * (1.0 / 5040.0 + z / 40320.0))))
    p3 = np.where(small, series, (ez - 1.0 - zl - 0.5 * zl * zl) / (zl * zl * zl))
    p2 = 0.5 + z * p3
    p1 = 1.0 + z * p2
    return ez, p1, p2, p3


def exponential_rk4(
    rhs: Rhs,
    x: np.ndarray,
    dt: float,
    n_sub: int,
    stiff: Sequence[int],
    rates: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """Exponential RK4 (ETDRK4, Cox & Matthews 2002) with a stiff linear decay on some components.

    For each component ``j`` in ``stiff`` the right-hand side is split as
    ``dx_j/dt = -lam_j x_j + N_j(x)`` with ``N_j = dx_j/dt + lam_j x_j``, where
    ``lam = rates(x)`` (shape ``(n, len(stiff))``, 1/s, >= 0) is evaluated at the
    start of each substep and held.  The linear part is integrated exactly through
    the phi-functions, so the scheme is stable for any ``lam h`` and exact when
    ``N`` is constant (an exact relaxation ``z -> z_ss + (z - z_ss) exp(-lam h)``
    with ``omega`` frozen is the special case of a constant ``N``).  The other
    components see ``lam = 0``, for which ETDRK4 *is* classical RK4.  The power
    channels are integrated with the RK4 weights over the same stages.

    Args:
        rhs: ``x -> (dxdt, power)`` with ``x`` of shape ``(n, n_states)`` and
            ``power`` of shape ``(n, n_channels)``.
        x: state ``(n, n_states)``.
        dt: step length (s), split into ``n_sub`` substeps.
        stiff: indices of the components with a stiff linear decay.
        rates: ``x -> lam``.

    Returns:
        ``(x_new, energy)``: the state after ``dt`` and the integral of every power
        channel over ``dt`` (J), shapes ``(n, n_states)`` and ``(n, n_channels)``.
    """
    if n_sub < 1:
        raise ValueError(f"n_sub must be >= 1, got {n_sub}")
    idx = np.asarray(stiff, dtype=np.intp)
    h = dt / n_sub
    energy: np.ndarray | None = None
    for _ in range(n_sub):
        lam = rates(x)
        e_half, p1_half, _, _ = phi_functions(-0.5 * h * lam)
        e_full, p1, p2, p3 = phi_functions(-h * lam)
        f_u = p1 - 3.0 * p2 + 4.0 * p3
        f_ab = 2.0 * (p2 - 2.0 * p3)
        f_c = 4.0 * p3 - p2
        w_half = 0.5 * h * p1_half
        xs = x[:, idx]

        k1, q1 = rhs(x)
        n1 = k1[:, idx] + lam * xs
        xa = x + 0.5 * h * k1
        xa[:, idx] = e_half * xs + w_half * n1
        k2, q2 = rhs(xa)
        n2 = k2[:, idx] + lam * xa[:, idx]
        xb = x + 0.5 * h * k2
        xb[:, idx] = e_half * xs + w_half * n2
        k3, q3 = rhs(xb)
        n3 = k3[:, idx] + lam * xb[:, idx]
        xc = x + h * k3
        xc[:, idx] = e_half * xa[:, idx] + w_half * (2.0 * n3 - n1)
        k4, q4 = rhs(xc)
        n4 = k4[:, idx] + lam * xc[:, idx]
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x[:, idx] = e_full * xs + h * (f_u * n1 + f_ab * (n2 + n3) + f_c * n4)
        de = (h / 6.0) * (q1 + 2.0 * q2 + 2.0 * q3 + q4)
        energy = de if energy is None else energy + de
    assert energy is not None
    return x, energy
