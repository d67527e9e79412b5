"""Multiple shooting in the selection: when a full open-loop replay runs away or drifts, and the windows it uses.

An open-loop replay of an integrating plant or of a vertical axis runs away with the smallest model error, and
one of a stick-slip axis drifts: the simulation-error least squares then stalls at the nominal error.  On windows
started from the measured state (truncated simulation error) it does not.  These are the tests and the window
length :class:`vsa_gym.identify.pipeline.Identifier` uses to decide that, and the record of a selection made on
windows.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vsa_gym.identify.record import Record
from vsa_gym.identify.result import Candidate, FittedModel
from vsa_gym.identify.selection import Ambiguity

#: a full replay whose nominal validation NRMSE exceeds this runs away (integrating plant, unmodelled load)
RUNAWAY_NRMSE = 1.0
#: a full open-loop replay whose selected model still leaves this validation NRMSE drifts: the selection is
#: repeated on shooting windows (:meth:`Identifier._second_opinion`)
DRIFT_NRMSE = 0.1

def shooting_window(record: Record) -> float:
    """Length (s) of the multiple-shooting windows of a record: a twentieth of it, 0.2 to 1 s."""
    return float(np.clip((record.t[-1] - record.t[0]) / 20.0, 0.2, 1.0))


def runs_away(nominal: FittedModel, fm: FittedModel) -> bool:
    """Whether the full replay ran away: the nominal model and ``fm`` both validate above :data:`RUNAWAY_NRMSE`."""
    return nominal.val_score > RUNAWAY_NRMSE and fm.val_score > RUNAWAY_NRMSE


@dataclasses.dataclass(frozen=True)
class WindowSelection:
    """A selection on shooting windows of ``window`` s (:meth:`Identifier._on_windows`): the model ``selected``
    there, its ``candidates`` and ``ambiguous`` look-alikes, and ``refit``, that model refitted by full simulation
    error (None where the windows selected no effect)."""

    window: float
    selected: FittedModel
    candidates: list[Candidate]
    ambiguous: list[Ambiguity]
    refit: FittedModel | None

    def settles(self, current: FittedModel, margin: float, level: float) -> bool:
        """Whether the refitted window model validates better than ``current`` by the ``margin`` and within
        ``level`` (a validation NRMSE)."""
        return (self.refit is not None and self.refit.val_score < (1 - margin) * current.val_score
                and self.refit.val_score <= level)


__all__ = ["DRIFT_NRMSE", "RUNAWAY_NRMSE", "WindowSelection", "runs_away", "shooting_window"]
