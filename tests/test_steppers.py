"""The generic row steppers: the tuple form (a row held in scalars) gives the array form's bits, compiled or plain.

The drive's roll-out runs on the tuple form (:mod:`vsa_gym.devices.drive.model`), the vsaUT-II and eLPAS kernels on
the array form; both claim the same operations in the same order, which these tests hold them to on a system that
has a nonlinear coupling, an input held over the step and a stiff, state-dependent decay on one column.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numba.extending import register_jitable

from vsa_gym.physics.integrate import etdrk4_weights_scalar
from vsa_gym.physics.steppers import etd_row_stepper, etd_tuple_stepper, rk4_row_stepper, rk4_tuple_stepper, tuple_io

STIFF = 2  # the column with the state-dependent decay


@register_jitable(inline="always")
def _rhs_tuple(ctx: tuple[np.ndarray, float], y: tuple[float, float, float]) -> tuple[float, float, float]:
    """A mass on a cubic spring with damping, an input, and a Dahl-like force ``z`` (decay ``p3 |v| z``)."""
    p, u = ctx
    x, v, z = y
    return v, (u - p[0] * x - p[1] * x * x * x - p[2] * v - z), p[4] * v - p[3] * abs(v) * z


@register_jitable(inline="always")
def _rhs_array(ctx: tuple[np.ndarray, float], y: np.ndarray, dy: np.ndarray, pw: np.ndarray) -> None:
    dy[0], dy[1], dy[2] = _rhs_tuple(ctx, (y[0], y[1], y[2]))


rk4_tuple = rk4_tuple_stepper(_rhs_tuple, 3)
etd_tuple = etd_tuple_stepper(_rhs_tuple, 3, STIFF)
rk4_array = rk4_row_stepper(_rhs_array)
etd_array = etd_row_stepper(_rhs_array, (STIFF,))
load, store = tuple_io(3)


@register_jitable
def _rate(p: np.ndarray, y: tuple[float, float, float]) -> float:
    return p[3] * abs(y[1])


def _rollout_tuple(p: np.ndarray, u: np.ndarray, h: float, n_sub: int, exponential: bool) -> np.ndarray:
    out = np.empty((u.shape[0], 3))
    s = np.array([0.3, 0.0, 0.0])
    for k in range(u.shape[0]):
        y = load(s)
        if exponential:
            for _ in range(n_sub):
                lam = _rate(p, y)
                y = etd_tuple((p, u[k]), y, h, lam, etdrk4_weights_scalar(lam, h))
        else:
            y = rk4_tuple((p, u[k]), y, h, n_sub)
        store(s, y)
        out[k] = s
    return out


def _rollout_array(p: np.ndarray, u: np.ndarray, h: float, n_sub: int, exponential: bool) -> np.ndarray:
    out = np.empty((u.shape[0], 3))
    s = np.array([0.3, 0.0, 0.0])
    k4, q, e = np.empty((4, 3)), np.empty((4, 0)), np.empty(0)
    ya, yb, yc, nl = np.empty(3), np.empty(3), np.empty(3), np.empty((4, 1))
    for k in range(u.shape[0]):
        if exponential:
            for _ in range(n_sub):
                lam = _rate(p, (s[0], s[1], s[2]))
                e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights_scalar(lam, h)
                etd_array((p, u[k]), s, h, 1, (lam,), ((e_half,), (w_half,), (e_full,), (f_u,), (f_ab,), (f_c,)),
                          k4, q, ya, yb, yc, nl, e)
        else:
            rk4_array((p, u[k]), s, h, n_sub, k4, q, ya, e)
        out[k] = s
    return out


_compiled_tuple = numba.njit(_rollout_tuple)
_compiled_array = numba.njit(_rollout_array)


@pytest.mark.parametrize("exponential", [False, True], ids=["rk4", "etdrk4"])
def test_tuple_steppers_give_the_array_steppers_bits_compiled_and_plain(exponential: bool) -> None:
    rng = np.random.default_rng(3)
    # the decay p3 |v| reaches about 1e4 1/s with the exponential stepper (stiff against h = 2.5e-4), 1e3 with RK4
    p = np.array([40.0, 300.0, 0.8, 2.0e4 if exponential else 2.0e3, 2.0e3])
    u = 3.0 * np.sin(np.arange(400) * 0.02) + rng.standard_normal(400)
    h, n_sub = 2.5e-4, 4
    want = _compiled_array(p, u, h, n_sub, exponential)
    assert np.all(np.isfinite(want)) and np.ptp(want[:, STIFF]) > 0.01  # the stiff column moves
    assert np.array_equal(_compiled_tuple(p, u, h, n_sub, exponential), want)
    # the same generated source run as plain Python (what NUMBA_DISABLE_JIT=1 runs); the first 40 samples keep the
    # test short.  The right-hand side uses + - * / and abs only, so RK4 gives the compiled bits; the exponential
    # stepper's weights take exp / expm1 from the C library in Python and from LLVM's code in the compiled run,
    # whose last bits can differ by processor (an Intel Xeon: 1.4e-16 relative in the stiff column), so there the
    # plain run is held to a few units in the last place
    plain = _rollout_tuple(p, u[:40], h, n_sub, exponential)
    if exponential:
        np.testing.assert_allclose(plain, want[:40], rtol=1e-14, atol=1e-300)
    else:
        assert np.array_equal(plain, want[:40])


def test_rk4_tuple_substep_is_the_fourth_order_taylor_polynomial_on_a_linear_decay() -> None:
    step = rk4_tuple_stepper(lambda ctx, y: (-ctx * y[0],), 1)
    for lam_h in (0.1, 0.5, 1.0, 2.5):
        y, = step(lam_h, (1.0,), 1.0, 1)
        assert y == pytest.approx(1 - lam_h + lam_h**2 / 2 - lam_h**3 / 6 + lam_h**4 / 24, rel=1e-14)


def test_etd_tuple_substep_is_exact_on_a_pure_decay_and_rk4_on_the_other_columns() -> None:
    # column 1 decays at lam with a constant drive c: exact z(h) = z_ss + (z0 - z_ss) exp(-lam h); column 0 is
    # d x / dt = -x, which the exponential stepper takes by classical RK4
    step = etd_tuple_stepper(lambda ctx, y: (-y[0], ctx[1] - ctx[0] * y[1]), 2, 1)
    lam, c, h = 5e4, 3.0, 1e-3
    x, z = step((lam, c), (1.0, 0.2), h, lam, etdrk4_weights_scalar(lam, h))
    assert z == pytest.approx(c / lam + (0.2 - c / lam) * np.exp(-lam * h), rel=1e-12)
    assert x == pytest.approx(1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24, rel=1e-14)


def test_tuple_io_round_trips_a_row() -> None:
    a = np.array([1.5, -2.0, 3.25, 0.0])
    ld, st = tuple_io(4)
    assert ld(a) == (1.5, -2.0, 3.25, 0.0)
    b = np.zeros(4)
    st(b, (4.0, 3.0, 2.0, 1.0))
    assert b.tolist() == [4.0, 3.0, 2.0, 1.0]
