"""Rig and vehicle models: Radau reference, energy balance, batching, extensions, input checks."""

import functools
from collections.abc import Callable

import numpy as np
import pytest

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.extensions import ExtensionContext, ExtensionOutput
from vsa_gym.devices.elpas.params import GRAVITY, DriveParams, ElpasEffects, ElpasParams
from vsa_gym.physics.integrate import reference_solution

P = ElpasParams()
DT = float(P.numerics.dt)


class _NullExtension:
    """An extension with one state that adds nothing (the numpy extension path on the nominal physics)."""

    name = "null"
    n_states = 1

    def initial_state(self, n: int) -> np.ndarray:
        return np.zeros((n, 1))

    def evaluate(self, ctx: ExtensionContext, s: np.ndarray) -> ExtensionOutput:
        zero = np.zeros(s.shape[0])
        return ExtensionOutput(torque_gamma=zero, force_act=zero, state_derivative=np.zeros_like(s))


def _rig_run(p: ElpasParams, u: np.ndarray, alpha: np.ndarray, x0: np.ndarray,
             ext: tuple = ()) -> tuple[np.ndarray, np.ndarray]:
    """Step the rig through per-step voltages/alphas; returns states (T+1, ns) and energies (T, ch)."""
    x, xs, es = x0, [x0[0]], []
    for k in range(u.size):
        x, e = em.step_rig(p, x, np.array([[u[k], alpha[k]]]), ext)
        xs.append(x[0])
        es.append(e[0])
    return np.array(xs), np.array(es)


def _rig_reference(p: ElpasParams, u: np.ndarray, alpha: np.ndarray, x0: np.ndarray) -> np.ndarray:
    a_prev = np.concatenate([[x0[0, em.ALPHA]], alpha[:-1]])

    def factory(k: int) -> Callable:
        inp = np.array([[u[k], (alpha[k] - a_prev[k]) / DT]])
        return lambda xx: em.rhs_rig(p, xx, inp)

    return reference_solution(factory, x0[0], DT, u.size, rtol=1e-7, atol=1e-10)[0]


def _worst_relative_error(x: np.ndarray, ref: np.ndarray) -> float:
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-9)
    return float(np.max(np.abs(x - ref).max(axis=0) / scale))


