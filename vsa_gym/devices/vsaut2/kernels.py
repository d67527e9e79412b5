"""The vsaUT-II's compiled row kernels: the right-hand side, RK4 and exponential RK4 steps of every row of a
batch (serial and threaded), and the readers of the flattened parameter rows (:mod:`vsa_gym.devices.vsaut2.model`
calls them; the environments' task steps call them directly)."""

from __future__ import annotations

import types
from typing import Any

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.vsaut2.equations import rhs_row
from vsa_gym.devices.vsaut2.layout import ETD_STIFF, N_POWER, Derived
from vsa_gym.devices.vsaut2.params import VsaUT2Params
from vsa_gym.physics.integrate import etdrk4_weights
from vsa_gym.physics.kernels import row_reader
from vsa_gym.physics.steppers import etd_row_stepper, rk4_row_stepper


def _rhs_rows_py(x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any) -> tuple[np.ndarray, np.ndarray]:
    n, nx = x.shape  # nx: 10 core states, or 11 with the hysteresis state (EFFECT_STATE)
    dx = np.empty((n, nx))
    pw = np.empty((n, N_POWER))
    for i in numba.prange(n):
        rhs_row(P_ROW(P, i), D_ROW(D, i), x[i], u[i, 0], u[i, 1], tau[i], dx[i], pw[i])
    return dx, pw


@register_jitable(inline="always")
def point_rhs(ctx: tuple[Any, Any, float, float, float], y: np.ndarray, dy: np.ndarray, pw: np.ndarray) -> None:
    """The vsaUT-II's point right-hand side in the steppers' contract (:mod:`vsa_gym.physics.steppers`):
    ``ctx = (p, d, u_1, u_2, tau_ext)``, one row's parameters, derived constants and held inputs."""
    p, d, u_1, u_2, te = ctx
    rhs_row(p, d, y, u_1, u_2, te, dy, pw)


rk4_row = rk4_row_stepper(point_rhs)
etd_row = etd_row_stepper(point_rhs, ETD_STIFF)


def _rk4_rows_py(
    x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any, dt: float, n_sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vsa_gym.physics.integrate.rk4` over :func:`rhs_row`, row by row with floats (no extensions): the
    generic :func:`~vsa_gym.physics.steppers.rk4_row_stepper` over :func:`point_rhs`.

    ``x`` has the 10 core states, or 11 with the hysteresis state (``EFFECT_STATE``).  The arithmetic of each
    element is that of the numpy ``rk4`` (same operations, same order).
    """
    n, nx = x.shape
    h = dt / n_sub
    x_new = np.empty((n, nx))
    energy = np.zeros((n, N_POWER))
    for i in numba.prange(n):
        y = x[i].copy()
        yt = np.empty(nx)
        k = np.empty((4, nx))
        q = np.empty((4, N_POWER))
        e = np.zeros(N_POWER)
        rk4_row((P_ROW(P, i), D_ROW(D, i), u[i, 0], u[i, 1], tau[i]), y, h, n_sub, k, q, yt, e)
        x_new[i] = y
        energy[i] = e
    return x_new, energy


def _etd_rows_py(
    x: np.ndarray, u: np.ndarray, tau: np.ndarray, P: Any, D: Any, dt: float, n_sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vsa_gym.physics.integrate.exponential_rk4` over :func:`rhs_row`, row by row (no extensions): the
    generic :func:`~vsa_gym.physics.steppers.etd_row_stepper` over :func:`point_rhs`.

    Stiff columns :data:`ETD_STIFF` (the currents) with the constant rates ``R/L`` of the row's
    motors; the weights are those of the numpy step (``etdrk4_weights``), the stages the same
    operations in the same order, so the two paths agree to round-off.  Widths of ``x`` as :func:`_rk4_rows_py`.
    """
    n, nx = x.shape
    h = dt / n_sub
    x_new = np.empty((n, nx))
    energy = np.zeros((n, N_POWER))
    # rates and weights of row 0; every row's when the parameters are shared (not batched): computed once
    p0 = P_ROW(P, 0)
    lam0 = np.array([p0.pivot_motor.R / p0.pivot_motor.L, p0.frame_motor.R / p0.frame_motor.L])
    w0 = etdrk4_weights(lam0, h)
    shared = P.shape[0] == 1
    for i in numba.prange(n):
        p = P_ROW(P, i)
        if shared:
            lam = lam0
            w = w0
        else:
            lam = np.array([p.pivot_motor.R / p.pivot_motor.L, p.frame_motor.R / p.frame_motor.L])
            w = etdrk4_weights(lam, h)  # constant over the step
        y = x[i].copy()
        ya = np.empty(nx)
        yb = np.empty(nx)
        yc = np.empty(nx)
        k = np.empty((4, nx))
        q = np.empty((4, N_POWER))
        nl = np.empty((4, 2))
        e = np.zeros(N_POWER)
        etd_row((p, D_ROW(D, i), u[i, 0], u[i, 1], tau[i]), y, h, n_sub, lam, w, k, q, ya, yb, yc, nl, e)
        x_new[i] = y
        energy[i] = e
    return x_new, energy


P_ROW = row_reader(VsaUT2Params().as_tuple())
D_ROW = row_reader(Derived(0.0, 0.0, 0.0, 0.0))

@numba.njit(cache=True)
def all_finite(a: np.ndarray) -> bool:
    """``np.all(np.isfinite(a))`` for a C-contiguous array, without the temporary."""
    for v in a.ravel():  # noqa: SIM110 (a loop numba compiles; no generator)
        if not np.isfinite(v):
            return False
    return True


#: Rows at and above which the compiled step runs its row loop on all cores (numba ``prange``).
PARALLEL_MIN_ROWS = 64


def _parallel_twin(f: Any) -> Any:
    """``f`` under the name ``<name>_parallel``, for its ``parallel=True`` compilation.

    numba names a cache entry after the function's qualified name and first line, and its index key
    (signature, CPU, bytecode) does not include ``parallel``: compiled twice from the same function,
    the serial and the parallel kernels share one cache entry, and whichever was saved first is loaded
    for both -- one env then ran the threaded kernel (tens of us of thread start-up per step), or a
    vector env the serial one.  The twin has its own entry.
    """
    twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "_parallel", f.__defaults__, f.__closure__)
    twin.__qualname__ = f.__qualname__ + "_parallel"
    return twin


rhs_rows = numba.njit(cache=True)(_rhs_rows_py)
rk4_rows = numba.njit(cache=True)(_rk4_rows_py)
rk4_rows_parallel = numba.njit(cache=True, parallel=True)(_parallel_twin(_rk4_rows_py))
etd_rows = numba.njit(cache=True)(_etd_rows_py)
etd_rows_parallel = numba.njit(cache=True, parallel=True)(_parallel_twin(_etd_rows_py))

