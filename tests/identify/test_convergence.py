"""The selected model's replay checked for integration error (:mod:`vsa_gym.identify.convergence`), on a record of
the independent truth simulator (tests/truthsim): truth case 157018, a 0.31 mrad backlash beside sticking Coulomb
friction on an open-loop gear-motor replay at 500 Hz, where the drive's substep rule leaves a replay that is
not converged (docs/identification.md, twenty-third session)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.truthsim.scenarios import draw_case, write_case
from vsa_gym.identify import convergence
from vsa_gym.identify.adapters import Adapter, make_adapter
from vsa_gym.identify.convergence import REFINE_STEPS, REFINE_TOL, refined, replay_change
from vsa_gym.identify.record import load_record
from vsa_gym.identify.result import FittedModel

#: the model replayed: the truth's gap and friction level, the friction sticking, the contact at its truth's
#: series stiffness (about 90 Hz) and lightly damped
THETA = {"backlash.width": 3.08e-4, "backlash.f_contact": 90.0, "backlash.zeta_contact": 0.1,
         "coulomb_friction.F_c": 0.267, "coulomb_friction.sticks": 1.0}


@pytest.fixture(scope="module")
def backlash_case(tmp_path_factory):
    case = draw_case(157018, ("backlash", "coulomb_friction"))
    rec = load_record(write_case(case, tmp_path_factory.mktemp("truth")))
    return rec


def _adapter(rec) -> tuple[Adapter, dict[str, np.ndarray]]:
    ad = make_adapter(rec)
    assert ad.can_refine() and ad.refine == 1
    return ad, rec.masks()


def _model(ad: Adapter, effects: tuple[str, ...] = ("backlash", "coulomb_friction")) -> FittedModel:
    keys = [k for e in effects for k in ad.effects[e].keys if k in THETA]
    specs = [p for e in effects for k, p in zip(ad.effects[e].keys, ad.effects[e].params, strict=True) if k in THETA]
    values = np.array([THETA[k] for k in keys])
    return FittedModel(effects=effects, keys=keys, specs=specs, values=values, ci=np.c_[values, values],
                       sse_fit=1.0, n_fit=1, val_score=1.0, at_bound=[])


def _replay(ad: Adapter, fm: FittedModel) -> np.ndarray:
    return ad.simulate({k: np.array([v]) for k, v in fm.theta().items()}, 1)[:, 0, :]


def test_doubling_the_substeps_converges_towards_a_fine_reference_and_leaves_the_adapter_as_it_was(backlash_case):
    ad, masks = _adapter(backlash_case)
    fm, val = _model(ad), masks["validation"]
    change_1, misfit_1 = replay_change(ad, fm, val)
    assert ad.refine == 1
    ad.refine = 2
    change_2, _ = replay_change(ad, fm, val)
    assert ad.refine == 2
    assert 0 < change_2 < change_1  # the change shrinks as the substeps grow: the replay converges
    # and the doubled replay is nearer a replay at 16x the rule's substeps than the rule's own replay is
    ad.refine = 16
    fine = _replay(ad, fm)
    coarse = {}
    for r in (1, 2):
        ad.refine = r
        coarse[r] = float(np.sqrt(np.mean((_replay(ad, fm)[val] - fine[val]) ** 2)))
    assert coarse[2] < coarse[1]
    assert np.isfinite(misfit_1) and misfit_1 > 0


def test_a_model_without_effects_or_a_converged_replay_is_not_refitted(backlash_case):
    ad, masks = _adapter(backlash_case)
    calls = []

    def refit(fm: FittedModel) -> FittedModel:
        calls.append(ad.refine)
        return fm

    nominal = _model(ad, ())
    assert refined(ad, nominal, masks, 0.0, refit) == (nominal, "")
    fm = _model(ad)
    change, misfit = replay_change(ad, fm, masks["validation"])
    # a floor above what doubling moves (over the tolerance) leaves the rule's substeps alone
    out, note = refined(ad, fm, masks, 1.01 * change / REFINE_TOL + misfit, refit)
    assert out is fm and note == "" and ad.refine == 1 and calls == []


def test_a_replay_that_moves_beyond_its_misfit_is_refined_and_refitted_once(backlash_case):
    ad, masks = _adapter(backlash_case)
    fm = _model(ad)
    # a record the model replays exactly at the rule's substeps: every integration error exceeds its misfit
    ad.measured = _replay(ad, fm).copy()
    change, misfit = replay_change(ad, fm, masks["validation"])
    assert misfit == 0.0 and change > 0.0
    calls = []

    def refit(m: FittedModel) -> FittedModel:
        calls.append(ad.refine)
        return m

    out, note = refined(ad, fm, masks, 0.0, refit)
    assert out is fm and len(calls) == 1
    assert 2 <= ad.refine <= 2 ** REFINE_STEPS and calls == [ad.refine]  # the adapter keeps the refinement
    assert f"refitted at {ad.refine}x" in note and f"{change:.3g} at 1x" in note


def test_each_doubling_is_judged_on_a_replay_at_its_own_substeps(backlash_case, monkeypatch):
    """With a tolerance that asks for both doublings, the second change the report gives is the one a fresh
    replay at twice the rule's substeps gives (the doubled replay is reused, not stale)."""
    ad, masks = _adapter(backlash_case)
    fm = _model(ad)
    ad.measured = _replay(ad, fm).copy()
    monkeypatch.setattr(convergence, "REFINE_TOL", 0.1)
    _, note = refined(ad, fm, masks, 0.0, lambda m: m)
    assert ad.refine == 2 ** REFINE_STEPS == 4
    fresh = make_adapter(backlash_case)
    fresh.measured, fresh.refine = ad.measured, 2
    change_2, misfit_2 = replay_change(fresh, fm, masks["validation"])
    assert f", then {change_2:.3g} at 2x (misfit {misfit_2:.3g})" in note
