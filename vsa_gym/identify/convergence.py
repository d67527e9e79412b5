"""The selected model's replay checked for integration error, and refined where it is not converged.

A device adapter steps its core with the substeps that the fastest mode of the candidate rows asks for
(the drive: :func:`vsa_gym.devices.drive.model.row_substeps`).  That rule bounds the error of smooth modes; it
does not see a law that is only piecewise smooth -- a load that sticks and breaks away, teeth that meet across a
gap -- where a fixed-step replay converges at first or second order only.  A least-squares fit at the rule's
substeps can then settle where the integration error fits the record (truth case 157018, a 0.31 mrad backlash
beside Coulomb friction at 500 Hz: five substeps; doubling them moved the fitted replay by 5.2e-4, 1.9x the
noise floor, and the gap was fitted 22 % short).

So the selected model is replayed once more at twice the substeps: where its replay moves by more than
:data:`REFINE_TOL` of its own misfit and of the noise floor on the validation part (an integration error
that large is what a fit can take for a parameter's effect; one far below the misfit, as on EMPS with its
unmodelled detail, is not), the adapter keeps the doubled substeps (doubled
again while that holds, at most :data:`REFINE_STEPS` times) and the model is refitted there, its effects as
selected (:meth:`vsa_gym.identify.pipeline.Identifier._refit_refined`: from its values, and each effect again
from its own starts, since the fit at the coarser substeps may sit in another basin).
A friction that the selection chose sticking is restarted sticking (the switch that an effect takes out with
it is held by another effect of the same friction, :func:`vsa_gym.identify.starts.restart_base`): the
refinement is for laws that are only piecewise smooth, while a creeping friction's smooth law is converged at
the substeps its own fastest mode sets, so at finer substeps it fits as it did when the selection refused it.
On timing case 11054 (Stribeck and Coulomb friction, 1 kHz, 20 s) the Stribeck term's restart, which let the
friction creep first, took 6.2 s and fitted at 5.1e-2 (fit NRMSE) against 3.7e-4 from the values; restarted
sticking, 1.3 s and 3.4e-3 (``python -m benchmarks.refine_restarts`` on the timing set, before and after).
The report states the substeps used and the change that set them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.fitting import part_nrmse
from vsa_gym.identify.result import FittedModel

#: the replay is refined while doubling its substeps moves it by more than this share of its misfit and of the
#: noise floor
REFINE_TOL = 0.5
#: at most this many doublings (the substeps times 2 ** REFINE_STEPS)
REFINE_STEPS = 2


def _replay(ad: Adapter, fm: FittedModel) -> np.ndarray:
    """``fm``'s replay at the adapter's current substeps, ``(samples, outputs)``."""
    return ad.simulate({k: np.array([v]) for k, v in fm.theta().items()}, 1)[:, 0, :]


def _doubled(ad: Adapter, fm: FittedModel) -> np.ndarray:
    """``fm``'s replay at twice the adapter's substeps; the adapter's refinement is left as it was."""
    ad.refine *= 2
    try:
        return _replay(ad, fm)
    finally:
        ad.refine //= 2


def _change(ad: Adapter, y: np.ndarray, y2: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """``(change, misfit)`` of replay ``y`` against ``y2`` and against the record on ``mask``
    (:func:`replay_change`)."""
    scale = np.std(ad.measured[mask], axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    change = float(np.mean(np.sqrt(np.mean((y[mask] - y2[mask]) ** 2, axis=0)) / scale))
    misfit = part_nrmse(ad.measured, y, mask)
    if not (np.isfinite(change) and np.isfinite(misfit)):
        return float("inf"), float("inf")
    return change, misfit


def replay_change(ad: Adapter, fm: FittedModel, mask: np.ndarray) -> tuple[float, float]:
    """How far ``fm``'s replay moves on ``mask`` when the adapter's substeps are doubled, and its misfit there
    before they are: ``(change, misfit)``, each the mean over the outputs of an RMS in units of the measured std
    (the scale of the noise floor and of :attr:`FittedModel.val_score`; the misfit is
    :func:`~vsa_gym.identify.fitting.part_nrmse`).  The adapter's refinement is left as it was."""
    return _change(ad, _replay(ad, fm), _doubled(ad, fm), mask)


def refined(ad: Adapter, fm: FittedModel, masks: dict[str, np.ndarray], floor: float,
            refit: Callable[[FittedModel], FittedModel]) -> tuple[FittedModel, str]:
    """``fm`` refitted (by ``refit``, at the adapter's new substeps) where its replay is not converged (see the
    module), and a sentence for the report ('' where the adapter's own substeps already were).  The substeps
    are doubled, at ``fm``'s values, until doubling them again moves the replay by at most :data:`REFINE_TOL`
    of its misfit or of ``floor`` (the noise floor as a validation NRMSE), whichever is larger, at most
    :data:`REFINE_STEPS` times; then ``fm`` is refitted once.  The adapter keeps the refinement, so the held-out
    part is replayed the same way.  Each doubling's replay is the next comparison's coarse one, so a step costs
    one simulation."""
    if not fm.effects or not ad.can_refine():
        return fm, ""
    changes: list[str] = []
    y = _replay(ad, fm)
    for _ in range(REFINE_STEPS):
        y2 = _doubled(ad, fm)
        change, misfit = _change(ad, y, y2, masks["validation"])
        if change <= REFINE_TOL * max(floor, misfit):
            break
        changes.append(f"{change:.3g} at {ad.refine}x (misfit {misfit:.3g})")
        ad.refine *= 2
        y = y2
    if not changes:
        return fm, ""
    fm = refit(fm)
    return fm, (f"doubling the substeps moved the selected model's replay by {', then '.join(changes)} the "
                f"substeps its fastest mode asks for (validation NRMSE; noise floor {floor:.3g}), so it was "
                f"refitted at {ad.refine}x, and the held-out part is replayed so")


__all__ = ["REFINE_STEPS", "REFINE_TOL", "refined", "replay_change"]
