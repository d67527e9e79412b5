"""The drive's gearbox efficiency acts at the mesh: rotor inertia before it, direction by the mesh power."""

from __future__ import annotations

import numpy as np
import pytest

from vsa_gym.devices.drive.model import N_STATE, DriveParams, simulate, substeps

M, FRAC, F = 2.0, 0.3, 10.0  # kg, motor-side share, N


def _speed_after(params: DriveParams, u: float, v0: float, t: float = 0.02, dt: float = 1e-3) -> float:
    n = int(round(t / dt))
    x0 = np.zeros(N_STATE)
    x0[[1, 3]] = v0
    y = simulate(params.vector(1), np.full(n + 1, u), dt, x0=x0, n_sub=20)
    return float(y[-1, 0, 1])


def test_forward_efficiency_acts_on_the_force_past_the_rotor_inertia():
    eta, eta_b = 0.7, 0.5
    p = DriveParams(m=M, k_u=1.0, frac_m=FRAC, eta=eta, eta_b=eta_b, v_eps=1e-4)
    a = eta * F / ((1 - FRAC) * M + eta * FRAC * M)  # forward: x'' = eta F / (m_l + eta m_m)
    v = _speed_after(p, F, v0=0.05)
    assert v == pytest.approx(0.05 + a * 0.02, rel=1e-6)


def test_back_driven_efficiency_brakes_harder_than_the_motor_force():
    eta, eta_b = 0.7, 0.5
    p = DriveParams(m=M, k_u=1.0, frac_m=FRAC, eta=eta, eta_b=eta_b, v_eps=1e-4)
    a = -F / eta_b / ((1 - FRAC) * M + FRAC * M / eta_b)  # back-driven: (F_m / eta_b) / (m_l + m_m / eta_b)
    v = _speed_after(p, -F, v0=1.0)
    assert v == pytest.approx(1.0 + a * 0.02, rel=1e-6)


def test_lossless_mesh_is_the_rigid_body_and_eta_b_defaults_to_eta():
    v = _speed_after(DriveParams(m=M, k_u=1.0, frac_m=FRAC), F, v0=0.05)
    assert v == pytest.approx(0.05 + F / M * 0.02, rel=1e-9)
    same = DriveParams(m=M, k_u=1.0, frac_m=FRAC, eta=0.8, v_eps=1e-4)
    both = DriveParams(m=M, k_u=1.0, frac_m=FRAC, eta=0.8, eta_b=0.8, v_eps=1e-4)
    for u, v0 in ((F, 0.05), (-F, 1.0)):
        assert _speed_after(same, u, v0) == _speed_after(both, u, v0)


def test_mesh_never_delivers_more_power_than_it_receives():
    """Over random forces and speeds (away from the tanh blend at v = 0) the mesh loss is >= 0."""
    rng = np.random.default_rng(0)
    dt = 1e-5
    for _ in range(40):
        eta, eta_b = rng.uniform(0.4, 1.0, 2)
        frac = rng.uniform(0.05, 0.9)
        p = DriveParams(m=M, k_u=1.0, frac_m=frac, eta=eta, eta_b=eta_b, v_eps=1e-5)
        u, v0 = rng.uniform(-20, 20), rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 2.0)
        x0 = np.zeros(N_STATE)
        x0[[1, 3]] = v0
        a = (simulate(p.vector(1), np.full(2, u), dt, x0=x0, n_sub=1)[-1, 0, 1] - v0) / dt
        mesh_in = (u - frac * M * a) * v0  # motor force less the rotor's inertia force, times speed
        mesh_out = (1 - frac) * M * a * v0  # what the load side receives
        assert mesh_in - mesh_out >= -1e-6 * abs(mesh_in)


def test_friction_that_sticks_holds_exactly_and_slides_beyond_the_breakaway_force():
    """With ``sticks`` the load at rest holds below F_c without moving at all (the tanh law creeps); above it
    slides with (F - F_c) / m."""
    F_c = 5.0
    p = DriveParams(m=M, k_u=1.0, F_c=F_c, sticks=1.0, v_eps=1e-3)
    held = simulate(p.vector(1), np.full(3000, 0.9 * F_c), 1e-3)[:, 0, 0]
    assert np.all(held == 0.0)
    tanh_law = simulate(DriveParams(m=M, k_u=1.0, F_c=F_c, v_eps=1e-3).vector(1), np.full(3000, 0.9 * F_c),
                        1e-3)[:, 0, 0]
    assert tanh_law[-1] > 1e-4  # the regularised law creeps
    slid = simulate(p.vector(1), np.full(1001, 1.5 * F_c), 1e-3)[:, 0, 1]
    assert slid[-1] == pytest.approx(0.5 * F_c / M * 1.0, rel=1e-9)  # (1.5 F_c - F_c) / m after 1 s


