"""A replay of part of a batch is the batch's own: ``Adapter.simulate(until=, rows=)`` and the fit's residual
and Jacobian, which replay only what they use (records of the independent truth simulator, tests/truthsim)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.fitting import SimulationErrorProblem
from vsa_gym.identify.record import load_record

PLANTED = ("coulomb_friction", "backlash")


def _case(seed: int, folder):
    rec = load_record(write_case(draw_case(seed, PLANTED), folder))
    return make_adapter(rec), rec.masks()


def _candidates(ad, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """``n`` candidates of friction that sticks or creeps (sharply or not), and backlash of stiff and soft
    contacts, around the effects' typical sizes."""
    c, b = ad.effects["coulomb_friction"], ad.effects["backlash"]
    return {"coulomb_friction.F_c": c.params[0].typical * rng.uniform(0.2, 2.0, n),
            "coulomb_friction.sticks": np.where(rng.random(n) < 0.5, 0.0, 1.0),
            "backlash.width": b.params[0].typical * rng.uniform(0.0, 2.0, n),
            "coulomb_friction.v_t": float(ad.params.v_eps) * 10.0 ** rng.uniform(-2.0, 0.0, n),
            "backlash.f_contact": 10.0 ** rng.uniform(1.3, 2.5, n)}


@pytest.mark.parametrize("seed, shooting", [(20250901, None), (20250907, None), (20250907, 0.5)],
                         ids=["closed-loop", "open-loop", "shooting"])
def test_simulate_until_and_rows_are_the_whole_batch_bit_for_bit(tmp_path, seed, shooting):
    ad, _ = _case(seed, tmp_path)
    if shooting:
        ad.set_shooting(shooting)
    n = 6
    theta = _candidates(ad, n, np.random.default_rng(seed))
    whole = ad.simulate(theta, n)
    assert np.all(np.isfinite(whole))
    # the stiffest row sets the substeps of the batch: a row alone would be integrated more coarsely
    assert len({ad.substeps(ad.param_matrix({k: v[i:i + 1] for k, v in theta.items()}, 1)) for i in range(n)}) > 1
    until, rows = int(0.7 * len(ad.t)), np.array([4, 1])
    part = ad.simulate(theta, n, until=until, rows=rows)
    assert part.shape == (len(ad.t), 2, whole.shape[2])
    np.testing.assert_array_equal(part[:until], whole[:until][:, rows])
    assert np.all(np.isnan(part[until:]))


def test_residual_alone_then_jacobian_equal_one_batch(tmp_path):
    ad, masks = _case(20250901, tmp_path)
    keys = ["coulomb_friction.F_c", "coulomb_friction.sticks", "backlash.width"]
    specs = [ad.effects[k.split(".")[0]].params[ad.effects[k.split(".")[0]].keys.index(k)] for k in keys]
    x = np.array([1.3, 0.0, 0.8])
    split = SimulationErrorProblem(ad, {}, keys, specs, masks["fit"])
    r = split.fun(x)
    r_again, J = split.residuals_and_jacobian(x)
    one = SimulationErrorProblem(ad, {}, keys, specs, masks["fit"])
    X = np.vstack([x, x + np.diag(1e-3 * np.maximum(1.0, np.abs(x)))])
    R = one.batch(X)  # the point and its steps replayed together, to the end of the record
    np.testing.assert_array_equal(r, R[0])
    np.testing.assert_array_equal(r_again, R[0])
    np.testing.assert_array_equal(J, ((R[1:] - R[0]) / (1e-3 * np.maximum(1.0, np.abs(x)))[:, None]).T)
    assert split.until == int(np.flatnonzero(masks["fit"])[-1]) + 1 < len(ad.t)
    assert np.any(J != 0.0)


def test_shooting_windows_in_one_roll_out_are_each_window_alone_bit_for_bit():
    """``simulate(starts=...)`` restarts every row at every window from that window's start state: the same
    arithmetic as one roll-out per window (friction that sticks or creeps, a Dahl loop, a gap, a lag), and a
    window list that does not tile the samples, or a closed loop, is refused."""
    from vsa_gym.devices.drive import model as drive

    rng = np.random.default_rng(7)
    rows = [drive.DriveParams(F_c=0.3, F_s=0.2, v_s=0.01, delta_s=1.6, sticks=1.0, b=0.5),
            drive.DriveParams(F_c=0.3, F_h=0.1, sigma_h=1e4, b=0.5, sticks=1.0),
            drive.DriveParams(F_c=0.2, backlash=1e-3, frac_m=0.3, b=0.5, tau_e=2e-3),
            drive.DriveParams(F_c=0.3, F_s=0.1, b=0.5)]
    P = np.vstack([r.vector(1) for r in rows])
    T, dt = 900, 1e-3
    u = np.sin(np.arange(T) * dt * 2 * np.pi * 1.3) * 0.8 + rng.normal(0, 0.05, T)
    starts = np.array([0, 250, 500, 640])
    x0 = np.zeros((len(starts), len(rows), drive.N_STATE))
    x0[:, :, 0] = x0[:, :, 2] = rng.normal(0, 0.01, (len(starts), len(rows)))
    x0[:, :, 1] = x0[:, :, 3] = rng.normal(0, 0.05, (len(starts), len(rows)))
    whole = drive.simulate(P, u, dt, x0=x0, n_sub=3, starts=starts)
    assert np.all(np.isfinite(whole))
    for w, (a, b) in enumerate(zip(starts, [*starts[1:], T], strict=True)):
        alone = drive.simulate(P, u[a:b], dt, x0=x0[w], n_sub=3)
        np.testing.assert_array_equal(whole[a:b], alone)
    for bad in (np.array([10, 300]), np.array([0, 300, 300]), np.array([0, T])):
        with pytest.raises(ValueError, match="starts"):
            drive.simulate(P, u, dt, x0=x0[:len(bad)], n_sub=3, starts=bad)
    with pytest.raises(ValueError, match="starts"):
        drive.simulate(P, u, dt, x0=x0, n_sub=3, starts=starts, controller=(1.0, 1.0, 1.0))
