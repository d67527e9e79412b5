"""The compiled per-row core: its shortcuts give the full formulas' bits, and a batch equals its rows one by one."""

import numba
import numpy as np
import pytest

from vsa_gym.devices.vsaut2.model import N_POWER, N_STATES, PARALLEL_MIN_ROWS, PORTS, VsaUT2Model, rhs_core, rhs_rows
from vsa_gym.devices.vsaut2.params import VsaUT2Effects, VsaUT2Params
from vsa_gym.physics.contact import FAR, penalty_contact
from vsa_gym.physics.gearbox import input_torque


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b)))


def _states(model: VsaUT2Model, n: int, seed: int = 0) -> np.ndarray:
    """Varied states: every stop approached from both sides, moving and at rest, some in contact."""
    rng = np.random.default_rng(seed)
    q2 = rng.uniform(-0.52, 0.52, n)
    x = model.initial_state(n, q1=rng.uniform(0.0015, 0.047, n), q2=q2, r=q2 + rng.uniform(-0.72, 0.72, n))
    x[:, 0], x[:, 3] = rng.normal(0, 3, n), rng.normal(0, 3, n)
    x[:, 2], x[:, 5] = rng.normal(0, 100, n), rng.normal(0, 100, n)
    x[:, 7], x[:, 9] = rng.normal(0, 3, n), rng.normal(0, 5, n)
    x[: n // 4, 2] *= 1e-3  # motors near standstill: the gearbox blends
    x[: n // 8, 1] = model.params.theta1_max + rng.uniform(0.0, 1.0, n // 8)  # pivot stroke stop (soft end)
    return x


@numba.njit
def _contact_rows(z, z_dot, K, D, eps):  # type: ignore[no-untyped-def]
    out = np.empty((z.size, 3))
    for i in range(z.size):
        c = penalty_contact(z[i], z_dot[i], K, D, eps)
        out[i, 0], out[i, 1], out[i, 2] = c.force, c.energy, c.p_diss
    return out


@numba.njit
def _contact_rows_full(z, z_dot, K, D, eps):  # type: ignore[no-untyped-def]
    """The penalty-contact formula (module docstring of contact.py) without the far-from-contact shortcut."""
    out = np.empty((z.size, 3))
    for i in range(z.size):
        s = z[i] / eps
        pen = eps * (np.maximum(s, 0.0) + np.log1p(np.exp(-np.abs(s))))
        w = 0.5 * (1.0 + np.tanh(0.5 * s))
        damp = D * w * z_dot[i]
        out[i, 0], out[i, 1], out[i, 2] = K * pen * w + damp, 0.5 * K * pen * pen, damp * z_dot[i]
    return out


@numba.njit
def _gearbox_rows_separate(p, tau, w):  # type: ignore[no-untyped-def]
    """The gearbox law with efficiency and |tau|/eta and the sign blend each evaluated on their own."""
    out = np.empty((tau.size, 2))
    for i in range(tau.size):
        a = np.abs(tau[i])
        x = p.alpha * a / p.tau_max
        ratio = x / (-np.expm1(-x)) if x > 1e-9 else 1.0 + 0.5 * x
        forward = (ratio * p.tau_max / (p.alpha * p.eta_max) - a) / p.n
        backward = a * (1.0 - p.eta_max * (-np.expm1(-p.alpha * np.abs(a) / p.tau_max))) / p.n
        s = np.tanh(w[i] / p.omega_eps)
        bw = 0.5 * (1.0 + np.tanh(s * tau[i] / (p.tau_eps_frac * p.tau_max)))
        m = bw * forward + (1.0 - bw) * backward
        loss = np.tanh(w[i] / p.omega_eps) * m
        out[i, 0], out[i, 1] = tau[i] / p.n + loss, loss * w[i]
    return out


@numba.njit
def _gearbox_rows(p, tau, w):  # type: ignore[no-untyped-def]
    out = np.empty((tau.size, 2))
    for i in range(tau.size):
        out[i, 0], out[i, 1] = input_torque(p, tau[i], w[i])
    return out


def test_contact_shortcut_gives_the_full_formula():
    """Far from the stop the compiled scalar path skips exp/log1p/tanh: force and dissipation keep their bits."""
    eps = 2e-3
    s = np.concatenate([-np.logspace(-3, 6, 4001), np.linspace(-FAR - 5, -FAR + 5, 4001), np.logspace(-3, 2, 500)])
    z = s * eps
    z_dot = np.random.default_rng(1).normal(0, 3, z.size)
    z_dot[::7] = 0.0
    z_dot[1::7] = -0.0
    K = 2000.0
    rows = _contact_rows(z, z_dot, K, 5.0, eps)
    ref = _contact_rows_full(z, z_dot, K, 5.0, eps)
    assert _same_bits(rows[:, [0, 2]], ref[:, [0, 2]])  # force and dissipation
    far = s < -FAR
    assert _same_bits(rows[~far, 1], ref[~far, 1])
    assert np.all(rows[far, 1] == 0.0) and np.all(ref[far, 1] < 1e-35 * K * eps**2)  # energy: an underflow
    # and the numpy path (vectorised libm: equal to round-off)
    full = np.stack(penalty_contact(z, z_dot, K, 5.0, eps), axis=1)
    assert np.allclose(rows, full, rtol=1e-12, atol=1e-12 * np.abs(full).max())


@pytest.mark.parametrize("gearbox", ["pivot_gearbox", "frame_gearbox"])
def test_gearbox_shared_terms_give_the_separate_formulas(gearbox):
    """``input_torque`` evaluates ``expm1`` and ``tanh(omega / omega_eps)`` once each: same bits as separately."""
    p = getattr(VsaUT2Params(), gearbox)
    rng = np.random.default_rng(2)
    tau = np.concatenate([rng.normal(0, 5, 3000), rng.normal(0, 1e-9, 300), [0.0, -0.0]])
    w = np.concatenate([rng.normal(0, 50, 1500), rng.normal(0, 0.5, 1802)])
    rows = _gearbox_rows(p.as_tuple(), tau, w)
    assert _same_bits(rows, _gearbox_rows_separate(p.as_tuple(), tau, w))
    full = np.stack(input_torque(p, tau, w), axis=1)
    assert np.allclose(rows, full, rtol=1e-12, atol=1e-12 * np.abs(full).max())


@pytest.mark.parametrize("effects", [VsaUT2Effects(), VsaUT2Effects(F_c_o=0.02, F_s_o=0.01, F_c_ad=0.05, b_belt=1e-5),
                                     VsaUT2Effects(F_c_ad=0.05)])
def test_compiled_rhs_equals_numpy_rhs_bit_for_bit(effects):
    """The compiled per-row RHS (shortcuts for far stops and absent effects) is the numpy RHS to round-off.

    (Not bit for bit: numpy's vectorised ``tanh``/``exp`` may differ from libm's by an ulp.)
    """
    model = VsaUT2Model(VsaUT2Params(effects=effects))
    n = 4000
    x = _states(model, n)
    rng = np.random.default_rng(3)
    u, tau = rng.uniform(-40, 40, (n, 2)), rng.normal(0, 2, n)
    dx_c, pw_c = rhs_rows(x, u, tau, model.p_rows, model.d_rows)
    dx_n, pw_n = np.empty((n, N_STATES)), np.empty((n, N_POWER))
    rhs_core(x, u, tau, model.params, model._d, np.zeros((n, len(PORTS))), dx_n, pw_n)
    for c, nm in ((dx_c, dx_n), (pw_c, pw_n)):
        scale = np.abs(nm).max(axis=0) + 1e-300
        assert (np.abs(c - nm) / scale).max() <= 1e-12


@pytest.mark.parametrize("integrator", ["rk4", "etd"])
def test_batch_equals_rows_one_by_one(integrator):
    """The row-parallel kernel (n >= PARALLEL_MIN_ROWS) gives each row exactly what the serial n = 1 kernel gives."""
    model = VsaUT2Model(integrator=integrator)
    n = PARALLEL_MIN_ROWS + 6
    x = _states(model, n, seed=4)
    rng = np.random.default_rng(5)
    u, tau = rng.uniform(-24, 24, (n, 2)), rng.normal(0, 0.5, n)
    xb, eb = model.step(x, u, tau, 2e-3)
    for i in range(n):
        xi, ei = model.step(x[i:i + 1], u[i:i + 1], tau[i:i + 1], 2e-3)
        assert _same_bits(xb[i], xi[0]) and _same_bits(eb[i], ei[0]), f"row {i}"


def test_serial_and_parallel_kernels_have_their_own_cache_entries():
    """numba's cache key ignores ``parallel``: the two compilations of a kernel must not share a function name."""
    from vsa_gym.devices.vsaut2 import model as core

    for serial, parallel in ((core.rk4_rows, core.rk4_rows_parallel),
                             (core.etd_rows, core.etd_rows_parallel)):
        assert serial.py_func.__qualname__ != parallel.py_func.__qualname__
        assert serial.py_func.__code__ is parallel.py_func.__code__  # the same kernel, compiled twice


def test_core_modes_command_gives_the_poles_the_integrators_are_chosen_against():
    """benchmarks.core_modes reproduces the poles quoted in the VsaUT2Model docstring."""
    from benchmarks.core_modes import modes

    ev = modes(0.002)
    assert ev.real[0] == pytest.approx(-8.95e3, rel=0.01) and ev.real[1] == pytest.approx(-3.62e3, rel=0.01)
    pair = ev[np.argmax(ev.imag)]
    assert pair.real == pytest.approx(-209, rel=0.02) and pair.imag == pytest.approx(3566, rel=0.01)
