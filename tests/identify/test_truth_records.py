"""Identification through the CLI on records of the independent truth simulator (tests/truthsim).

The simulator shares no code with the fitted drive model: exact stiction, L/R or current-loop
amplifiers, quantised encoders.  The full case set is ``python -m benchmarks.identify_truth``
(docs/identification.md).  The first two are cases of its *tuning* set (base seed 20250, the set the
selection thresholds were chosen on): CI-sized regression checks that the CLI path names a planted
effect with its magnitude and keeps a nominal record clean.  The others are single cases of later sets
(``seed * 1000 + index``), each the case a selection rule was written on, read before the rule existed:
regression checks of those rules, not evidence of recovery rates, which come from the fresh sets
(docs/identification.md gives the ``--join`` command).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.truthsim.plant import V_L
from tests.truthsim.records import read_truth, run
from tests.truthsim.scenarios import MAIN, draw_case, write_case
from vsa_gym.cli import main
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.pipeline import identify
from vsa_gym.identify.record import load_record

BASE = 20250 * 1000  # the benchmark's default case seeds: base seed * 1000 + index


def _identify(tmp_path, seed: int, effects: tuple[str, ...]) -> tuple[dict, dict]:
    csv = write_case(draw_case(seed, effects), tmp_path)
    out = tmp_path / "out.json"
    assert main(["identify", str(csv), "--json", str(out)]) == 0
    truth = read_truth(csv)
    return json.loads(out.read_text()), truth


def _truth_main(folder) -> dict[str, float]:
    """The main parameters of the one case written into ``folder`` (its truth sidecar)."""
    (csv,) = folder.glob("*.csv")
    return read_truth(csv)["main"]


def _pair_named_within_15_percent(tmp_path, seed: int, effects: tuple[str, str], candidates: tuple[str, ...] | None):
    """Identify case ``seed`` (``effects`` planted) among ``candidates`` (None: the whole library): exactly the
    planted pair is named, each main parameter within 15 %; returns the result."""
    csv = write_case(draw_case(seed, effects), tmp_path)
    truth = read_truth(csv)
    res = identify(str(csv), candidates=candidates)
    named = {e["name"]: e["parameters"] for e in res.effects}
    assert set(named) == set(effects), res.statements()
    for e in effects:
        assert named[e][MAIN[e]] == pytest.approx(truth["main"][e], rel=0.15), e
    return res


def test_planted_coulomb_friction_is_named_alone_within_15_percent(tmp_path):
    res, truth = _identify(tmp_path, BASE + 0, ("coulomb_friction",))
    assert [e["name"] for e in res["effects"]] == ["coulomb_friction"], res["statements"]
    got = res["effects"][0]["parameters"]["F_c"]
    assert got == pytest.approx(truth["main"]["coulomb_friction"], rel=0.15)
    assert res["metrics"]["after"]["q"]["rmse"] < res["metrics"]["before"]["q"]["rmse"]


def test_nominal_truth_record_names_nothing(tmp_path):
    res, _ = _identify(tmp_path, BASE + 60, ())
    assert res["effects"] == [] and res["ambiguous"] == [], res["statements"]
    assert res["replay"]


# Cases of the sets of later base seeds (``seed * 1000 + index``), each read while the rule it tests was written
# (docs/identification.md, "What the independent records taught"): regression checks, not rates.


def test_exponential_stribeck_decay_is_fitted_with_its_shape(tmp_path):
    """Case 7005: a Tustin-like decay (truth exponent 1.16).  With the Gaussian shape held, F_s came out 22 %
    low; the shape exponent is freed because that validates better, and F_s is then within 15 %."""
    res, truth = _identify(tmp_path, 7005, ("stribeck_friction",))
    assert [e["name"] for e in res["effects"]] == ["stribeck_friction"], res["statements"]
    got = res["effects"][0]["parameters"]
    assert got["F_s"] == pytest.approx(truth["main"]["stribeck_friction"], rel=0.15)
    assert got["delta"] < 1.5


def test_dahl_loop_chosen_first_gives_way_to_coulomb_beside_viscous_friction(tmp_path):
    """Case 11049: Coulomb + viscous friction.  Alone, a Dahl loop with the shortest presliding travel fits
    better than the creeping tanh Coulomb law; once the viscous part is accepted, the look-alikes of the first
    effect are refitted beside it and Coulomb friction replaces the loop."""
    res, truth = _identify(tmp_path, 11049, ("coulomb_friction", "viscous_friction"))
    named = {e["name"]: e["parameters"] for e in res["effects"]}
    assert set(named) == {"coulomb_friction", "viscous_friction"}, res["statements"]
    assert named["coulomb_friction"]["F_c"] == pytest.approx(truth["main"]["coulomb_friction"], rel=0.15)
    assert named["viscous_friction"]["b"] == pytest.approx(truth["main"]["viscous_friction"], rel=0.15)


def test_lightly_damped_shaft_is_named_compliance_with_its_damping(tmp_path):
    """Case 11016: a 12.9 Hz shaft mode damped at zeta = 0.025, rung by steps.  With the damping held at 0.05
    the compliance barely beat the nominal model and a backlash was named; freed, the damping ratio comes out
    near the truth and the compliance within 15 %."""
    res, truth = _identify(tmp_path, 11016, ("transmission_compliance",))
    assert [e["name"] for e in res["effects"]] == ["transmission_compliance"], res["statements"]
    got = res["effects"][0]["parameters"]
    assert got["compliance"] == pytest.approx(truth["main"]["transmission_compliance"], rel=0.15)
    planted, ph = truth["planted"]["transmission_compliance"], truth["physics"]
    m_r = ph["m_l"] * ph["m_m"] / (ph["m_l"] + ph["m_m"])
    zeta = planted["c_s"] / (2 * np.sqrt(planted["k_s"] * m_r))
    assert got["zeta"] == pytest.approx(zeta, rel=0.15)


def test_closed_loop_sensor_offset_is_judged_on_the_start_transient(tmp_path):
    """Case seed 5000 drawn with a sensor offset (``--seed 5 --only sensor_offset``; read while the rule was
    written): a PD loop on an offset
    linear scale tracks its reference either way, so only the transient from the declared start position, in
    the fit part, shows the offset.  The validation part cannot tell the two models apart; the offset is judged
    on the fit part (``judged_on``) and named within 15 %.  Without the declared start position the record holds
    no evidence of an offset at all, and nothing is named."""
    res, truth = _identify(tmp_path, 5000, ("sensor_offset",))
    assert [e["name"] for e in res["effects"]] == ["sensor_offset"], res["statements"]
    assert res["effects"][0]["parameters"]["offset"] == pytest.approx(truth["main"]["sensor_offset"], rel=0.15)
    accepted = [c for c in res["candidates"] if c["name"] == "sensor_offset" and c["accepted"]]
    assert accepted and accepted[0]["judged_on"] == "fit"

    side = next(p for p in tmp_path.glob("truthsim_*.json") if not p.name.endswith(".truth.json"))  # the sidecar
    meta = json.loads(side.read_text())
    del meta["initial_state"]["position"]  # the start is then read from the (offset) sensor itself
    side.write_text(json.dumps(meta))
    out = tmp_path / "blind.json"
    assert main(["identify", str(side.with_suffix(".csv")), "--json", str(out)]) == 0
    blind = json.loads(out.read_text())
    assert blind["effects"] == [] and blind["ambiguous"] == [], blind["statements"]


def test_backlash_start_in_the_gap_is_fitted_not_named_a_sensor_offset(tmp_path):
    """Case 13012 (the seed-13 set's first backlash draw, read while the rule was written): the truth's motor
    starts 0.68 of the half gap off centre, so an open-loop replay that starts it in the middle leaves the load
    shifted for the whole record, and a sensor offset was named beside the backlash.  The start in the gap is
    fitted with the gap: the backlash is named alone, its width within 15 % and its start near the truth's."""
    res, truth = _identify(tmp_path, 13012, ("backlash",))
    assert [e["name"] for e in res["effects"]] == ["backlash"], res["statements"]
    got = res["effects"][0]["parameters"]
    assert got["width"] == pytest.approx(truth["main"]["backlash"], rel=0.15)
    case = draw_case(13012, ("backlash",))
    assert got["start"] == pytest.approx(case.gap0 / (0.5 * truth["main"]["backlash"]), abs=0.15)


def test_runner_up_branch_names_mesh_loss_and_viscous_friction_a_sensor_gain_stood_in_for(tmp_path):
    """Case 5052 of the seed-5 set (read while the rule was written): a closed-loop ball screw with a mesh loss
    and a viscous friction.  A sensor gain of about -23 % validated a few per cent better than the viscous friction
    alone and no second effect removed what it left; the branch from round one's runner-up names both planted
    effects, within 15 %, and replaces the gain.  The candidates are limited to the three that matter (the full
    catalogue takes minutes on this 5 kHz record and chose the same way)."""
    res = _pair_named_within_15_percent(tmp_path, 5052, ("gearbox_efficiency", "viscous_friction"),
                                        ("sensor_gain", "viscous_friction", "gearbox_efficiency"))
    gain = [c for c in res.candidates if c.name == "sensor_gain" and c.round == 1]
    assert gain and not gain[0].accepted and "runner-up viscous_friction" in gain[0].reason


def test_a_second_friction_term_is_also_fitted_with_the_first_creeping(tmp_path):
    """Case 7054 (Stribeck + Coulomb friction, closed-loop sines): Coulomb friction went in first sticking (then a
    bristle of 1.5 um); the Stribeck excess was then fitted only beside a stuck friction (validation 7.4e-5), and a
    Dahl loop replaced the Coulomb level (3.5e-5) where the true creeping pair replays at 3.5e-5.  Sticking is one
    switch of the friction, so the pair is also tried with both terms creeping: both are named, no loop."""
    res, truth = _identify(tmp_path, 7054, ("stribeck_friction", "coulomb_friction"))
    assert sorted(e["name"] for e in res["effects"]) == ["coulomb_friction", "stribeck_friction"], res["statements"]
    got = {e["name"]: e["parameters"] for e in res["effects"]}
    assert got["coulomb_friction"]["F_c"] == pytest.approx(truth["main"]["coulomb_friction"], rel=0.15)
    assert got["stribeck_friction"]["F_s"] == pytest.approx(truth["main"]["stribeck_friction"], rel=0.15)
    # one friction law, one switch: at most one of its terms carries it (the truth sticks; with exact sticking a
    # stuck pair and a creeping one replay alike here, 3.46e-5 and 3.47e-5)
    assert got["coulomb_friction"]["sticks"] + got["stribeck_friction"]["sticks"] <= 1.0


def test_dahl_loop_started_on_a_grid_of_travels_is_named_not_coulomb_friction(tmp_path):
    """Case 11024 (hysteresis, closed-loop sines replayed open loop): from one typical presliding travel the loop
    slid to the shortest travel at twice the force and Coulomb friction was named; the travel is now searched
    with the force for the start, and the loop is named with both within 15 %."""
    res, truth = _identify(tmp_path, 11024, ("hysteresis",))
    assert [e["name"] for e in res["effects"]] == ["hysteresis"], res["statements"]
    got = res["effects"][0]["parameters"]
    x_h = truth["planted"]["hysteresis"]["F_h"] / truth["planted"]["hysteresis"]["sigma"]
    assert got["F_h"] == pytest.approx(truth["main"]["hysteresis"], rel=0.15)
    assert got["x_h"] == pytest.approx(x_h, rel=0.15)


def test_backlash_beside_coulomb_friction_is_named_when_it_removes_most_of_what_is_left(tmp_path):
    """Case 7050 (a gear motor's backlash and Coulomb friction, open-loop steps at 200 Hz): beside the friction
    the gap removes most of the validation misfit above the noise floor, as a further effect must
    (``min_share_next`` 0.5), and both are named within 15 %.  (When that rule was set the gap removed 65 %, and at
    0.7 it was rejected and the friction named alone, 14 % off; since the drive lag's wider substep reach,
    :func:`vsa_gym.devices.drive.model.row_substeps`, it removes 96 %.)  The candidates are the friction and the
    transmission's look-alikes."""
    res = _pair_named_within_15_percent(tmp_path, 7050, ("backlash", "coulomb_friction"),
                                        ("coulomb_friction", "backlash", "transmission_compliance"))
    gap = next(c for c in res.candidates if c.name == "backlash" and c.accepted)
    assert gap.share >= 0.5


def test_backlash_beside_friction_that_sticks_keeps_its_width(tmp_path):
    """Case 37018 (a 48 um backlash behind a 63 Hz shaft, 12.3 N of Coulomb friction, closed-loop sines at 2 kHz,
    motor encoder): with sticking approximated by a sub-count bristle, its give-way lag at every reversal left
    errors of several counts, and a gap 35 % wide absorbed them.  Friction that sticks exactly (stick-slip
    events) leaves the true gap, with the shaft as its contact, near the noise floor: both within 15 %."""
    _pair_named_within_15_percent(tmp_path, 37018, ("backlash", "coulomb_friction"),
                                  ("coulomb_friction", "backlash", "transmission_compliance"))


def test_a_gap_fitted_short_on_a_replay_that_is_not_converged_is_restarted_at_finer_substeps(tmp_path):
    """Case 157018 (a fresh pairs set; a 0.31 mrad backlash beside sticking Coulomb friction, open-loop gear motor
    at 500 Hz): at the drive's own five substeps the fitted replay leans on its integration error and the gap came
    out 22 % short.  Doubling the substeps moves the replay beyond the tolerance, so the model is refitted there:
    from its values it gains nothing (fit NRMSE 5.70e-4 to 5.61e-4, the gap still short); the gap restarted from
    its own starts fits 6.5x better and is within 3 % (:func:`vsa_gym.identify.convergence.refined`)."""
    res = _pair_named_within_15_percent(tmp_path, 157018, ("backlash", "coulomb_friction"),
                                        ("coulomb_friction", "backlash", "transmission_compliance"))
    assert "refitted at 2x" in res.replay_mode, res.replay_mode
    width = next(e for e in res.effects if e["name"] == "backlash")["parameters"]["width"]
    assert width == pytest.approx(_truth_main(tmp_path)["backlash"], rel=0.03)  # 0.308 mrad


def test_a_friction_chosen_creeping_on_a_coarse_replay_sticks_once_refitted_at_finer_substeps(tmp_path):
    """Case 139006 (a fresh pairs set; Stribeck beside Coulomb friction, open-loop gear motor, steps at 500 Hz):
    at the drive's own substeps the selection keeps both frictions creeping; doubling the substeps moves the
    replay beyond the tolerance.  Refitted there from its values the creeping law gains 2.7x on the fit part
    but leaves F_s 6 % high; restarted from its own starts the Stribeck friction sticks, fits 23x better still,
    and F_s is within 3 %."""
    res = _pair_named_within_15_percent(tmp_path, 139006, ("stribeck_friction", "coulomb_friction"), None)
    assert "refitted at 2x" in res.replay_mode, res.replay_mode
    named = {e["name"]: e["parameters"] for e in res.effects}
    assert max(named[e].get("sticks", 0.0) for e in named) == 1.0
    assert named["stribeck_friction"]["F_s"] == pytest.approx(_truth_main(tmp_path)["stribeck_friction"], rel=0.03)


def test_inertia_error_and_coulomb_friction_on_a_direct_drive_are_not_a_mesh_loss(tmp_path):
    """Case 13051 of the fresh seed-13 set (a linear motor, closed-loop multisine at 1 kHz, with the moving mass
    34 % heavier than its sidecar says and Coulomb friction): with the transmission's effects as candidates, a
    61 % mesh loss was named alone on such records (7051, 13051).  The truth simulator's sidecar says the drive
    is direct (``model.transmission``), so the mesh loss is no candidate even where asked for, and both planted
    effects are named within 15 %.  The candidates are limited to the four that matter."""
    res = _pair_named_within_15_percent(tmp_path, 13051, ("inertia_error", "coulomb_friction"),
                                        ("gearbox_efficiency", "sensor_gain", "inertia_error", "coulomb_friction"))
    assert not any(c.name == "gearbox_efficiency" for c in res.candidates)


def test_dahl_loop_and_coulomb_friction_are_split_not_named_one_loop(tmp_path):
    """Case 7053 of the seed-7 set (a ball screw, open-loop chirp at 500 Hz; Dahl loop of 10.3 N with 1.1 mm of
    presliding travel, Coulomb friction of 14.7 N): the loop fitted first carried their sum (24.2 N, 0.19 mm),
    and Coulomb friction started beside it stayed at zero (one loop named, 135 % off).  Started with a share of
    the loop's force and the loop's travel searched again, both are named within 15 %."""
    _pair_named_within_15_percent(tmp_path, 7053, ("hysteresis", "coulomb_friction"),
                                  ("hysteresis", "coulomb_friction", "gearbox_efficiency"))


def test_a_force_beside_an_accepted_one_is_fitted_however_low_it_ranks(tmp_path):
    """Case 13053 of the seed-13 set (a gear motor, open-loop steps at 200 Hz, Dahl loop and Coulomb friction of
    about the same force), with every candidate: beside a loop carrying both forces, Coulomb friction's signature
    ranked too low to be fitted and one loop was named (103 % off).  A force of the kind already accepted is
    always fitted in the next round; both are named within 15 %."""
    res, truth = _identify(tmp_path, 13053, ("hysteresis", "coulomb_friction"))
    named = {e["name"]: e["parameters"] for e in res["effects"]}
    assert set(named) == {"hysteresis", "coulomb_friction"}, res["statements"]
    for e in named:
        assert named[e][MAIN[e]] == pytest.approx(truth["main"][e], rel=0.15), e


def test_coulomb_friction_standing_in_for_viscous_friction_is_swapped_beside_a_mesh_loss(tmp_path):
    """Case 17052 of the seed-17 set (a gear motor, closed loop at 2 kHz; mesh loss 0.21, viscous friction
    0.23 N m s/rad): a Coulomb friction whose build-up speed v_t was freed to 0.59 rad/s (linear in the speed
    below it) validated best in round one, and beside it the mesh loss came out 52 % low.  As look-alikes, the
    swap step revisits the Coulomb friction beside the mesh loss and viscous friction replaces it."""
    _pair_named_within_15_percent(tmp_path, 17052, ("gearbox_efficiency", "viscous_friction"),
                                  ("coulomb_friction", "viscous_friction", "gearbox_efficiency"))


def test_record_scales_are_the_measured_ones_where_the_nominal_replay_runs_away(tmp_path):
    """A vertical axis replayed open loop without its weight falls away: bounds and typical sizes scaled on that
    replay would describe the fall (case 29008 of ``--seed 29 --draws 0 --pairs 24``: a Stribeck curve of
    v_s = 4.9 m/s, 8x the record's peak speed and flat over it, passed for its Coulomb friction).  The adapter takes
    the measured position's spread and peak speed instead; the peak speed is checked against the truth simulator's
    own."""
    case = draw_case(29008, ("coulomb_friction", "force_offset"))
    ad = make_adapter(load_record(write_case(case, tmp_path)))
    x = ad.measured[:, ad.loop_output]
    replay = ad.simulate({}, 1)[:, 0, ad.loop_output]
    assert np.std(replay) > 30 * np.std(x)  # the nominal replay runs away
    assert ad.x_ref == pytest.approx(float(np.std(x)), rel=1e-12)
    v_true = float(np.max(np.abs(run(case).x[:, V_L])))
    assert 0.7 < ad.v_ref / v_true < 1.3
    v_s = next(p for p in ad.effects["stribeck_friction"].params if p.name == "v_s")
    assert v_s.upper < v_true


def test_backlash_of_a_voltage_drive_is_fitted_with_the_damping_on_the_motor(tmp_path):
    """Case 29002 of ``--seed 29 --draws 0 --pairs 24`` (a voltage-driven ball screw whose sidecar does not split
    b; backlash and Coulomb friction, open-loop steps at 5 kHz, encoder at the load).  The rigid nominal fit
    leaves the back-EMF share of b at 0, which a rigid drive hardly feels; with the gap in, it decides whether b
    damps the motor crossing the gap or the load.  Fitted only from there, the true gap validated no better
    than Coulomb friction alone and the gap was not named.  The gap is also fitted from share 1
    (``DriveAdapter.restarts``): both effects are named within 15 %, with most of b on the motor."""
    res = _pair_named_within_15_percent(tmp_path, 29002, ("backlash", "coulomb_friction"),
                                        ("coulomb_friction", "backlash", "transmission_compliance"))
    assert res.final.theta()["base.emf_share"] > 0.5
    ad = make_adapter(load_record(next(tmp_path.glob("*.csv"))))  # the record the helper wrote
    assert ad.restarts("backlash", {"base.emf_share": 0.0}) == {"base.emf_share": 1.0}
    assert ad.restarts("coulomb_friction", {"base.emf_share": 0.0}) == {}


def test_mesh_loss_of_a_voltage_drive_is_fitted_with_the_damping_in_front_of_the_mesh(tmp_path):
    """Case 107020 of ``--seed 107 --draws 0 --pairs 24`` (a fresh miss, read before the change): a voltage-driven
    gear motor whose sidecar does not split b, 99.6 % of it back-EMF; a mesh loss of 0.226 and a viscous load
    friction, open-loop steps.  The nominal fit leaves the back-EMF share at 0, so b acted behind the mesh, and
    the loss fitted from there stopped at 0.197 with a back-driven loss of 0.70 (truth 0.27) and no viscous
    friction.  A lossy mesh passes a motor-side damping scaled by its efficiency: the loss is also fitted from
    share 1 (``DriveAdapter.restarts``), and both effects are named within 15 %, with b on the motor."""
    res = _pair_named_within_15_percent(tmp_path, 107020, ("gearbox_efficiency", "viscous_friction"),
                                        ("gearbox_efficiency", "viscous_friction", "coulomb_friction"))
    theta = res.final.theta()
    assert theta["base.emf_share"] > 0.9
    truth = read_truth(next(tmp_path.glob("*.csv")))
    assert theta["gearbox_efficiency.loss_back"] == pytest.approx(1 - truth["planted"]["gearbox_efficiency"]["eta_b"],
                                                                  rel=0.15)
    ad = make_adapter(load_record(next(tmp_path.glob("*.csv"))))
    assert ad.restarts("gearbox_efficiency", {"base.emf_share": 0.0}) == {"base.emf_share": 1.0}
    assert ad.restarts("gearbox_efficiency", {"base.emf_share": 0.6}) == {}


def test_look_alikes_ambiguous_alone_are_separated_once_a_later_effect_is_in(tmp_path):
    """Case 61003 of the seed-61 set (a linear motor, open-loop steps at 2 kHz; the moving mass 19 % lighter than
    its sidecar says, 1.55 N of Coulomb friction): in round one a Dahl loop and Coulomb friction validate alike
    (0.1514 vs 0.1524) and were reported ambiguous.  Beside the inertia error the swap replaces the loop by the
    friction at 6.6e-05 against 0.090: the record has told them apart, so the ambiguity is dropped and both
    planted effects are named within 15 % (before, only the inertia error was asserted)."""
    res = _pair_named_within_15_percent(tmp_path, 61003, ("inertia_error", "coulomb_friction"),
                                        ("inertia_error", "coulomb_friction", "hysteresis"))
    assert not res.ambiguous
    swap = next(c for c in res.candidates if c.reason.startswith("replaces hysteresis"))
    assert "separates hysteresis and coulomb_friction" in swap.reason


def test_viscous_friction_is_also_fitted_with_the_accepted_friction_sticking(tmp_path):
    """Case 43017 of the seed-43 pairs set (a linear motor, closed-loop moves at 2 kHz, load encoder; 2.47 N of
    Coulomb friction and 29 N s/m of viscous friction): alone, the friction that creeps (v_t freed) validated
    best, and beside it the viscous friction removed 45 % of what was left (needs 50 %); the Coulomb friction was
    named alone, 41 % off.  An effect without shapes is now also fitted with the accepted friction sticking
    (:func:`vsa_gym.identify.starts.switch_flips`), and both are named within 15 %, the friction sticking."""
    res = _pair_named_within_15_percent(tmp_path, 43017, ("coulomb_friction", "viscous_friction"),
                                        ("coulomb_friction", "viscous_friction", "hysteresis"))
    assert res.final.theta()["coulomb_friction.sticks"] == 1.0


def test_sensor_gain_chosen_first_is_swapped_for_the_mesh_loss_beside_viscous_friction(tmp_path):
    """Case 67052 of the seed-67 set (a ball screw, open-loop chirp at 500 Hz, motor encoder; a mesh loss of 0.245
    and 178 N s/m of viscous friction): a sensor gain of -4 % validated best in round one (0.168; the loss alone
    0.165 but its CI included absent) and the viscous friction beside it was named, the loss never.  A sensor gain
    is now a look-alike of a mesh loss and of viscous friction (it scales a replay as a drive-side loss does), so
    the swap after round two tries the loss in its place: 0.0029 against 0.054, both named within 15 %."""
    res = _pair_named_within_15_percent(tmp_path, 67052, ("gearbox_efficiency", "viscous_friction"),
                                        ("sensor_gain", "viscous_friction", "gearbox_efficiency"))
    swap = next(c for c in res.candidates if c.reason.startswith("replaces sensor_gain"))
    assert swap.name == "gearbox_efficiency" and swap.accepted


def test_inertia_error_chosen_first_is_swapped_for_the_transmission_compliance(tmp_path):
    """Case 79007 of the seed-79 pairs set (a gear motor in closed loop, sines at 1 kHz, motor encoder; a shaft
    mode at 10.5 Hz and a 3.9 ms sensor delay): the inertia error validated best in round one (0.0262 against the
    compliance's 0.0280) and the delay was named beside it, 23 % short.  Above its mode a compliant shaft leaves
    the motor its own inertia, so a compliance is now a look-alike of an inertia error, and the swap after round
    two puts it in place of the inertia error: 1.1e-4 against 0.0073, both named within 0.1 %."""
    res = _pair_named_within_15_percent(tmp_path, 79007, ("transmission_compliance", "sensor_delay"),
                                        ("inertia_error", "transmission_compliance", "sensor_delay", "sensor_gain"))
    swap = next(c for c in res.candidates if c.reason.startswith("replaces inertia_error"))
    assert swap.name == "transmission_compliance" and swap.accepted


def test_a_look_alike_within_the_nominal_tolerance_makes_nothing_ambiguous(tmp_path):
    """Case 61007 of the seed-61 pairs set (a gear motor in closed loop, sines at 500 Hz; a shaft compliance and a
    6.3 ms sensor delay): beside the delay, an inertia error of under 5 % (within the nominal model's tolerance, so
    not named) validated better than the compliance, and once the two were look-alikes the compliance was
    reported ambiguous with it and not asserted.  A look-alike too small to name is no rival: both planted effects
    are named within 15 %, nothing is ambiguous."""
    res = _pair_named_within_15_percent(tmp_path, 61007, ("transmission_compliance", "sensor_delay"),
                                        ("sensor_delay", "transmission_compliance", "inertia_error"))
    assert not res.ambiguous


def test_an_effect_that_passed_alone_is_fitted_first_beside_the_accepted_one(tmp_path):
    """Case 71023 of the seed-71 pairs set (a gear motor, open-loop chirp at 500 Hz, load encoder, voltage drive; a
    shaft mode at 24.7 Hz and a 3.7 ms sensor delay): a backlash validated best in round one (0.0071; the delay
    alone 0.026 passed too), and beside it the delay ranked too low to be fitted, so the backlash was named alone.
    What passed alone in round one is now fitted in round two whatever its rank, and each round-two candidate is
    also fitted the other way round (alone first, the accepted effect added to it): the delay then validates at
    7.8e-4 (the noise floor 7.2e-4), and the swap puts the compliance in place of the backlash beside it, both
    within 1 %."""
    res = _pair_named_within_15_percent(tmp_path, 71023, ("transmission_compliance", "sensor_delay"), None)
    # which shaft effect round one accepts depends on the fit's last bits (an Intel Xeon: the backlash, which the swap
    # then replaces; an AMD EPYC: the compliance itself); either way the compliance ends beside the delay
    swaps = [c for c in res.candidates if c.reason.startswith("replaces backlash")]
    if swaps:
        assert swaps[0].name == "transmission_compliance" and swaps[0].accepted
    else:
        assert any(c.round == 1 and c.name == "transmission_compliance" and c.accepted for c in res.candidates)


def test_a_newcomer_that_only_moved_the_earlier_effect_is_not_named(tmp_path):
    """Case 59013 of the seed-59 set (a gear motor in closed loop, sines at 200 Hz, motor encoder; a 2.16 mrad
    backlash): alone, the backlash fit stopped 58 % narrow.  Fitted after a mesh loss (the reordered round two),
    it reached its width, and the loss beside it passed every rule.  Refitted from that joint fit without the
    loss, the backlash fits as well, so the loss is not named and the backlash keeps its new width (within 15 %)."""
    res, truth = _identify(tmp_path, 59013, ("backlash",))
    assert [e["name"] for e in res["effects"]] == ["backlash"], res["statements"]
    assert res["effects"][0]["parameters"]["width"] == pytest.approx(truth["main"]["backlash"], rel=0.15)
    assert any("not needed: refitted from this joint fit" in c["reason"] for c in res["candidates"])


def test_two_forces_that_pass_only_together_are_named_together(tmp_path):
    """Case 61016 of the seed-61 pairs set (a vertical ball screw in closed loop, moves at 200 Hz, motor encoder,
    voltage drive; 208 N of gravity and 102 N of Coulomb friction): alone, the load force fits the fit part
    better than the nominal model but validates worse, and the friction alone cannot hold the load, so nothing
    passed round one and nothing was named.  Where nothing passes alone, the candidate that fits the fit part
    best is now fitted together with the others: the two forces pass as a pair, each within 15 %."""
    res = _pair_named_within_15_percent(tmp_path, 61016, ("coulomb_friction", "force_offset"), None)
    assert any(c.accepted and c.reason.startswith("passes only together with") for c in res.candidates)


def test_runner_up_within_twice_the_winners_error_gets_its_branch(tmp_path):
    """Case 43012 of the seed-43 pairs set (a ball screw in closed loop, sines at 1 kHz, load encoder; a 10.6 %
    mesh loss and a viscous friction): Coulomb friction validated best in round one (3.6e-4), the viscous
    friction 1.55x that, beyond the runner-up's old reach of 1.25x, and beside the Coulomb friction no second
    effect removed half of what was left, so Coulomb friction was named alone.  A runner-up within twice the
    winner's error now gets its branch: viscous friction, then the mesh loss, validating at 2.5e-6."""
    res = _pair_named_within_15_percent(tmp_path, 43012, ("gearbox_efficiency", "viscous_friction"), None)
    assert any(c.accepted and c.reason.startswith("round one's runner-up, adopted") for c in res.candidates)


def test_an_effect_round_one_did_not_fit_is_found_and_named_alone(tmp_path):
    """Case 97021 of the seed-97 set (a ball screw, voltage drive, open-loop steps at 1 kHz, motor encoder; an
    11.5 % mesh loss): the mesh loss ranked below the five candidates round one fits, and none of those passed.
    It was first found by the pair look-ahead (d955ab0: fitted beside the load force, which it did not need, then
    refitted alone); since the ninth session round one fits the low-ranked candidates where nothing passes on a
    misfit well above the noise floor, and the mesh loss passes there, alone, within 15 %."""
    res, truth = _identify(tmp_path, 97021, ("gearbox_efficiency",))
    assert [e["name"] for e in res["effects"]] == ["gearbox_efficiency"], res["statements"]
    assert res["effects"][0]["parameters"]["loss"] == pytest.approx(truth["main"]["gearbox_efficiency"], rel=0.15)
    assert any(c["accepted"] and c["reason"].startswith("fitted though ranked low") for c in res["candidates"])


def test_a_gap_that_replays_the_record_to_its_noise_is_named_though_its_start_sits_at_the_bound(tmp_path):
    """Case 97012 of the seed-97 set (a gear motor in closed loop, sines at 500 Hz, motor encoder; a 0.87 mrad
    backlash whose motor starts 0.98 of the half gap from the middle): the backlash fit replays the record below
    its noise floor, the width 1 % off, but its start sat at the end of its range (0.95), and a start at the bound
    was always read as a gap standing in for something else, so the compliance, 84x worse, was named.  A shape
    or start at a bound is now accepted where the fit is within 3x the noise floor and 3x better than the model
    before and every passing candidate."""
    res, truth = _identify(tmp_path, 97012, ("backlash",))
    assert [e["name"] for e in res["effects"]] == ["backlash"], res["statements"]
    assert res["effects"][0]["parameters"]["width"] == pytest.approx(truth["main"]["backlash"], rel=0.15)
    assert any(c["accepted"] and "backlash.start at a bound" in c["reason"] for c in res["candidates"])


def test_a_stand_in_gap_at_its_bound_is_still_refused_where_it_is_not_far_better_than_the_rest(tmp_path):
    """Case 47016 of the seed-47 set (a shaft's compliance): a backlash fit with a shape at its bound replays the
    record as well as the compliance, near the noise floor; it is not 3x better than the compliance, so the bound
    still refuses it and the compliance is named."""
    res, truth = _identify(tmp_path, 47016, ("transmission_compliance",))
    assert [e["name"] for e in res["effects"]] == ["transmission_compliance"], res["statements"]
    refused = [c for c in res["candidates"] if c["name"] == "backlash" and c["round"] == 1]
    assert refused and not refused[0]["accepted"] and refused[0]["reason"] == "parameter at a bound"


def test_beside_an_accepted_effect_a_gap_at_its_start_bound_is_named_far_ahead_of_the_rest(tmp_path):
    """Case 197010 of the seed-197 pairs set (a gear motor in open loop, steps at 500 Hz, motor encoder; an 11 mrad
    backlash beside Coulomb friction): beside the Coulomb friction the gap's fit replays the record 7.6x better
    than the friction alone, its width 2.5 % off, but its start sits at the bound (the motor against a tooth at the
    first sample) and the fit is 59x the noise floor, beyond the 3x the bound relief asked for, so nothing but the
    friction was named.  Beside an accepted effect the relief no longer asks for the floor; it still asks for a fit
    3x better than the model before and every passing candidate (47016 above: a stand-in in round one)."""
    res = _pair_named_within_15_percent(tmp_path, 197010, ("backlash", "coulomb_friction"), None)
    relieved = [c for c in res.candidates if c.name == "backlash" and c.accepted]
    assert relieved and "backlash.start at a bound: beside coulomb_friction" in relieved[0].reason


def test_a_gap_ranked_too_low_to_fit_is_fitted_where_nothing_else_passed(tmp_path):
    """Case 103015 of the seed-103 set (a gear motor in closed loop, sines at 1 kHz, motor encoder; a 1.5 mrad
    backlash): the gap's secant signature ranked it below the six candidates round one fits, none of which passed,
    and nothing was named on a nominal misfit 440x the noise floor.  Where nothing passes on a misfit well above
    the floor, the candidates ranked too low are now fitted too: the gap passes alone, within 15 %."""
    res, truth = _identify(tmp_path, 103015, ("backlash",))
    assert [e["name"] for e in res["effects"]] == ["backlash"], res["statements"]
    assert res["effects"][0]["parameters"]["width"] == pytest.approx(truth["main"]["backlash"], rel=0.15)
    assert any(c["accepted"] and c["reason"].startswith("fitted though ranked low") for c in res["candidates"])


def test_a_refused_newcomer_that_moved_the_accepted_effect_to_a_better_optimum_leaves_it_there(tmp_path):
    """Case 127006 of the seed-127 set (a gear motor in closed loop, sines at 1 kHz, motor encoder; a
    near-exponential Stribeck decay, delta 1.21, that sticks): alone, the Stribeck fit stopped with F_s 34 % high
    at a third of the decay speed (validation 0.019, noise floor 0.00024).  Beside it a Coulomb friction was pressed
    to zero and refused, but that joint fit had moved the Stribeck friction to the truth's optimum; refitted from
    there without the Coulomb friction it validates as well, so it keeps those values (within 15 %).  Among two
    candidates, to keep the test short (the whole library names the same, 63 s)."""
    csv = write_case(draw_case(127006, ("stribeck_friction",)), tmp_path)
    truth = read_truth(csv)
    res = identify(str(csv), candidates=("stribeck_friction", "coulomb_friction"))
    assert [e["name"] for e in res.effects] == ["stribeck_friction"], res.statements()
    assert res.effects[0]["parameters"]["F_s"] == pytest.approx(truth["main"]["stribeck_friction"], rel=0.15)
    polished = [c for c in res.candidates if c.round == 2 and c.name == "coulomb_friction"]
    assert polished and not polished[0].accepted and "not needed: refitted from this joint fit" in polished[0].reason


def test_a_soft_shaft_on_a_rotor_light_drive_is_within_the_fitted_range(tmp_path):
    """Case 151023 (a fresh pairs set, read before the change): a 4.6 Hz shaft beside a 3.6 ms sensor delay on a
    gear motor whose rotor carries 19 % of the inertia.  The compliance range ended at a 4 Hz mode on ``m / 4``,
    stiffer than this shaft on the model's own reduced mass, so the fit stopped at the bound and nothing was
    named; the range now ends at 4 Hz on ``frac_m (1 - frac_m) m`` (and is unchanged at frac_m = 0.5)."""
    csv = write_case(draw_case(151023, ("transmission_compliance", "sensor_delay")), tmp_path)
    ad = make_adapter(load_record(csv))
    spec = ad.effects["transmission_compliance"].params[0]
    p = ad.params
    m_r = p.frac_m * (1 - p.frac_m) * p.m
    assert p.frac_m == pytest.approx(0.19, abs=0.01)
    assert spec.upper == pytest.approx(1 / ((2 * np.pi * 4.0) ** 2 * m_r), rel=1e-12)
    assert spec.upper > 1 / ((2 * np.pi * 4.0) ** 2 * p.m / 4) * 1.5  # beyond the old bound
    _pair_named_within_15_percent(tmp_path, 151023, ("transmission_compliance", "sensor_delay"), None)
