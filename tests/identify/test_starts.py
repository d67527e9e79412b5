"""Fit starts of the identification (:mod:`vsa_gym.identify.starts`) on a record of the independent truth
simulator (tests/truthsim): a friction's stick travel is one switch, a shape the switch leaves out of the
equations is not searched while it is on, and a force of the same kind as an accepted one starts with a share of
it."""

from __future__ import annotations

import numpy as np
import pytest

from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.identify import starts
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.fitting import SimulationErrorProblem, fit_model
from vsa_gym.identify.record import load_record
from vsa_gym.identify.selection import shares_force


@pytest.fixture(scope="module")
def coulomb_case(tmp_path_factory):
    """Truth case 20250000 (Coulomb friction; the tuning set of tests/identify/test_truth_records.py), its
    adapter, masks and the Coulomb friction held at its default shapes."""
    csv = write_case(draw_case(20250 * 1000, ("coulomb_friction",)), tmp_path_factory.mktemp("truth"))
    rec = load_record(csv)
    ad, masks = make_adapter(rec), rec.masks()
    spec = ad.effects["coulomb_friction"]
    keys = [f"base.{b.name}" for b in ad.base] + ["coulomb_friction.F_c"]
    specs = [*ad.base, spec.params[0]]
    init = {**{f"base.{b.name}": b.absent for b in ad.base}, "coulomb_friction.F_c": spec.params[0].typical}
    held = fit_model(ad, {}, keys, specs, init, masks, ("coulomb_friction",), 10)
    return ad, masks, held


def test_a_shape_dead_with_its_switch_is_held_on_every_point_where_the_switch_is_on(coulomb_case, monkeypatch):
    ad, masks, held = coulomb_case
    spec = ad.effects["coulomb_friction"]
    i_vt, i_xs = spec.keys.index("coulomb_friction.v_t"), spec.keys.index("coulomb_friction.sticks")
    assert spec.params[i_vt].dead_with == spec.params[i_xs].name and spec.params[i_xs].switch
    seen = []
    original = SimulationErrorProblem.batch

    def spy(self, X, rows=None):
        seen.append(self.to_p(X))
        return original(self, X, rows)

    monkeypatch.setattr(SimulationErrorProblem, "batch", spy)
    off, on = starts.shape_starts(ad, held, spec, masks["fit"])
    pts, *refined = seen  # the grid, then the main size refined at each group's best point
    assert len(refined) == 1 and len(refined[0]) > 0
    sticking = pts[:, i_xs] != spec.params[i_xs].absent
    assert sticking.any() and (~sticking).any()
    assert np.all(pts[sticking, i_vt] == spec.params[i_vt].absent)  # v_t not searched while it sticks
    assert len(np.unique(pts[~sticking, i_vt])) > 2  # but searched while it creeps
    assert on["coulomb_friction.sticks"] > 0.0 and off.get("coulomb_friction.sticks", 0.0) == 0.0
    # the refinement moves only the main size: every refined point keeps a grid point's shape
    i_fc = spec.keys.index("coulomb_friction.F_c")
    shape = [i for i in range(len(spec.keys)) if i != i_fc]
    for row in refined[0]:
        assert np.any(np.all(pts[:, shape] == row[shape], axis=1))


def test_a_switch_already_on_is_tried_on_and_off_for_a_second_friction_term(coulomb_case):
    ad, masks, held = coulomb_case
    spec = ad.effects["coulomb_friction"]
    i_xs = spec.keys.index("coulomb_friction.sticks")
    sticking = fit_model(ad, {}, held.keys + ["coulomb_friction.sticks"], held.specs + [spec.params[i_xs]],
                         {**held.theta(), "coulomb_friction.sticks": spec.params[i_xs].typical}, masks,
                         held.effects, 5)
    stribeck = ad.effects["stribeck_friction"]
    f_s = stribeck.params[0]

    def with_stribeck(fm):  # the held fit Identifier._with starts the variants from
        return fit_model(ad, {}, fm.keys + ["stribeck_friction.F_s"], fm.specs + [f_s],
                         {**fm.theta(), "stribeck_friction.F_s": f_s.typical}, masks,
                         (*fm.effects, "stribeck_friction"), 3)

    variants = starts.shape_variants(ad, sticking, with_stribeck(sticking), stribeck, masks["fit"])
    bases = [set(base.keys) for base, _ in variants]
    assert bases == [set(sticking.keys), set(sticking.keys) - {"coulomb_friction.sticks"}]
    for _, shape in variants:  # the new term's own switch stays off: one friction, one switch
        assert shape.get("stribeck_friction.sticks", 0.0) == 0.0
    # without a switch on in the model, the new term's switch is tried itself (off, then on)
    alone = starts.shape_variants(ad, held, with_stribeck(held), stribeck, masks["fit"])
    assert [base for base, _ in alone] == [held, held] and alone[1][1]["stribeck_friction.sticks"] > 0.0


def test_only_forces_of_one_kind_at_one_place_share_a_force(coulomb_case):
    ad = coulomb_case[0]
    fx = ad.effects
    assert shares_force(fx["coulomb_friction"], fx["hysteresis"])
    assert shares_force(fx["stribeck_friction"], fx["coulomb_friction"])
    assert not shares_force(fx["coulomb_friction"], fx["backlash"])  # a look-alike, but a width, not a force
    assert not shares_force(fx["hysteresis"], fx["viscous_friction"])  # no look-alike


