"""The exponential RK4 weights in both forms, and the drive's Dahl force stepped by them against a stiff reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import vsa_gym.devices.drive.model as drive
from vsa_gym.physics.integrate import etdrk4_weights, etdrk4_weights_scalar


def test_scalar_weights_equal_the_array_weights_on_both_branches() -> None:
    h = 1e-3
    # lam h from 0 (RK4) through the Taylor branch (|zeta| < 0.1) to the closed form and far beyond
    lam = np.concatenate([[0.0], np.geomspace(1e-3, 1e6, 400), [99.99, 100.0, 100.01, 199.99, 200.0, 200.01]])
    arrays = etdrk4_weights(lam, h)
    for i, value in enumerate(lam):
        scalar = etdrk4_weights_scalar(float(value), h)
        for a, s in zip(arrays, scalar, strict=True):
            assert s == pytest.approx(float(a[i]), rel=1e-13, abs=1e-300)
    rk4 = etdrk4_weights_scalar(0.0, h)  # no decay: the RK4 weights
    assert rk4 == pytest.approx((1.0, h / 2, 1.0, 1 / 6, 1 / 3, 1 / 6), rel=1e-15)


def _radau(P: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    def f(_t: float, s: np.ndarray, uk: float) -> np.ndarray:
        return np.array(drive.rhs_point((P[0], uk, 0.0, False), tuple(s)))

    s, out = np.zeros(drive.N_STATE), []
    for uk in u:
        out.append(s.copy())
        s = solve_ivp(f, (0.0, dt), s, method="Radau", rtol=1e-10, atol=1e-13, args=(float(uk),)).y[:, -1]
    return np.array(out)


@pytest.mark.parametrize("F_h, x_h, m", [(0.3, 2e-6, 1.0), (0.1, 3e-6, 0.2)])
def test_dahl_force_with_a_short_presliding_travel_matches_radau(F_h: float, x_h: float, m: float) -> None:
    """A presliding travel far below one sample's travel (the Dahl decay ``sigma |v| / F_h`` up to 1e5 1/s) no longer
    sets the substeps: the exponential stepper integrates the decay exactly and stays within 1e-3 of Radau."""
    dt, T = 1e-3, 1500
    t = np.arange(T) * dt
    u = 0.6 * np.sin(2 * np.pi * 1.5 * t) + 0.3 * np.sin(2 * np.pi * 4.1 * t)  # many reversals
    P = drive.DriveParams(m=m, b=0.5, k_u=1.0, F_h=F_h, sigma_h=F_h / x_h, F_c=0.05, v_eps=1e-3).vector(1)
    n_sub = drive.substeps(P, dt)
    ref = _radau(P, u, dt)
    v_max = float(np.max(np.abs(ref[:, 1])))
    assert np.ceil(v_max / x_h * dt / 1.5) >= 10 * n_sub  # RK4 alone would need ten times the substeps
    y = drive.simulate(P, u, dt)[:, 0, :]
    for j in (0, 1):
        assert np.max(np.abs(y[:, j] - ref[:, j])) < 1e-3 * np.max(np.abs(ref[:, j]))
    # the hysteresis force itself (state 5) through the drive's force balance: the loop reaches +-F_h
    assert np.max(np.abs(ref[:, 5])) == pytest.approx(F_h, rel=0.05)


def test_the_drive_lag_at_its_wider_reach_passes_the_exact_lag_impulse_to_the_motion() -> None:
    """A force step through the lag ``tau_e`` on a free mass: at the rule's substeps (``h / tau_e`` = 2.5, where
    the nonlinear reach would take 4) the speed once the transient has passed is the exact lag's
    ``F / m (t - tau_e)`` to round-off, because RK4's discrete lag misses exactly ``tau_e`` times the step of
    impulse (:func:`~vsa_gym.devices.drive.model.row_substeps`)."""
    dt, tau, F, m = 1e-3, 2e-4, 3.0, 2.0
    P = drive.DriveParams(m=m, k_u=F, tau_e=tau).vector(1)
    assert drive.row_substeps(P, dt).tolist() == [2]
    assert np.ceil(float(drive.lag_rate(P)[0]) * dt / drive.RK4_REACH) == 4
    t = np.arange(60) * dt
    y = drive.simulate(P, np.ones(60), dt)[:, 0, :]
    v = F / m * (t - tau + tau * np.exp(-t / tau))
    x = F / m * (t**2 / 2 - tau * t + tau**2 * (1 - np.exp(-t / tau)))
    late = t >= 0.03
    assert np.max(np.abs(y[late, 1] - v[late])) < 1e-9 * np.max(v)
    # the position keeps only the transient's spread over the first substeps: under 1 % of the lag's own effect
    assert np.max(np.abs(y[:, 0] - x)) < 0.01 * F / m * tau * t[-1]


def test_the_drive_lag_at_its_wider_reach_stays_within_the_error_the_rule_accepts_for_friction() -> None:
    """A lag, a lossy mesh both ways and a viscous friction driven by a multisine with steps at 1 kHz, against
    Radau: with ``tau_e`` = 0.22 ms the rule takes 2 substeps (``h / tau_e`` = 2.27); the replay's error is no
    larger than that of the same drive whose Coulomb friction sets 1 substep at ``h |lambda|`` = 1.45, the reach
    the rule gives every nonlinear mode, and both stay under 1e-3 of the position's spread (NRMSE)."""
    dt = 1e-3
    t = np.arange(3000) * dt
    u = (0.6 * np.sin(2 * np.pi * 1.3 * t) + 0.4 * np.sin(2 * np.pi * 7.1 * t)
         + 0.2 * np.sign(np.sin(2 * np.pi * 3.3 * t)))
    base = {"m": 0.5, "b": 0.8, "k_u": 2.0, "eta": 0.8, "eta_b": 0.7, "frac_m": 0.4, "F_c": 0.2}
    errors = {}
    for name, kw in {"lag": {"tau_e": 2.2e-4, "v_eps": 2e-2}, "friction": {"v_eps": 0.2 / (1450.0 * 0.5)}}.items():
        P = drive.DriveParams(**base, **kw).vector(1)
        ref = _radau(P, u, dt)
        y = drive.simulate(P, u, dt)[:, 0, 0]
        errors[name] = (drive.substeps(P, dt), float(np.sqrt(np.mean((y - ref[:, 0]) ** 2)) / np.std(ref[:, 0])))
    assert errors["lag"][0] == 2 and errors["friction"][0] == 1
    assert errors["lag"][1] <= errors["friction"][1] < 1e-3
