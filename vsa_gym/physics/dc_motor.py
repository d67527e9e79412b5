"""Brushed (or brushless, per-phase-equivalent) DC motor with its amplifier limits.

Equations (vsaUT-II Sec. III-B; eLPAS eqs. 1-4)::

    L di/dt = u_eff - k_e * omega - R * i              (armature circuit)
    tau_m   = k_t * i - b * omega                       (shaft torque after viscous friction)
    P_el    = u_eff * i                                 (power drawn from the supply; < 0 regenerates)

The amplifier limits act on the applied voltage ``u_eff`` (a voltage-foldback
current limiter, as a current-limited H-bridge behaves):

    u_hi = min(U_max,  R I_max + k_e omega)
    u_lo = max(-U_max, -R I_max + k_e omega)
    u_eff = min(max(u, u_lo), u_hi)

so ``|u_eff| <= U_max`` always and, at ``|i| = I_max``, ``di/dt`` can no longer push
the current outward; the current therefore never exceeds ``I_max`` once inside.
The map is continuous in ``(u, i, omega)``, which keeps the right-hand side
Lipschitz for the integrators.

Shapes: every argument is a float or an array broadcastable to ``(n,)``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numba.extending import register_jitable

from vsa_gym.physics.kernels import select
from vsa_gym.physics.parameters import ParameterSet, param


@dataclasses.dataclass(frozen=True)
class DCMotorParams(ParameterSet):
    """Parameters of one DC motor and its amplifier.

    A generic component: the motor's constants have no default (a device package declares its motors as
    subclasses that set them, with their datasheet source, e.g. :class:`vsa_gym.devices.vsaut2.params.RE40Motor`).
    """

    L: float = param(symbol="L", unit="H", source="motor datasheet", tag="catalog",
                     lower=0.0, strict_lower=True, doc="armature inductance")
    R: float = param(symbol="R", unit="ohm", source="motor datasheet", tag="catalog",
                     lower=0.0, strict_lower=True, doc="armature resistance")
    k_t: float = param(symbol="k_t", unit="N m/A", source="motor datasheet",
                       tag="catalog", lower=0.0, strict_lower=True, doc="torque constant")
    k_e: float = param(symbol="k_e", unit="V s/rad", source="motor datasheet",
                       tag="catalog", lower=0.0, strict_lower=True, doc="back-EMF constant")
    J: float = param(symbol="J_m", unit="kg m^2", source="motor datasheet",
                     tag="catalog", lower=0.0, strict_lower=True, doc="rotor inertia")
    b: float = param(symbol="b_m", unit="N m s/rad", source="motor datasheet",
                     tag="catalog", lower=0.0, doc="rotor viscous friction")
    U_max: float = param(symbol="U_max", unit="V", source="amplifier / supply", tag="catalog",
                         lower=0.0, strict_lower=True, doc="supply voltage limit")
    I_max: float = param(symbol="I_max", unit="A", source="amplifier datasheet", tag="catalog",
                         lower=0.0, strict_lower=True, doc="amplifier current limit")


@register_jitable
def applied_voltage(p: DCMotorParams, u: np.ndarray, i: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Voltage the amplifier actually applies, ``u_eff`` (see module docstring). Shape ``(n,)``."""
    emf = p.k_e * omega
    u_hi = np.minimum(p.U_max, p.R * p.I_max + emf)
    u_lo = np.maximum(-p.U_max, -p.R * p.I_max + emf)
    return np.minimum(np.maximum(u, u_lo), u_hi)


@register_jitable
def current_derivative(p: DCMotorParams, u_eff: np.ndarray, i: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """``di/dt = (u_eff - k_e omega - R i) / L`` in A/s."""
    return (u_eff - p.k_e * omega - p.R * i) / p.L


@register_jitable
def shaft_torque(p: DCMotorParams, i: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Electromagnetic torque minus rotor viscous friction, ``k_t i - b omega`` in N m."""
    return p.k_t * i - p.b * omega


def steady_state_speed(p: DCMotorParams, u: float, load_torque: float = 0.0) -> float:
    """Speed at which ``k_t i = b omega + load_torque`` with ``i = (u - k_e omega)/R`` (rad/s).

    The motor's static torque-speed characteristic at voltage ``u``; ``load_torque`` is what
    the shaft must deliver (a friction or a gearbox's input torque).
    """
    return float((p.k_t * u / p.R - load_torque) / (p.b + p.k_t * p.k_e / p.R))


def current_control_voltage(
    p: DCMotorParams, i_ref: np.ndarray, i: np.ndarray, omega: np.ndarray, bandwidth_hz: float = 1000.0
) -> np.ndarray:
    """Voltage command of a current-mode amplifier (proportional loop with R and back-EMF feedforward).

    ``u = R i_ref + k_e omega + L (2 pi f_c) (i_ref - i)`` places the closed current
    loop's pole at ``f_c`` (the plant ``1/(L s + R)`` with the feedforward cancelling
    ``R`` and the EMF).  Call it at the physics sub-step rate (e.g. 10 kHz for
    ``f_c = 1 kHz``).  The amplifier limits still apply through :func:`applied_voltage`.
    """
    return p.R * i_ref + p.k_e * omega + p.L * 2.0 * np.pi * bandwidth_hz * (i_ref - i)


@register_jitable
def foldback_current(i_max: Any, i_fold: float, utilisation: Any, start: float, end: float) -> Any:
    """The I^2 t foldback of a servo amplifier's current limit (A).

    When the amplifier's I^2 t protection fills up it does not switch off: it folds its current limit back
    towards the continuous current (maxon EPOS4 Firmware Specification, "I2t current limitation": the limit
    drops to the continuous current when the thermal integral is used up).  The limit is ``i_max`` up to the
    ``utilisation`` (heating state over trip threshold) ``start``, ``i_fold`` from ``end`` on, linear in between;
    with ``i_fold`` below the nominal current the heating state drains at the folded limit, so the trip (
    ``utilisation = 1``) is not reached by the drive's own current.  ``start >= end``: no foldback.  Floats
    (the compiled drive step) or arrays (a controller's rows).
    """
    if end <= start:
        return i_max
    f = np.minimum(np.maximum((utilisation - start) / (end - start), 0.0), 1.0)
    return i_max - (i_max - np.minimum(i_fold, i_max)) * f


@register_jitable
def current_limited_voltage(p: DCMotorParams, u: Any, omega: Any, i_lim: Any) -> Any:
    """The voltage command clamped to a current limit ``i_lim`` below ``I_max``: ``k_e omega +- R i_lim`` (the
    quasi-static current limit, as :func:`applied_voltage` does at ``I_max``; the current settles within
    ``L/R``).  At ``i_lim >= I_max`` the command is returned unchanged (the amplifier's own limit acts).  Floats
    or arrays, as :func:`foldback_current`."""
    emf = p.k_e * omega
    return select(i_lim >= p.I_max, u, np.minimum(np.maximum(u, emf - p.R * i_lim), emf + p.R * i_lim))
