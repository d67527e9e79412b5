"""The eLPAS motor controller: the paper's 10 kHz PI current loop around the core, written once.

eLPAS paper eqs. 10-13, Table 2: a PI controller on the torque error ``K_T (I_ref - I)`` with ``P_m = 0.1 V/(N m)``,
``I_m = 50 V/(N m s)``, the integrator clamped to ``+-28 V`` (anti-windup), plus the resistance feed-forward
``R I_ref``.  It runs at 10 kHz: over one control step the core is advanced ``n_inner`` times by
``h = control_dt / n_inner`` (about ``CURRENT_LOOP_DT``; :func:`~vsa_gym.devices.elpas.integrator.advance_row` with
``n_sub`` substeps of at most ``SUBSTEP_MAX``), the voltage held over each, the imposed input (alpha on the rig,
the road height under the car) moving linearly from its start to its end value.

:func:`current_loop_row` is the loop for one row (the environments' compiled step calls it per row);
:func:`current_loop_rows` runs it for every row of a batch in one compiled call (the identification replay).
``K_T`` and ``R`` are arguments: the loop is the amplifier's firmware and may use other values than the plant
(the identification replay uses the nominal ones).
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.integrator import advance_row
from vsa_gym.devices.elpas.layout import ALPHA, CURRENT, N_POWER, P_EL, Y_R
from vsa_gym.devices.elpas.packing import ElpasT, matrix_row_params

CURRENT_LOOP_DT = 1e-4  # s (10 kHz)
SUBSTEP_MAX = 2.5e-4  # s, the core's validated RK4 sub-step


@dataclasses.dataclass(frozen=True)
class ElpasCurrentLoop:
    """Motor controller of the eLPAS paper (eqs. 10-13, Table 2)."""

    P_m: float = 0.1  # V per N m of torque error
    I_m: float = 50.0  # V per N m s
    I_m_max: float = 28.0  # V, integrator clamp


def core_substeps(h: float) -> int:
    """The core's substeps over a held-voltage interval ``h``: as few as keep each at most ``SUBSTEP_MAX``."""
    return max(1, int(np.ceil(h / SUBSTEP_MAX - 1e-9)))


def loop_steps(control_dt: float) -> tuple[int, float, int]:
    """``(n_inner, h, n_sub)`` of the current loop over one control step: ``n_inner`` loop steps of ``h`` (about
    ``CURRENT_LOOP_DT``), each ``n_sub`` core substeps of at most ``SUBSTEP_MAX`` (:func:`core_substeps`)."""
    n_inner = max(1, int(round(control_dt / CURRENT_LOOP_DT)))
    h = control_dt / n_inner
    return n_inner, h, core_substeps(h)


@register_jitable
def current_loop_row(x: np.ndarray, i_ref: float, pi_int: float, start: float, end: float, p: ElpasT, h: float,
                     n_inner: int, n_sub: int, vehicle: bool, k_t: float, R: float, P_m: float, I_m: float,
                     I_m_max: float) -> tuple[float, float]:
    """One control step of one row under the PI current loop; ``x`` ``(n_states,)`` is advanced in place.

    Each of the ``n_inner`` loop steps of ``h``: the torque error ``k_t (i_ref - i)``, the clamped integrator
    ``pi_int`` (``+-I_m_max``), the voltage ``P_m err + pi_int + R i_ref`` held over
    :func:`~vsa_gym.devices.elpas.integrator.advance_row` (``n_sub`` substeps, parameters ``p`` of this row), while the
    imposed input (column ``ALPHA`` on the rig, ``Y_R`` on the vehicle) moves linearly from ``start`` to ``end``
    and is set exactly at each loop step's end.

    Returns ``(pi_int, E_el)``: the integrator after the step and the electrical energy over it (J).
    """
    col = Y_R if vehicle else ALPHA
    x_new = np.empty(x.shape[0])
    e = np.empty(N_POWER)
    e_el = 0.0
    for k in range(1, n_inner + 1):
        err = k_t * (i_ref - x[CURRENT])
        pi_int = min(max(pi_int + I_m * err * h, -I_m_max), I_m_max)
        u = P_m * err + pi_int + R * i_ref
        target = start + (end - start) * (k / n_inner)
        advance_row(x, u, (target - x[col]) / h, p, h, n_sub, vehicle, x_new, e)
        x_new[col] = target
        x[:] = x_new
        e_el = e_el + e[P_EL]
    return pi_int, e_el


@numba.njit(cache=True)
def current_loop_rows(x: np.ndarray, i_ref: np.ndarray, pi_int: np.ndarray, start: np.ndarray, end: np.ndarray,
                      P: np.ndarray, h: float, n_inner: int, n_sub: int, vehicle: bool, k_t: float, R: float,
                      P_m: float, I_m: float, I_m_max: float) -> np.ndarray:
    """:func:`current_loop_row` for every row of ``x`` ``(n, n_states)`` (in place, as ``pi_int`` ``(n,)``); ``i_ref``,
    ``start``, ``end`` ``(n,)``; ``P`` the parameter matrix (:func:`~vsa_gym.devices.elpas.packing.params_matrix`); the
    controller's ``k_t``, ``R`` and gains shared by all rows.  Returns the electrical energy of every row (J)."""
    n = x.shape[0]
    e_el = np.empty(n)
    for i in range(n):
        pi_int[i], e_el[i] = current_loop_row(x[i], i_ref[i], pi_int[i], start[i], end[i], matrix_row_params(P, i),
                                              h, n_inner, n_sub, vehicle, k_t, R, P_m, I_m, I_m_max)
    return e_el