def test_a_split_start_gives_the_new_force_a_share_of_the_accepted_one(coulomb_case):
    """Beside the fitted Coulomb friction, a Dahl loop starts with a share of its force and the friction keeps
    the rest (their sliding force stays the fitted one); a gap shares no force and gets no split start."""
    ad, masks, held = coulomb_case
    f_c = held.theta()["coulomb_friction.F_c"]
    start = starts.split_start(ad, held, ad.effects["hysteresis"], masks["fit"])
    assert set(start) == {"hysteresis.F_h", "hysteresis.x_h", "coulomb_friction.F_c"}
    assert start["hysteresis.F_h"] + start["coulomb_friction.F_c"] == pytest.approx(f_c)
    assert start["hysteresis.F_h"] / f_c == pytest.approx(min(starts.SPLIT_SHARES, key=lambda s: abs(
        s - start["hysteresis.F_h"] / f_c)))
    x_h = ad.effects["hysteresis"].params[1]
    assert x_h.lower <= start["hysteresis.x_h"] <= x_h.upper
    assert starts.split_start(ad, held, ad.effects["backlash"], masks["fit"]) == {}


def test_a_new_effect_is_also_tried_with_an_accepted_friction_sticking(coulomb_case):
    """An accepted friction that creeps (its switch off, its build-up speed v_t freed) was chosen before the new
    effect was there: beside a gap the new effect is also fitted with the friction sticking, v_t left out of the
    equations (truth case 59050)."""
    ad, masks, held = coulomb_case
    spec = ad.effects["coulomb_friction"]
    v_t = spec.params[spec.keys.index("coulomb_friction.v_t")]
    creeping = fit_model(ad, {}, held.keys + ["coulomb_friction.v_t"], held.specs + [v_t],
                         {**held.theta(), "coulomb_friction.v_t": v_t.typical}, masks, held.effects, 3)
    gap = ad.effects["backlash"]
    width = gap.params[0]
    with_gap = fit_model(ad, {}, creeping.keys + ["backlash.width"], creeping.specs + [width],
                         {**creeping.theta(), "backlash.width": width.typical}, masks,
                         (*creeping.effects, "backlash"), 3)
    variants = starts.shape_variants(ad, creeping, with_gap, gap, masks["fit"])
    assert variants[0][0] is creeping
    flipped = [base for base, _ in variants if "coulomb_friction.sticks" in base.keys]
    assert len(flipped) == 1
    base = flipped[0]
    assert "coulomb_friction.v_t" not in base.keys
    assert set(base.keys) == set(creeping.keys) - {"coulomb_friction.v_t"} | {"coulomb_friction.sticks"}
    assert base.param("coulomb_friction.sticks") == (1.0, 1.0, 1.0)
    assert base.theta()["coulomb_friction.F_c"] == creeping.theta()["coulomb_friction.F_c"]
    # a friction that already sticks is not flipped again
    assert [b for b, _ in starts.shape_variants(ad, base, with_gap, gap, masks["fit"])] == [base]


def test_a_friction_selected_sticking_is_restarted_sticking(coulomb_case):
    """The refined refit restarts each effect beside the others (Identifier._refit_refined): the switch that a
    restarted Stribeck term takes out with it is held by the Coulomb term of the same friction, and no variant of
    the restart turns it off; a switch that no other effect has cannot be held."""
    from vsa_gym.identify.fitting import with_switch_on

    ad, masks, held = coulomb_case
    stribeck = ad.effects["stribeck_friction"]
    stick = next(p for p in stribeck.params if p.switch)
    f_s = stribeck.params[0]
    fm = fit_model(ad, {}, held.keys + ["stribeck_friction.F_s"], held.specs + [f_s],
                   {**held.theta(), "stribeck_friction.F_s": f_s.typical}, masks,
                   (*held.effects, "stribeck_friction"), 3)
    fm = with_switch_on(fm, stribeck, stick)
    base, holds = starts.restart_base(ad, fm, "stribeck_friction")
    assert holds and base.effects == ("coulomb_friction",)
    assert "coulomb_friction.sticks" in base.keys and not any(k.startswith("stribeck") for k in base.keys)
    other, holds = starts.restart_base(ad, fm, "coulomb_friction")
    assert holds and "stribeck_friction.sticks" in other.keys and other.effects == ("stribeck_friction",)
    alone, holds = starts.restart_base(ad, with_switch_on(held, ad.effects["coulomb_friction"],
                                                           stick), "coulomb_friction")
    assert not holds and alone.effects == ()

    # the restart's variants (Identifier._with) keep the friction sticking: the one that lets both terms creep goes
    with_f_s = fit_model(ad, {}, base.keys + ["stribeck_friction.F_s"], base.specs + [f_s],
                         {**base.theta(), "stribeck_friction.F_s": f_s.typical}, masks,
                         (*base.effects, "stribeck_friction"), 2)
    variants = starts.shape_variants(ad, base, with_f_s, stribeck, masks["fit"])
    assert any("coulomb_friction.sticks" not in b.keys for b, _ in variants)
    kept = starts.holding_switches(base, variants)
    assert kept and len(kept) < len(variants) and all("coulomb_friction.sticks" in b.keys for b, _ in kept)
