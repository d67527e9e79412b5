"""Shape parameters at a bound in :func:`vsa_gym.identify.fitting.fit_model`, on a record of the independent truth
simulator (tests/truthsim): a shape the record does not hold at its bound is moved back to its default, with its
whole range as its CI; one the record presses there stays, and rejects its effect as before."""

from __future__ import annotations

import types

import numpy as np
import pytest

from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.fitting import SimulationErrorProblem, fit_model
from vsa_gym.identify.record import load_record


@pytest.fixture(scope="module")
def coulomb_case(tmp_path_factory):
    """Truth case 20250000 (Coulomb friction only), its adapter, masks and the friction fitted alone."""
    csv = write_case(draw_case(20250 * 1000, ("coulomb_friction",)), tmp_path_factory.mktemp("truth"))
    rec = load_record(csv)
    ad, masks = make_adapter(rec), rec.masks()
    f_c = ad.effects["coulomb_friction"].params[0]
    keys = [f"base.{b.name}" for b in ad.base] + ["coulomb_friction.F_c"]
    init = {**{f"base.{b.name}": b.absent for b in ad.base}, "coulomb_friction.F_c": f_c.typical}
    return ad, masks, fit_model(ad, {}, keys, [*ad.base, f_c], init, masks, ("coulomb_friction",), 10)


def test_a_shape_the_record_cannot_see_is_moved_off_its_bound(coulomb_case):
    """A gap of zero width leaves the motor's start in it out of every replay: started at its bound, the start
    stays there in the least squares, but it is not pressed there; it goes back to the middle of the gap."""
    ad, masks, held = coulomb_case
    gap = ad.effects["backlash"]
    width, start = gap.params[0], gap.params[-1]
    assert start.name == "start" and start.check_bound and not start.main
    fm = fit_model(ad, {}, held.keys + ["backlash.width", "backlash.start"], held.specs + [width, start],
                   {**held.theta(), "backlash.width": 0.0, "backlash.start": start.upper}, masks,
                   (*held.effects, "backlash"), 2)
    assert fm.theta()["backlash.start"] == start.absent
    assert "backlash.start" not in fm.at_bound
    assert tuple(fm.param("backlash.start")[1:]) == (start.lower, start.upper)


def test_a_shape_the_record_presses_to_its_bound_stays_there(coulomb_case):
    """A Dahl loop carrying the whole friction of a record that has no loop slides to its shortest travel (the
    friction sticks at once): back at its default travel it fits far worse, so it stays at the bound."""
    ad, masks, held = coulomb_case
    loop = ad.effects["hysteresis"]
    f_h, x_h = loop.params
    assert x_h.check_bound and not x_h.main
    f_c = held.theta()["coulomb_friction.F_c"]
    keys = [k for k in held.keys if k != "coulomb_friction.F_c"] + ["hysteresis.F_h", "hysteresis.x_h"]
    specs = [s for k, s in zip(held.keys, held.specs, strict=True) if k != "coulomb_friction.F_c"] + [f_h, x_h]
    fm = fit_model(ad, {}, keys, specs, {**held.theta(), "hysteresis.F_h": f_c, "hysteresis.x_h": x_h.lower},
                   masks, ("hysteresis",), 5)
    assert "hysteresis.x_h" in fm.at_bound
    assert fm.theta()["hysteresis.x_h"] == pytest.approx(x_h.lower, rel=1e-2)


def test_a_replay_that_runs_away_to_huge_finite_values_is_scored_like_a_diverged_one() -> None:
    """Truth case 149054 (a voltage drive at 200 Hz) crashed ``identify`` when a candidate row's replay ran away to
    finite values near 1e300: its squared residuals overflowed and the least squares' SVD met infinities.  Such a
    row is capped at 1e6 standard deviations per sample, as a NaN row is."""
    measured = np.linspace(0.0, 1.0, 50)[:, None]
    runaway = np.concatenate([np.linspace(0.0, 1.0, 50)[:, None, None],
                              np.full((50, 1, 1), 1e300), np.full((50, 1, 1), np.nan)], axis=1)
    ad = types.SimpleNamespace(measured=measured, simulate=lambda theta, n, until=None, rows=None: runaway)
    spec = types.SimpleNamespace(typical=1.0, absent=0.0)
    prob = SimulationErrorProblem(ad, {}, ["k"], [spec], np.ones(50, dtype=bool))
    r = prob.batch(np.zeros((3, 1)))
    assert np.all(np.isfinite(r)) and np.max(np.abs(r)) == 1e6
    assert np.isfinite(np.dot(r[1], r[1])) and np.allclose(r[0], 0.0)
