"""The eLPAS core's integrator: the generic ETDRK4 row stepper over the eLPAS point right-hand side, and the
refinement of speed reversals.

One control step integrates ``(q, z)`` instead of ``(omega, z)`` (:func:`~vsa_gym.devices.elpas.equations.q_of_omega`):
the bristle damping ``s1 dz/dt`` couples the stiff bristle mode into the speed, and along that mode
``q = J_r omega + N s1 z`` stays constant, so ``dq/dt`` contains no ``dz/dt``.  The remaining stiff decay
``-lambda z`` of the bristle is treated exactly by the exponential RK4 of Cox & Matthews: the generic
:func:`vsa_gym.physics.steppers.etd_row_stepper` over :func:`point_rhs` with the stiff column ``BRISTLE``, one
substep per call, ``lambda = |omega_m| s0 / g`` frozen per substep (its weights
:func:`vsa_gym.physics.integrate.etdrk4_weights`); every other column sees plain RK4.  Stable for any speed;
accuracy is checked against Radau (tests/elpas/test_model.py).

* :func:`integrate_row` is one control step of one row: ``n_sub`` substeps of the generic stepper;
* :func:`advance_row` is one control step: :func:`integrate_row`, redone with ``REVERSAL_REFINE`` times more
  substeps when the speed reverses through a fast bristle rate (:func:`needs_refinement`);
* :func:`advance_rows` is :func:`advance_row` for every row in one compiled call (``step_rig`` / ``step_vehicle``);
* :func:`reversal_rows` is :func:`needs_refinement` for every row (the numpy path of the model's extensions).

A row may carry the effect-state columns after its base states (the arm hysteresis,
:data:`~vsa_gym.devices.elpas.layout.EFFECT_STATE`): the stepper integrates every column of the row it is given.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.equations import omega_of_q, q_constants, q_of_omega, rhs_q_row
from vsa_gym.devices.elpas.layout import BRISTLE, N_POWER, OMEGA, effect_column
from vsa_gym.devices.elpas.packing import ElpasT, matrix_row_params
from vsa_gym.devices.elpas.params import ElpasParams
from vsa_gym.physics.friction import bristle_rate
from vsa_gym.physics.integrate import etdrk4_weights
from vsa_gym.physics.steppers import etd_row_stepper

REVERSAL_REFINE = 4
"""Substep refinement for the rows whose motor speed changes sign within a control step."""
REVERSAL_RATE_H = 0.01
"""Refine a reversal only if the bristle rate times the substep exceeds this (slow creep needs no refinement)."""

ETD_STIFF = (BRISTLE,)
"""The stiff column of the ETDRK4 stepper: the LuGre bristle deflection."""


def substep_count(p: ElpasParams) -> int:
    """The number of ETDRK4 substeps per control step, ``p.numerics.n_sub`` as an int."""
    return int(round(float(p.numerics.n_sub)))


# inline="always": inlined into the stepper's stages (and rhs_q_row into it)
@register_jitable(inline="always")
def point_rhs(ctx: Any, y: np.ndarray, k: np.ndarray, pw: np.ndarray) -> None:
    """The device contract's point right-hand side (:mod:`vsa_gym.physics.steppers`): ``ctx = (u, rate, p,
    vehicle, c, J, hyst)`` -- held voltage, dalpha/dt (rig) or dy_r/dt (vehicle), this row's parameters, the
    configuration, :func:`~vsa_gym.devices.elpas.equations.q_constants` and whether the row runs its arm hysteresis
    column; ``y`` in the ``(q, z)`` variables."""
    u, rate, p, vehicle, c, J, hyst = ctx
    rhs_q_row(y, u, rate, p, vehicle, c, J, hyst, k, pw)


etd_row = etd_row_stepper(point_rhs, ETD_STIFF)
"""One row's ETDRK4 substeps over :func:`point_rhs` (the generic stepper)."""