def test_stick_slip_events_are_located_inside_the_sample():
    """The mode changes fall between samples and are located there, one substep per sample: a load sliding at
    v0 against friction alone stops at t = m v0 / F_c after m v0^2 / (2 F_c) and stays; under a force ramp
    r t it breaks away at t* = F_c / r and then moves r (t - t*)^3 / (6 m)."""
    F_c, v0, dt = 5.0, 0.37, 1e-2
    p = DriveParams(m=M, k_u=1.0, F_c=F_c, sticks=1.0)
    x0 = np.zeros(N_STATE)
    x0[[1, 3]] = v0
    y = simulate(p.vector(1), np.zeros(40), dt, x0=x0, n_sub=1)[:, 0, :]
    t_stop = M * v0 / F_c  # 0.148 s: between samples 14 and 15
    before = np.arange(40) * dt < t_stop
    np.testing.assert_allclose(y[before, 1], v0 - F_c / M * np.arange(40)[before] * dt, atol=1e-12)
    assert np.all(y[~before, 1] == 0.0)
    np.testing.assert_allclose(y[~before, 0], M * v0**2 / (2 * F_c), rtol=1e-12)
    r = 40.0  # N/s: breaks away at 0.125 s, between samples
    t = np.arange(60) * dt
    ramp = simulate(p.vector(1), r * t, dt, n_sub=1)[:, 0, 0]
    # the force is held over each sample (zero-order hold): integrate that staircase exactly
    exact = np.zeros_like(t)
    x = v = 0.0
    for k in range(1, len(t)):
        f = r * t[k - 1]
        if v == 0.0 and f <= F_c:
            exact[k] = x
            continue
        a = (f - F_c) / M
        x, v = x + v * dt + 0.5 * a * dt**2, v + a * dt
        exact[k] = x
    np.testing.assert_allclose(ramp, exact, atol=1e-12)


def test_stick_slip_behind_a_gap_converges_to_a_fine_reference():
    """A load that sticks behind a backlash, driven back and forth through the gap: the roll-out at the model's
    own substeps is within 0.5 % of the travel of one at 32x the substeps, and 4x the substeps within 0.1 %
    (the events are located inside the substeps, so refining converges instead of chattering)."""
    dt = 1e-3
    u = 8.0 * np.sin(2 * np.pi * 1.5 * np.arange(3000) * dt)
    P = DriveParams(m=M, k_u=1.0, F_c=5.0, sticks=1.0, frac_m=FRAC, backlash=1e-3, b=0.5).vector(1)
    n = substeps(P, dt)
    ref = simulate(P, u, dt, n_sub=32 * n)[:, 0, :]
    assert np.mean(ref[:, 1] == 0.0) > 0.02  # the load does stick between the strokes
    span = float(np.ptp(ref[:, 0]))
    for k, tol in ((n, 5e-3), (4 * n, 1e-3)):
        y = simulate(P, u, dt, n_sub=k)[:, 0, :]
        assert np.all(np.isfinite(y))
        assert np.max(np.abs(y[:, [0, 2]] - ref[:, [0, 2]])) < tol * span, k


@pytest.mark.parametrize("delta", [1.0, 1.5, 2.0])
def test_stribeck_shape_exponent_sets_the_steady_sliding_speed(delta):
    """Under a constant force the load settles where F = F_s exp(-|v/v_s|^delta) + b v (Tustin at delta = 1,
    LuGre's Gaussian at 2); the speed found by simulation is that root."""
    from scipy.optimize import brentq

    F_s, v_s, b, force = 4.0, 0.05, 20.0, 3.5
    p = DriveParams(m=M, k_u=1.0, F_s=F_s, v_s=v_s, b=b, v_eps=1e-5, delta_s=delta)
    x0 = np.zeros(N_STATE)
    x0[[1, 3]] = 0.3  # start sliding above the root, so that the load slides down onto it
    v = simulate(p.vector(1), np.full(4001, force), 1e-3, x0=x0)[-1, 0, 1]
    root = brentq(lambda w: F_s * np.exp(-abs(w / v_s) ** delta) + b * w - force, 0.06, 0.3)
    assert v == pytest.approx(root, rel=1e-6)


def test_default_stribeck_shape_is_the_gaussian_bit_for_bit():
    p = DriveParams(m=M, k_u=1.0, F_c=1.0, F_s=2.0, v_s=0.05, v_eps=1e-3)
    u = np.sin(np.linspace(0, 20, 2000)) * 4.0
    same = simulate(p.vector(1), u, 1e-3)
    assert np.array_equal(same, simulate(DriveParams(**{**p.__dict__, "delta_s": 2.0}).vector(1), u, 1e-3))
    other = simulate(DriveParams(**{**p.__dict__, "delta_s": 1.0}).vector(1), u, 1e-3)
    assert not np.allclose(same, other)


def test_a_diverging_roll_out_raises_naming_the_row_instead_of_returning_nan():
    """A contact far too stiff for the substep cap: the public roll-out names the row and the substeps; the
    identification path (``diverged="nan"``) gets the non-finite row back to score it as infinitely bad."""
    ok = DriveParams(m=M, k_u=1.0, frac_m=FRAC, backlash=1e-3)
    stiff = DriveParams(m=M, k_u=1.0, frac_m=FRAC, backlash=1e-3, k_contact=1e14)
    P = np.vstack([ok.vector(1), stiff.vector(1)])
    u = np.sin(np.linspace(0, 20, 400)) * F
    with pytest.raises(FloatingPointError, match=r"row\(s\) \[1\].*capped at 400"):
        simulate(P, u, 1e-2)
    y = simulate(P, u, 1e-2, diverged="nan")
    assert np.all(np.isfinite(y[:, 0])) and not np.all(np.isfinite(y[:, 1]))
    with pytest.raises(ValueError, match="diverged must be"):
        simulate(P, u, 1e-2, diverged="ignore")
