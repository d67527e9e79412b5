"""The eLPAS core's integrator, written once: the LuGre-aware ETDRK4 per row, and the refinement of speed reversals.

One control step integrates ``(q, z)`` instead of ``(omega, z)`` (:func:`~vsa_gym.devices.elpas.equations.q_of_omega`):
the bristle damping ``s1 dz/dt`` couples the stiff bristle mode into the speed, and along that mode
``q = J_r omega + N s1 z`` stays constant, so ``dq/dt`` contains no ``dz/dt``.  The remaining stiff decay
``-lambda z`` of the bristle is treated exactly by the exponential RK4 of Cox & Matthews (ETDRK4, the weights of
:func:`vsa_gym.physics.integrate.etdrk4_weights`, ``lambda = |omega_m| s0 / g`` frozen per substep); every other
component sees plain RK4.  Stable for any speed; accuracy is checked against Radau (tests/elpas/test_model.py).

* :func:`etd_stages_row` runs a range of stages of the substeps of one row -- the scheme itself;
* :func:`integrate_row` is one control step of one row without extensions: all ``4 n_sub`` stages in one call;
* :func:`advance_row` is one control step: :func:`integrate_row`, redone with ``REVERSAL_REFINE`` times more
  substeps when the speed reverses through a fast bristle rate (:func:`needs_refinement`);
* :func:`advance_rows` is :func:`advance_row` for every row in one compiled call (``step_rig`` / ``step_vehicle``);
* :func:`stage_rows` and :func:`reversal_rows` are one stage of :func:`etd_stages_row` and
  :func:`needs_refinement` for every row, for the one Python-level loop that evaluates model extensions (Python
  objects, on columns) between the stages (:func:`vsa_gym.devices.elpas.model.step_rig` with extensions).
"""

from __future__ import annotations

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.equations import omega_of_q, q_constants, q_of_omega, rhs_q_row
from vsa_gym.devices.elpas.layout import BRISTLE, N_POWER, OMEGA
from vsa_gym.devices.elpas.packing import ElpasT, matrix_row_params
from vsa_gym.devices.elpas.params import ElpasParams
from vsa_gym.physics.friction import bristle_rate
from vsa_gym.physics.integrate import etdrk4_weights

REVERSAL_REFINE = 4
"""Substep refinement for the rows whose motor speed changes sign within a control step."""
REVERSAL_RATE_H = 0.01
"""Refine a reversal only if the bristle rate times the substep exceeds this (slow creep needs no refinement)."""

N_STAGES = 4
"""Stages of one ETDRK4 substep."""


def substep_count(p: ElpasParams) -> int:
    """The number of ETDRK4 substeps per control step, ``p.numerics.n_sub`` as an int."""
    return int(round(float(p.numerics.n_sub)))


# ``PW``, a row's stage buffer: the stages' power channels (rows 0-3), then what a call that continues a substep
# reads (the Python-level extension loop runs one stage per call): the frozen rate and the weights, the stages'
# nonlinear parts
ROW_WEIGHTS = N_STAGES  # lambda, e_half, w_half, e_full, f_u, f_ab, f_c
ROW_NONLINEAR = N_STAGES + 1  # n1, n2, n3
N_PW_ROWS = N_STAGES + 2
assert N_POWER >= 7, "the stage buffer keeps the substep's 7 weights in one row of N_POWER entries"


