"""eLPAS rig force tests (closed loop, the paper's cascade) hiding one effect: the right cause, its parameter.

Each case fits on one of the paper's force tests -- a sine or a step test -- and scores on the other
kind of test of the same device (held out; :func:`vsa_gym.identify.recovery.identify_case`).  The
truth feeds the controller the quantised encoders, the replay does not (a small, realistic model
error); force sensor noise 5 N.  Tolerance on the recovered parameter: 10 % relative.  Recovery
rates over many seeds: ``python -m benchmarks.identify_recovery_devices --device elpas``.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.identify.recovery import assert_planted_effect_recovered
from vsa_gym.devices.elpas.adapter import ElpasAdapter
from vsa_gym.devices.elpas.synthetic import make_elpas_record
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.recovery import identify_case, main_key

REL_TOL = 0.10


@pytest.mark.parametrize(("fit_on", "effect", "seed"), [
    ("sine", "coulomb_friction", 1),  # the paper's "underestimated friction power"
    ("sine", "spring_stiffness_drift", 2),  # the paper's drifting spring
    ("sine", "viscous_friction", 1),  # underestimated friction power, the speed-proportional part
    ("step", "alpha_offset", 1),  # the paper's nonzero disturbance moment at alpha = 0 (alignment error)
])
def test_planted_effect_is_named_and_recovered(fit_on, effect, seed):
    res, truth = identify_case("elpas", fit_on, effect, seed)
    # held out: the other kind of force test of the same device, scored on the force sensor
    assert res.test_name.startswith("test record")
    assert_planted_effect_recovered(res, truth, effect, main_key("elpas", effect), REL_TOL, 0.7, outputs=["F"])


@pytest.mark.parametrize(("fit_on", "seed"), [("sine", 0), ("sine", 1), ("sine", 2), ("step", 3)])
def test_negative_control_reports_none(fit_on, seed):
    res, _ = identify_case("elpas", fit_on, None, 200 + seed)
    assert res.effects == [], res.statements()
    assert res.statements()[0].startswith("No significant effect")


def test_replay_is_the_rig_closed_loop_of_the_baselines():
    """With the encoders quantised, the replay equals baselines.elpas_rig.run_rig (the env's loop)."""
    from baselines.elpas_cascade import ElpasCascade
    from baselines.elpas_rig import run_rig

    rec, _ = make_elpas_record(5, None, "step", duration=0.5)
    ad = make_adapter(rec)
    assert isinstance(ad, ElpasAdapter)
    ad.quantised_feedback = True
    gam, F = ad.simulate_states({}, 1)
    out = run_rig(ElpasCascade(), rec.input("force_reference")[None, :], rec.input("alpha")[None, :],
                  gamma0=ad.gamma0)
    # run_rig column k is the state after step k + 1
    np.testing.assert_allclose(out["gamma"][0], gam[1:, 0], atol=1e-5)
    np.testing.assert_allclose(out["F_act"][0], F[1:, 0], atol=0.05)
    assert np.ptp(F) > 500.0  # the steps did move the actuator


def test_spring_drift_acts_only_off_alpha_zero():
    """The cone spring keeps its length at alpha = 0: C_a is visible only through alpha motion."""
    rec, _ = make_elpas_record(6, None, "sine", duration=0.5)
    ad = ElpasAdapter(rec)
    gam, F = ad.simulate_states({"spring_stiffness_drift.drift": np.array([0.0, 0.1])}, 2)
    moving = np.abs(ad.alpha) > 0.02
    assert np.max(np.abs(F[moving, 1] - F[moving, 0])) > 10.0
    still = np.abs(ad.alpha) < 1e-6
    assert np.max(np.abs(F[still, 1] - F[still, 0])) < 1.0


def test_replay_runs_the_arm_hysteresis_column():
    """``hysteresis.M_h`` / ``phi_h`` in a replay's theta switch on the compiled core's arm hysteresis column for
    the rows that have it; rows with ``M_h = 0`` replay exactly as the nominal model."""
    rec, _ = make_elpas_record(5, None, "sine", duration=0.3)
    ad = make_adapter(rec)
    nominal = ad.simulate({}, 2)
    theta = {"hysteresis.M_h": np.array([0.0, 40.0]), "hysteresis.phi_h": np.array([0.01, 0.002])}
    y = ad.simulate(theta, 2)
    np.testing.assert_array_equal(y[:, 0], nominal[:, 0])
    assert np.max(np.abs(y[:, 1] - nominal[:, 1])) > 1.0  # N: the moment on the arm moves the force
    p = ad.identified_params({"hysteresis.M_h": 40.0, "hysteresis.phi_h": 0.002})
    assert float(p.effects.M_h) == 40.0 and float(p.effects.phi_h) == 0.002
