"""Planetary gearhead with the load-dependent efficiency law (vsaUT-II Sec. III-C, Table III).

Efficiency law (paper)::

    eta(tau_o) = eta_max * (1 - exp(-alpha |tau_o| / tau_max))

with ``tau_o`` the (ideal) output torque.  The gearhead is a rigid ratio ``n``
(``omega_in = n omega_out``) whose output side is massless -- the gear inertia is
lumped at the input (``J_in``, Table III) -- so the torque it must deliver at the
output equals the load torque ``tau_L`` that the downstream element (belt, sun gear)
exerts back on it.  The torque the gearhead draws from the motor shaft is then

* forward (the motor drives the load, ``tau_L * omega > 0``): ``tau_in = tau_L / (n eta)``
* back-driven (the load drives the motor, ``tau_L * omega < 0``): ``tau_in = tau_L eta / n``

i.e. ``tau_in = tau_L / n + sgn(omega_in) * m`` with a loss magnitude ``m >= 0``: the
loss always opposes the motion, in both power-flow directions, and the dissipated
power ``sgn(omega) m omega`` is never negative.  Two regularisations keep the
right-hand side Lipschitz for the integrators (both tagged ``numerics``):

* ``sgn(omega)`` is ``tanh(omega_in / omega_eps)``;
* the switch between the forward and back-driven magnitudes is blended with
  ``w = (1 + tanh(sgn(omega) tau_L / tau_eps)) / 2``.

Near zero load the forward loss tends to ``tau_max / (n alpha eta_max)``: the
efficiency law implies a no-load drag torque at the motor (3.7 mN m for the GP26B,
19 mN m for the GP42C).

Shapes: arguments broadcast to ``(n,)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.kernels import select
from vsa_gym.physics.parameters import ParameterSet, param


@dataclasses.dataclass(frozen=True)
class GearboxParams(ParameterSet):
    """Gearhead parameters: a generic component, the ratio, rating, efficiency law and inertia without default (a
    device package declares its gearheads as subclasses that set them, e.g.
    :class:`vsa_gym.devices.vsaut2.params.GP42CGearbox`); the two regularisations have numerical defaults."""

    n: float = param(symbol="n", unit="-", source="gearhead datasheet", tag="catalog",
                     lower=1.0, doc="speed reduction ratio")
    tau_max: float = param(symbol="tau_max", unit="N m", source="gearhead datasheet",
                           tag="catalog", lower=0.0, strict_lower=True, doc="max continuous output torque")
    eta_max: float = param(symbol="eta_max", unit="-", source="gearhead datasheet",
                           tag="catalog", lower=0.0, upper=1.0, strict_lower=True, doc="maximum efficiency")
    alpha: float = param(symbol="alpha", unit="-", source="gearhead datasheet", tag="catalog",
                         lower=0.0, strict_lower=True, doc="steepness of the efficiency law")
    J_in: float = param(symbol="J_gb", unit="kg m^2", source="gearhead datasheet",
                        tag="catalog", lower=0.0, doc="gear inertia at the input shaft")
    omega_eps: float = param(2.0, symbol="omega_eps", unit="rad/s", source="regularisation of sgn(omega)",
                             tag="numerics", lower=0.0, strict_lower=True,
                             doc="input speed below which the loss direction is blended")
    tau_eps_frac: float = param(0.05, symbol="tau_eps/tau_max", unit="-",
                                source="regularisation of the power-flow switch", tag="numerics",
                                lower=0.0, strict_lower=True,
                                doc="load-torque blend width, as a fraction of tau_max")


@register_jitable
def efficiency(p: GearboxParams, tau_out: np.ndarray) -> np.ndarray:
    """``eta(tau_o) = eta_max (1 - exp(-alpha |tau_o| / tau_max))`` (dimensionless)."""
    return p.eta_max * (-np.expm1(-p.alpha * np.abs(tau_out) / p.tau_max))


@register_jitable
def _load_over_eta(p: GearboxParams, abs_tau: np.ndarray) -> np.ndarray:
    """``|tau| / eta(|tau|)``, finite at zero load (limit ``tau_max / (alpha eta_max)``)."""
    x = p.alpha * abs_tau / p.tau_max
    safe = select(x > 1e-9, x, 1.0)
    ratio = select(x > 1e-9, safe / (-np.expm1(-safe)), 1.0 + 0.5 * x)
    return ratio * p.tau_max / (p.alpha * p.eta_max)


@register_jitable
def _loss_magnitude_at(p: GearboxParams, tau_load: np.ndarray, s: np.ndarray) -> np.ndarray:
    """:func:`loss_magnitude` given ``s = tanh(omega_in / omega_eps)``.

    The same operations as :func:`_load_over_eta` and :func:`efficiency`, with their common
    ``-expm1(-alpha |tau| / tau_max)`` evaluated once (bit-identical, one transcendental fewer).
    """
    a = np.abs(tau_load)
    x = p.alpha * a / p.tau_max
    em = -np.expm1(-x)  # eta(|tau|) / eta_max
    small = x > 1e-9
    ratio = select(small, x / select(small, em, 1.0), 1.0 + 0.5 * x)
    forward = (ratio * p.tau_max / (p.alpha * p.eta_max) - a) / p.n
    backward = a * (1.0 - p.eta_max * em) / p.n
    w = 0.5 * (1.0 + np.tanh(s * tau_load / (p.tau_eps_frac * p.tau_max)))
    return w * forward + (1.0 - w) * backward


@register_jitable
def loss_magnitude(p: GearboxParams, tau_load: np.ndarray, omega_in: np.ndarray) -> np.ndarray:
    """Loss torque magnitude ``m >= 0`` referred to the input shaft (N m)."""
    return _loss_magnitude_at(p, tau_load, np.tanh(omega_in / p.omega_eps))


@register_jitable
def input_torque(p: GearboxParams, tau_load: np.ndarray, omega_in: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Torque the gearhead draws from its input shaft, and the power it dissipates.

    Args:
        tau_load: torque the load exerts against the output shaft, ``(n,)`` N m.
        omega_in: input (motor) shaft speed, ``(n,)`` rad/s.

    Returns:
        ``(tau_in, p_loss)``: input torque (N m) and dissipated power (W, >= 0).
    """
    s = np.tanh(omega_in / p.omega_eps)  # once: the loss blend and the loss direction share it
    loss = s * _loss_magnitude_at(p, tau_load, s)
    return tau_load / p.n + loss, loss * omega_in


def static_output_torque(p: GearboxParams, tau_in: np.ndarray) -> np.ndarray:
    """Output torque for a given input torque when driving forward (Fig. 8 protocol).

    Solves ``tau_in = tau_o / (n eta(tau_o))`` for ``tau_o`` by bisection; zero below
    the no-load drag ``tau_max / (n alpha eta_max)``.  Shape follows ``tau_in``.
    """
    tin = np.abs(np.asarray(tau_in, dtype=np.float64))
    lo = np.zeros_like(tin)
    hi = p.n * tin
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        need = _load_over_eta(p, mid) / p.n
        too_much = need > tin
        hi = np.where(too_much, mid, hi)
        lo = np.where(too_much, lo, mid)
    drag = p.tau_max / (p.n * p.alpha * p.eta_max)
    out = np.where(tin > drag, 0.5 * (lo + hi), 0.0)
    return np.sign(tau_in) * out
