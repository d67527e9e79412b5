"""eLPAS rig force tests (closed loop, the paper's cascade) hiding one effect: the right cause, its parameter.

Each case fits on a synthetic sine force test and scores on a step force test of the same device
(held out).  The truth feeds the controller the quantised encoders, the replay does not (a small,
realistic model error); force sensor noise 5 N.  Tolerance on the recovered parameter: 10 % relative.
"""

from __future__ import annotations

import numpy as np
import pytest

from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.elpas_adapter import ElpasAdapter
from vsa_gym.identify.pipeline import Identifier
from vsa_gym.identify.synthetic_elpas import make_elpas_record

REL_TOL = 0.10
DURATION = 1.5


def _identify(seed: int, effect: str | None):
    rec, truth = make_elpas_record(seed, effect, "sine", duration=DURATION)
    test, _ = make_elpas_record(seed + 1000, effect, "step", duration=DURATION, truth=truth["params"])
    return Identifier(n_fit=2, max_nfev=15).fit(rec, test).result_, truth


@pytest.mark.parametrize(("effect", "key", "seed"), [("coulomb_friction", "F_c", 1),
                                                     ("spring_stiffness_drift", "drift", 2)])
def test_planted_effect_is_named_and_recovered(effect, key, seed):
    res, truth = _identify(seed, effect)
    names = [e["name"] for e in res.effects]
    assert names == [effect], f"planted {truth['params']}, named {names}: {res.statements()}"
    got = res.effects[0]["parameters"][key]
    want = truth["params"][f"{effect}.{key}"]
    assert got == pytest.approx(want, rel=REL_TOL)
    lo, hi = res.effects[0]["ci"][key]
    assert lo < hi and not lo <= 0.0 <= hi
    # held out: the step test of the same device
    assert res.test_name.startswith("test record")
    assert res.metrics_after["F"]["rmse"] < 0.7 * res.metrics_before["F"]["rmse"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_negative_control_reports_none(seed):
    res, _ = _identify(200 + seed, None)
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