@register_jitable
def integrate_row(x: np.ndarray, u: float, rate: float, p: ElpasT, dt: float, n_sub: int, vehicle: bool,
                  x_out: np.ndarray, e_out: np.ndarray) -> None:
    """One control step ``dt`` of one row: ``n_sub`` substeps of :data:`etd_row`, the bristle rate frozen per
    substep.

    ``x``/``x_out`` ``(n_states,)``, ``e_out`` ``(N_POWER,)`` (overwritten with the energy of every power
    channel over the step); ``p`` this row's scalars (:func:`~vsa_gym.devices.elpas.packing.matrix_row_params`); ``u``
    the held voltage, ``rate`` dalpha/dt (rig) or dy_r/dt (vehicle).
    """
    nx = x.shape[0]
    c, J = q_constants(p)
    work = np.empty((8, nx))  # one allocation for the stepper's scratch (small arrays cost more to allocate)
    k, y, ya, yb, yc = work[0:4], work[4], work[5], work[6], work[7]
    q = np.empty((4, N_POWER))  # the stages' power channels
    nl = np.empty((4, 1))  # the stages' bristle nonlinear parts
    for j in range(nx):
        y[j] = x[j]
    y[OMEGA] = q_of_omega(x[OMEGA], x[BRISTLE], c, J)
    for j in range(N_POWER):
        e_out[j] = 0.0
    n_base = effect_column(vehicle)  # the effect columns follow the base states
    hyst = nx > n_base and p.effects.M_h > 0.0  # the arm hysteresis column is there and on in this row
    if not hyst:
        for s in range(4):
            for j in range(n_base, nx):
                k[s, j] = 0.0  # an effect column carried for other rows keeps its value (rhs_q_row skips it)
    h = dt / n_sub
    ctx = (u, rate, p, vehicle, c, J, hyst)
    for _ in range(n_sub):
        lam = bristle_rate(p.friction, p.drive.N * (y[OMEGA] - c * y[BRISTLE]) / J)
        e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights(lam, h)
        etd_row(ctx, y, h, 1, (lam,), ((e_half,), (w_half,), (e_full,), (f_u,), (f_ab,), (f_c,)), k, q, ya, yb,
                yc, nl, e_out)
    for j in range(nx):
        x_out[j] = y[j]
    x_out[OMEGA] = omega_of_q(y[OMEGA], y[BRISTLE], c, J)


@register_jitable
def needs_refinement(w0: float, w1: float, p: ElpasT, h: float) -> bool:
    """Whether a row's step with substep ``h`` must be redone finer: its speed went from ``w0`` to ``w1`` through
    zero, with a bristle rate at either end that matters within a substep (``lambda h > REVERSAL_RATE_H``).

    ``|omega_m|`` in the bristle equation has a kink at zero speed; a substep containing the reversal loses two
    orders of accuracy.  ``REVERSAL_REFINE`` times more substeps keep the Radau error below 1e-3 at little cost.
    """
    fast = max(bristle_rate(p.friction, p.drive.N * w0), bristle_rate(p.friction, p.drive.N * w1)) * h \
        > REVERSAL_RATE_H
    return np.sign(w0) != np.sign(w1) and fast


@register_jitable
def advance_row(x: np.ndarray, u: float, rate: float, p: ElpasT, dt: float, n_sub: int, vehicle: bool,
                x_out: np.ndarray, e_out: np.ndarray) -> None:
    """One control step of one row (arguments as :func:`integrate_row`): :func:`integrate_row`, redone with
    ``REVERSAL_REFINE`` times more substeps when :func:`needs_refinement`."""
    integrate_row(x, u, rate, p, dt, n_sub, vehicle, x_out, e_out)
    if needs_refinement(x[OMEGA], x_out[OMEGA], p, dt / n_sub):
        integrate_row(x, u, rate, p, dt, n_sub * REVERSAL_REFINE, vehicle, x_out, e_out)


@numba.njit(cache=True)
def advance_rows(x: np.ndarray, rin: np.ndarray, P: np.ndarray, dt: float, n_sub: int,
                 vehicle: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`advance_row` for every row, in one call: ``(x_new, energy)``.

    ``x`` ``(n, n_states)``; ``rin`` ``(n, 2)``: voltage, dalpha/dt (rig) or dy_r/dt (vehicle); ``P`` the
    parameter matrix (:func:`~vsa_gym.devices.elpas.packing.params_matrix`).
    """
    n = x.shape[0]
    x_new = np.empty_like(x)
    energy = np.empty((n, N_POWER))
    for i in range(n):
        advance_row(x[i], rin[i, 0], rin[i, 1], matrix_row_params(P, i), dt, n_sub, vehicle, x_new[i], energy[i])
    return x_new, energy


@numba.njit(cache=True)
def reversal_rows(x: np.ndarray, x_new: np.ndarray, P: np.ndarray, h: float) -> np.ndarray:
    """:func:`needs_refinement` of every row's step from ``x`` to ``x_new`` with substep ``h`` (bool ``(n,)``)."""
    n = x.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        out[i] = needs_refinement(x[i, OMEGA], x_new[i, OMEGA], matrix_row_params(P, i), h)
    return out