def _rig_cases() -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    rng = np.random.default_rng(7)
    n = 100
    t = DT * np.arange(1, n + 1)
    bang = np.repeat(rng.choice([-42.0, 42.0], n // 20), 20)  # saturating, speed reversals
    return [
        ("bang-bang voltage, alpha sine 3 Hz", bang, np.radians(8.0) * np.sin(2 * np.pi * 3 * t), 0.0),
        ("slow voltage through zero speed, alpha = -12 deg", 3.0 * np.sin(2 * np.pi * 5 * t),
         np.full(n, np.radians(-12.0)), 0.5),
        ("random steps at 10 ms, alpha ramp", np.repeat(rng.uniform(-20, 20, n // 10), 10),
         np.radians(np.linspace(0.0, 14.0, n)), -0.8),
    ]


@functools.cache
def _rig_case_reference(case: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(u, alpha, x0, Radau states) of one rig case, computed once per session."""
    _, u, alpha, g0 = _rig_cases()[case]
    x0 = em.initial_state_rig(P, 1, gamma=g0, alpha=0.0 if case != 1 else alpha[0])
    return u, alpha, x0, _rig_reference(P, u, alpha, x0)


@pytest.mark.parametrize("case", range(3))
def test_rig_matches_radau_reference(case: int) -> None:
    u, alpha, x0, ref = _rig_case_reference(case)
    xs, _ = _rig_run(P, u, alpha, x0)
    assert _worst_relative_error(xs, ref) <= 1e-3


def test_substeps_are_inside_rk4_stability_and_needed() -> None:
    """n_sub = 4 (h = 0.25 ms): |h lambda| stays far inside RK4's region for the fast modes."""
    h = DT / P.numerics.n_sub
    m, d = P.motor, P.drive
    electrical = m.R / m.L  # 520 1/s
    electromech = np.sqrt(d.N**2 * m.k_t * m.k_e / (m.L * d.J_r))  # 424 rad/s
    presliding = np.sqrt(d.N**2 * P.friction.s0 / d.J_r)  # 273 rad/s
    assert h * max(electrical, electromech, presliding) < 0.2
    # and a coarser step is measurably worse on the hardest case
    u, alpha, x0, ref = _rig_case_reference(0)
    coarse = P.replace(numerics=P.numerics.replace(n_sub=1.0))
    err_coarse = _worst_relative_error(_rig_run(coarse, u, alpha, x0)[0], ref)
    err = _worst_relative_error(_rig_run(P, u, alpha, x0)[0], ref)
    assert err < 1e-3 < err_coarse


def test_rig_energy_balance() -> None:
    _, u, alpha, g0 = _rig_cases()[0]
    x0 = em.initial_state_rig(P, 1, gamma=g0)
    xs, es = _rig_run(P, u, alpha, x0)
    e = es.sum(axis=0)
    stored = em.stored_energy(P, xs[-1:], vehicle=False)[0] - em.stored_energy(P, xs[:1], vehicle=False)[0]
    out = stored + e[em.P_RES] + e[em.P_FRIC] + e[em.P_STOP] + e[em.P_DAMPER] + e[em.P_EXT] + e[em.P_OUT]
    assert e[em.P_EL] > 10.0
    assert e[em.P_EL] == pytest.approx(out, rel=1e-4, abs=1e-3)


def test_gamma_end_stop_holds_and_conserves_energy() -> None:
    u = np.full(400, -20.0)  # negative omega_m -> positive dgamma/dt, into the +90 deg stop
    x0 = em.initial_state_rig(P, 1, gamma=1.2)
    xs, es = _rig_run(P, u, np.zeros(400), x0)
    assert xs[:, em.GAMMA].max() > P.cone.gamma_max
    assert xs[:, em.GAMMA].max() < P.cone.gamma_max + np.radians(3.0)
    e = es.sum(axis=0)
    stored = em.stored_energy(P, xs[-1:], False)[0] - em.stored_energy(P, xs[:1], False)[0]
    assert e[em.P_STOP] > 0.0
    assert e[em.P_EL] == pytest.approx(stored + e[1:].sum(), rel=1e-4)


def _vehicle_run(p: ElpasParams, u: np.ndarray, road: np.ndarray, x0: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    x, xs, es = x0, [x0.copy()], []
    for k in range(u.shape[0]):
        x, e = em.step_vehicle(p, x, np.stack([u[k], road[k]], axis=-1).reshape(x.shape[0], 2))
        xs.append(x.copy())
        es.append(e)
    return np.array(xs), np.array(es)


def _vehicle_cases() -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(3)
    n = 100
    t = DT * np.arange(1, n + 1)
    return [
        (np.repeat(rng.uniform(-42, 42, n // 15), 15), 0.03 * np.sin(2 * np.pi * 4 * t)),
        (np.full(n, 5.0), np.where(t > 0.02, 0.04, 0.0) * np.minimum((t - 0.02) / 0.01, 1.0).clip(0)),
    ]


@pytest.mark.parametrize("case", range(2))
def test_vehicle_matches_radau_reference(case: int) -> None:
    u, road = _vehicle_cases()[case]
    x0 = em.initial_state_vehicle(P, 1)
    xs, _ = _vehicle_run(P, u, road, x0)
    r_prev = np.concatenate([[0.0], road[:-1]])

    def factory(k: int) -> Callable:
        inp = np.array([[u[k], (road[k] - r_prev[k]) / DT]])
        return lambda xx: em.rhs_vehicle(P, xx, inp)

    ref = reference_solution(factory, x0[0], DT, u.size, rtol=1e-7, atol=1e-10)[0]
    assert _worst_relative_error(xs[:, 0], ref) <= 1e-3


def test_vehicle_energy_balance_and_tyre_lift_off() -> None:
    n = 300
    t = DT * np.arange(1, n + 1)
    road = np.where(t > 0.05, -0.12, 0.0)  # 12 cm drop: the wheel leaves the ground
    road = np.where((t > 0.05) & (t < 0.06), -0.12 * (t - 0.05) / 0.01, road)
    u = 10.0 * np.sin(2 * np.pi * 6 * t)
    x0 = em.initial_state_vehicle(P, 1)
    xs, es = _vehicle_run(P, u, road, x0)
    tyre = np.array([em.tyre_force(P, x)[0] for x in xs])
    assert np.min(tyre) == 0.0 and np.max(tyre) > 0.0
    e = es[:, 0].sum(axis=0)
    stored = em.stored_energy(P, xs[-1], True)[0] - em.stored_energy(P, xs[0], True)[0]
    # the wheel falls 12 cm and lands: compare with the gross energy exchanged (kinks in the tyre force)
    gross = abs(stored) + np.abs(e).sum()
    assert gross > 100.0
    assert e[em.P_EL] == pytest.approx(stored + e[1:].sum(), abs=1e-4 * gross)


def test_quarter_car_settles_to_static_equilibrium_near_gamma_zero() -> None:
    # a physics test, not a numerics one: 2 ms steps with 0.5 ms substeps keep it fast
    p = P.replace(numerics=P.numerics.replace(dt=2e-3, n_sub=4.0))
    x0 = em.initial_state_vehicle(p, 2)
    x0[:, em.Y_S] += np.array([0.01, -0.02])  # displaced body, released at rest, motor shorted (u = 0)
    n = 1250  # 2.5 s: the body mode (1.3 Hz, zeta ~ 0.3) has decayed to ~0.5 %
    xs, _ = _vehicle_run(p, np.zeros((n, 2)), np.zeros((n, 2)), x0)
    assert np.max(np.abs(xs[:, :, em.V_S])) > 0.05  # it did move
    x = xs[-1]
    a_eq = em.equilibrium_alpha(p, x[:, em.GAMMA])
    np.testing.assert_allclose(x[:, em.ALPHA], a_eq, atol=2e-3)
    assert np.all(np.abs(x[:, em.GAMMA]) < np.radians(0.5))
    assert np.all(np.abs(x[:, em.V_S]) < 2e-3) and np.all(np.abs(x[:, em.ALPHA_DOT]) < 1e-2)
    np.testing.assert_allclose(em.tyre_force(p, x), (p.car.m_s + p.car.m_u) * GRAVITY, rtol=3e-3)
    np.testing.assert_allclose(em.actuator_force_of(p, x), p.car.m_s * GRAVITY, rtol=3e-3)


def test_batched_run_equals_single_runs() -> None:
    jr = np.array([0.6, 0.7, 0.85])
    pb = P.replace(drive=DriveParams(J_r=jr))
    rng = np.random.default_rng(11)
    u = rng.uniform(-30, 30, (60, 3))
    alpha = np.radians(rng.uniform(-10, 10, (60, 3)))
    xb = em.initial_state_rig(pb, 3, gamma=np.array([0.0, 0.3, -0.4]))
    for k in range(60):
        xb, eb = em.step_rig(pb, xb, np.stack([u[k], alpha[k]], axis=1))
    for j in range(3):
        pj = P.replace(drive=DriveParams(J_r=float(jr[j])))
        xj = em.initial_state_rig(pj, 1, gamma=[0.0, 0.3, -0.4][j])
        for k in range(60):
            xj, _ = em.step_rig(pj, xj, np.array([[u[k, j], alpha[k, j]]]))
        np.testing.assert_allclose(xb[j], xj[0], rtol=1e-12, atol=1e-14)


def test_arm_hysteresis_column() -> None:
    """The arm hysteresis (Dahl, ``effects.M_h``) is a state column of the compiled core: the loop saturates at
    ``M_h``, the energy balance closes with its stored part and its dissipation in the friction channel, and
    ``M_h = 0`` keeps the nominal layout."""
    rng = np.random.default_rng(5)
    u = np.repeat(rng.uniform(-25, 25, 10), 20)
    alpha = np.radians(5.0) * np.ones(200)
    on = P.replace(effects=ElpasEffects(M_h=30.0, phi_h=0.01))
    assert em.initial_state_rig(P, 1).shape == (1, em.N_RIG)
    assert em.initial_state_rig(on, 1).shape == (1, em.N_RIG + 1)
    x_base, _ = _rig_run(P, u, alpha, em.initial_state_rig(P, 1))
    x_on, e_on = _rig_run(on, u, alpha, em.initial_state_rig(on, 1))
    assert np.max(np.abs(x_on[:, em.GAMMA] - x_base[:, em.GAMMA])) > 1e-3
    assert np.max(np.abs(x_on[:, em.effect_column(False)])) == pytest.approx(30.0, rel=0.05)  # saturates at M_h
    e = e_on.sum(axis=0)
    stored = em.stored_energy(on, x_on[-1:], False)[0] - em.stored_energy(on, x_on[:1], False)[0]
    assert e[em.P_EXT] == 0.0
    assert e[em.P_EL] == pytest.approx(stored + e[1:].sum(), rel=1e-4)
    with pytest.raises(ValueError, match="Extension protocol"):
        em.step_rig(P, em.initial_state_rig(P, 1), np.array([[0.0, 0.0]]), ("not an extension",))


def test_arm_hysteresis_rows_off_are_nominal_bit_for_bit() -> None:
    """A batch whose rows have ``M_h`` 0 and > 0 carries the column for all; the rows with ``M_h = 0`` step
    exactly as the nominal model (rig and vehicle), their hysteresis state stays 0."""
    pb = P.replace(effects=ElpasEffects(M_h=np.array([0.0, 20.0]), phi_h=np.array([0.01, 0.01])))
    rng = np.random.default_rng(3)
    for vehicle in (False, True):
        init = em.initial_state_vehicle if vehicle else em.initial_state_rig
        step = em.step_vehicle if vehicle else em.step_rig
        xb, xn = init(pb, 2), init(P, 1)
        assert xb.shape[1] == xn.shape[1] + 1
        for k in range(60):
            volt = rng.uniform(-42.0, 42.0)
            ext = 0.01 * np.sin(k / 7.0) if vehicle else np.radians(5.0) * np.sin(k / 7.0)
            xb, eb = step(pb, xb, np.array([[volt, ext], [volt, ext]]))
            xn, en = step(P, xn, np.array([[volt, ext]]))
            np.testing.assert_array_equal(xb[0, :-1], xn[0])
            np.testing.assert_array_equal(eb[0], en[0])
            assert xb[0, -1] == 0.0
        assert np.max(np.abs(xb[1, :-1] - xn[0])) > 0.0


def test_bad_inputs_are_rejected() -> None:
    x = em.initial_state_rig(P, 1)
    with pytest.raises(ValueError, match="voltage"):
        em.step_rig(P, x, np.array([[np.nan, 0.0]]))
    with pytest.raises(ValueError, match="alpha"):
        em.step_rig(P, x, np.array([[1.0, np.radians(16.0)]]))
    with pytest.raises(ValueError, match="alpha"):
        em.initial_state_rig(P, 1, alpha=-0.3)
    with pytest.raises(ValueError, match="road height"):
        em.step_vehicle(P, em.initial_state_vehicle(P, 1), np.array([[0.0, np.inf]]))
    with pytest.raises(ValueError, match="inputs"):
        em.step_rig(P, x, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="J_r"):
        DriveParams(J_r=-1.0)
    with pytest.raises(ValueError, match="N"):
        DriveParams(N=0.0)


def test_quarter_car_on_iso_roads_comfort_scales_with_class() -> None:
    """Road -> vehicle -> ISO 2631-1 pipeline: one class up doubles the road amplitude, and the
    nearly linear car (motor shorted, u = 0) doubles the weighted RMS body acceleration."""
    from vsa_gym.vehicle import comfort, road

    p = P.replace(numerics=P.numerics.replace(dt=2e-3, n_sub=4.0))
    dt, n = 2e-3, 1000
    heights = np.stack([road.road_signal(c, speed=20.0, duration=n * dt, dt=dt, seed=4) for c in "BC"], axis=1)
    x = em.initial_state_vehicle(p, 2)
    acc = np.empty((2, n))
    for k in range(n):
        v0 = x[:, em.V_S].copy()
        x, _ = em.step_vehicle(p, x, np.stack([np.zeros(2), heights[k + 1]], axis=1))
        acc[:, k] = (x[:, em.V_S] - v0) / dt
    aw = comfort.weighted_rms(acc, 1.0 / dt, settle=0.7)
    assert 0.01 < aw[0] < 1.0
    assert aw[1] / aw[0] == pytest.approx(2.0, rel=0.1)
    assert np.all(em.tyre_force(p, x) > 0.0)


def test_extension_path_runs_the_same_scheme() -> None:
    """With extensions the step runs the numpy path of the same scheme (``physics.integrate.exponential_rk4`` over
    the numpy right-hand side); with a null extension it equals the compiled step (the generic row stepper) to
    round-off -- numpy's exp/cos/tanh may round the last bit differently --, reversal refinement included
    (bang-bang voltages reverse the speed), rig and vehicle, batched parameters, the arm hysteresis column on in
    one row."""
    from vsa_gym.devices.elpas.integrator import reversal_rows

    pb = P.replace(drive=DriveParams(J_r=np.array([0.6, 0.7])),
                   effects=ElpasEffects(M_h=np.array([0.0, 20.0]), phi_h=np.array([0.01, 0.01])))
    null = (_NullExtension(),)
    h = DT / em.substep_count(pb)
    rng = np.random.default_rng(2)
    for vehicle in (False, True):
        if vehicle:
            xa, xb = em.initial_state_vehicle(pb, 2), em.initial_state_vehicle(pb, 2, extensions=null)
        else:
            gamma = np.array([0.0, 0.5])
            xa, xb = em.initial_state_rig(pb, 2, gamma=gamma), em.initial_state_rig(pb, 2, gamma=gamma, extensions=null)
        step = em.step_vehicle if vehicle else em.step_rig
        refined = 0
        for k in range(40):
            drive = np.repeat(rng.choice([-42.0, 42.0]), 2) * np.array([1.0, -1.0])
            ext = np.full(2, 0.01 * np.sin(k / 7.0)) if vehicle else np.full(2, np.radians(5.0) * np.sin(k / 7.0))
            inp = np.stack([drive, ext], axis=1)
            x0 = xa
            xa, ea = step(pb, xa, inp)
            xb, eb = step(pb, xb, inp, null)
            refined += int(reversal_rows(x0, xa, em.params_matrix(pb, 2), h).sum())
            np.testing.assert_allclose(xb[:, :-1], xa, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(eb, ea, rtol=1e-12, atol=1e-15)
        assert refined > 0