# inline="always": numba inlines it into integrate_row and stage_rows (as a call it cost 10-15 % of a step)
@register_jitable(inline="always")
def etd_stages_row(g0: int, g1: int, Y: np.ndarray, K: np.ndarray, PW: np.ndarray, u: float, rate: float,
                   p: ElpasT, vehicle: bool, tau_ext: float, f_ext: float, h: float, e_out: np.ndarray) -> None:
    """Stages ``g0 .. g1 - 1`` of the ETDRK4 substeps of ``h`` of one row, in the ``(q, z)`` variables: stage ``g``
    is stage ``s = g % 4`` of substep ``g // 4``.  This is the scheme, written once.

    ``Y`` ``(4, n_states)``: ``Y[0]`` the row's state at the start of the substep, ``Y[1..3]`` the stage states;
    ``K`` ``(4, n_states)``: the stages' derivatives; ``PW`` ``(N_PW_ROWS, N_POWER)``: the stages' power channels
    and the substep's rate, weights and nonlinear parts (``ROW_WEIGHTS``, ``ROW_NONLINEAR``).  Stage ``s``
    evaluates :func:`~vsa_gym.devices.elpas.equations.rhs_q_row` at ``Y[s]`` into ``K[s]``, ``PW[s]`` (the base states;
    the extension states' derivatives must already be in ``K[s]``), then forms ``Y[s + 1]``; ``s = 3`` replaces
    ``Y[0]`` by the state after the substep and adds the substep's energy to ``e_out``.  ``u``: held voltage;
    ``rate``: dalpha/dt (rig) or dy_r/dt (vehicle); ``tau_ext``, ``f_ext``: the extensions' port moment and force
    (0 without extensions; with extensions the caller runs one stage per call, with the ports at ``Y[s]``).
    """
    c, J = q_constants(p)
    nx = Y.shape[1]
    # the rows as views, once (a view costs two atomic reference counts)
    y0, y1, y2, y3, k0, k1, k2, k3 = Y[0], Y[1], Y[2], Y[3], K[0], K[1], K[2], K[3]
    p0, p1, p2, p3, w, nl = PW[0], PW[1], PW[2], PW[3], PW[ROW_WEIGHTS], PW[ROW_NONLINEAR]
    lam, e_half, w_half, e_full, f_u, f_ab, f_c = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    n1, n2, n3 = 0.0, 0.0, 0.0
    if g0 % N_STAGES > 0:  # continuing a substep
        lam, e_half, w_half, e_full, f_u, f_ab, f_c = w[0], w[1], w[2], w[3], w[4], w[5], w[6]
        n1, n2, n3 = nl[0], nl[1], nl[2]
    for g in range(g0, g1):
        s = g % N_STAGES
        if s == 0:
            lam = bristle_rate(p.friction, p.drive.N * (y0[OMEGA] - c * y0[BRISTLE]) / J)
            e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights(lam, h)
            w[0], w[1], w[2], w[3], w[4], w[5], w[6] = lam, e_half, w_half, e_full, f_u, f_ab, f_c
            rhs_q_row(y0, u, rate, p, vehicle, c, J, tau_ext, f_ext, k0, p0)
            n1 = nl[0] = k0[BRISTLE] + lam * y0[BRISTLE]  # the bristle's nonlinear part dz/dt + lambda z
            for j in range(nx):
                y1[j] = y0[j] + 0.5 * h * k0[j]
            y1[BRISTLE] = e_half * y0[BRISTLE] + w_half * n1
        elif s == 1:
            rhs_q_row(y1, u, rate, p, vehicle, c, J, tau_ext, f_ext, k1, p1)
            n2 = nl[1] = k1[BRISTLE] + lam * y1[BRISTLE]
            for j in range(nx):
                y2[j] = y0[j] + 0.5 * h * k1[j]
            y2[BRISTLE] = e_half * y0[BRISTLE] + w_half * n2
        elif s == 2:
            rhs_q_row(y2, u, rate, p, vehicle, c, J, tau_ext, f_ext, k2, p2)
            n3 = nl[2] = k2[BRISTLE] + lam * y2[BRISTLE]
            for j in range(nx):
                y3[j] = y0[j] + h * k2[j]
            y3[BRISTLE] = e_half * y1[BRISTLE] + w_half * (2.0 * n3 - n1)
        else:
            rhs_q_row(y3, u, rate, p, vehicle, c, J, tau_ext, f_ext, k3, p3)
            n4 = k3[BRISTLE] + lam * y3[BRISTLE]
            zs = y0[BRISTLE]
            for j in range(nx):
                y0[j] = y0[j] + (h / 6.0) * (k0[j] + 2.0 * k1[j] + 2.0 * k2[j] + k3[j])
            y0[BRISTLE] = e_full * zs + h * (f_u * n1 + f_ab * (n2 + n3) + f_c * n4)
            for j in range(N_POWER):
                e_out[j] += (h / 6.0) * (p0[j] + 2.0 * p1[j] + 2.0 * p2[j] + p3[j])


@register_jitable
def integrate_row(x: np.ndarray, u: float, rate: float, p: ElpasT, dt: float, n_sub: int, vehicle: bool,
                  x_out: np.ndarray, e_out: np.ndarray) -> None:
    """One control step ``dt`` of one row (no extensions): the ``4 n_sub`` stages of :func:`etd_stages_row`.

    ``x``/``x_out`` ``(n_states,)``, ``e_out`` ``(N_POWER,)`` (overwritten with the energy of every power
    channel over the step); ``p`` this row's scalars (:func:`~vsa_gym.devices.elpas.packing.matrix_row_params`); ``u``
    the held voltage, ``rate`` dalpha/dt (rig) or dy_r/dt (vehicle).
    """
    nx = x.shape[0]
    c, J = q_constants(p)
    work = np.empty((2, N_STAGES, nx))  # one allocation for the stages (small arrays cost more to allocate)
    Y, K = work[0], work[1]
    PW = np.empty((N_PW_ROWS, N_POWER))
    for j in range(nx):
        Y[0, j] = x[j]
    Y[0, OMEGA] = q_of_omega(x[OMEGA], x[BRISTLE], c, J)
    for j in range(N_POWER):
        e_out[j] = 0.0
    etd_stages_row(0, N_STAGES * n_sub, Y, K, PW, u, rate, p, vehicle, 0.0, 0.0, dt / n_sub, e_out)
    for j in range(nx):
        x_out[j] = Y[0, j]
    x_out[OMEGA] = omega_of_q(Y[0, OMEGA], Y[0, BRISTLE], c, J)


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
def stage_rows(s: int, Y: np.ndarray, K: np.ndarray, PW: np.ndarray, rin: np.ndarray, P: np.ndarray, vehicle: bool,
               ports: np.ndarray, h: float, E: np.ndarray) -> None:
    """Stage ``s`` (0..3) of the current substep of every row (:func:`etd_stages_row` of one stage): ``Y``, ``K``
    ``(n, 4, n_states)``, ``PW`` ``(n, N_PW_ROWS, N_POWER)``, ``E`` ``(n, N_POWER)``; ``rin`` as :func:`advance_rows`;
    ``ports`` ``(n, 2)``: the extensions' moment and force at ``Y[:, s]``."""
    for i in range(Y.shape[0]):
        etd_stages_row(s, s + 1, Y[i], K[i], PW[i], rin[i, 0], rin[i, 1], matrix_row_params(P, i), vehicle,
                       ports[i, 0], ports[i, 1], h, E[i])


@numba.njit(cache=True)
def reversal_rows(x: np.ndarray, x_new: np.ndarray, P: np.ndarray, h: float) -> np.ndarray:
    """:func:`needs_refinement` of every row's step from ``x`` to ``x_new`` with substep ``h`` (bool ``(n,)``)."""
    n = x.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        out[i] = needs_refinement(x[i, OMEGA], x_new[i, OMEGA], matrix_row_params(P, i), h)
    return out
