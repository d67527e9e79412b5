"""The two look-aheads from round one of the forward selection, mixed into
:class:`vsa_gym.identify.pipeline.Identifier` (:class:`LookAheads`).

Forward selection commits to one effect at a time, and round one can mislead it in two ways:

* no effect passes alone because two are needed together (a load force and the friction that holds it):
  :meth:`LookAheads._together` fits the best of round one with a partner;
* the effect that validates best alone stands in for two (a sensor gain for a mesh loss plus a viscous
  friction) and nothing added to it removes the rest: :meth:`LookAheads._runner_up` runs the later rounds
  again from round one's runner-up.

Both use the estimator's own fits and rules (``Identifier._with``, ``_judge``, ``_prune``, ``_forward``): they
are methods of it, kept here so that the selection's main loop stays readable.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.fitting import compared, effect_sound, effect_values
from vsa_gym.identify.ranking import rank_candidates
from vsa_gym.identify.result import Candidate, FittedModel
from vsa_gym.identify.rules import undersized
from vsa_gym.identify.selection import Ambiguity, excess_share

if TYPE_CHECKING:
    from vsa_gym.identify.pipeline import Identifier

#: a selection ending this many times above the validation noise floor is tried again from round one's runner-up
#: where that validated within RUNNER_UP times the winner's error; the runner-up's branch must validate below
#: BRANCH_GAIN times the selection's error to replace it (:meth:`LookAheads._runner_up`)
BRANCH_FLOOR = 10.0
RUNNER_UP = 2.0
BRANCH_GAIN = 0.5


class LookAheads:
    """Round one's look-aheads of :class:`vsa_gym.identify.pipeline.Identifier` (a mixin: see the module)."""

    def _together(self: Identifier, ad: Adapter, start: FittedModel, fitted: list[tuple[FittedModel, Candidate]],
                  names: list[str], masks: dict[str, np.ndarray], floors: dict[str, float], cands: list[Candidate],
                  rnd: int) -> FittedModel | None:
        """Two effects that pass only together, where none passed alone in round one; else None.

        Each of two forces can be needed for the other to show: on a vertical axis in closed loop (truth case
        61016: 208 N of gravity, 102 N of Coulomb friction) the load force alone fits the fit part better but
        validates no better than the nominal model, and the friction alone validates worse (it cannot hold the
        load); the two together validate at 2.4e-6 against 0.022. So where the nominal model is well above the
        noise floor (:attr:`floor_factor`) and the candidate that fits the fit part best removes most of its
        misfit there (:attr:`min_share_next` of the excess), the others are ranked beside it and the best
        :attr:`n_fit` fitted jointly with it. A pair is accepted by the same rules as a single effect against
        the nominal model (the second effect's evidence as in round one), and also if the first effect's
        evidence stands beside it, both are at least :attr:`min_size_next` of their typical sizes, and the pair
        validates better by the margin than the first effect alone; of those, the one that validates best.
        (Until the ninth session a partner round one had not fitted, for its low rank, was also refitted alone
        here (fresh case 97021, a mesh loss); round one now fits every candidate where nothing passes on such a
        misfit, so that mesh loss is named there.)"""
        if start.val_score < self.floor_factor * floors["validation"] or not fitted:
            return None
        base, base_cand = min(fitted, key=lambda p: p[0].fit_score)
        if excess_share(base.fit_score, start.fit_score, floors["fit"]) < self.min_share_next:
            return None
        others = [n for n in names if n != base_cand.name]
        pairs: list[tuple[FittedModel, Candidate]] = []  # accepted pairs
        for name, score in rank_candidates(ad, base, others, masks["fit"])[:self.n_fit]:
            fm = self._with(ad, base, name, masks)
            cand = Candidate(rnd, name, score)
            self._judge(ad, cand, fm, start, floors)
            base_sound = effect_sound(ad.effects[base_cand.name], fm)
            minor = undersized(fm, [ad.effects[e].main_param for e in fm.effects], self.min_size_next)
            s_pair, s_base, part = compared(fm, base, floors["validation"])
            reasons = [] if cand.accepted else [cand.reason]
            if not base_sound:
                reasons.append(f"{base_cand.name} beside it: CI includes absent, at a bound or within tolerance")
            if minor:
                reasons.append(f"{', '.join(minor)} below {self.min_size_next:g}x its typical size")
            if not s_pair < (1 - self.margin) * s_base:
                reasons.append(f"{part} error {s_pair:.4g} vs {s_base:.4g} with {base_cand.name} alone")
            cand.accepted = not reasons
            cand.reason = (f"fitted together with {base_cand.name} (no effect passed alone; it fits the fit part "
                           f"best): " + ("passes all criteria as a pair" if cand.accepted else "; ".join(reasons)))
            cands.append(cand)
            if cand.accepted:
                pairs.append((fm, cand))
        if not pairs:
            return None
        # the pair that validates best; every other accepted one stands down
        fm, cand = min(pairs, key=lambda p: p[0].val_score)
        for _, c in pairs:
            if c is not cand:
                c.accepted = False
                c.reason += "; another pair validates better"
        base_cand.reason += f"; accepted together with {cand.name} (validation {fm.val_score:.4g})"
        cands.append(Candidate(rnd, base_cand.name, float("nan"), True, fm.val_score, fm.bic, accepted=True,
                               reason=f"passes only together with {cand.name} (validation {fm.val_score:.4g} vs "
                                      f"{start.val_score:.4g} nominal, {base.val_score:.4g} alone)",
                               values=effect_values(fm, base_cand.name)))
        return self._prune(ad, fm, masks, cands, rnd, floors["validation"])

    def _runner_up(self: Identifier, ad: Adapter, current: FittedModel, cands: list[Candidate],
                   ambiguous: list[Ambiguity], first: list[tuple[FittedModel, Candidate]], names: list[str],
                   masks: dict[str, np.ndarray], floors: dict[str, float], solo: dict[str, FittedModel]
                   ) -> tuple[FittedModel, list[Candidate], list[Ambiguity]]:
        """Repeat the selection from round one's runner-up where the winner's branch ends far above the noise floor.

        Forward selection commits to the first effect that validates best, and one effect can stand in for two
        at the first round: on a closed loop, a sensor gain reproduces a mesh loss plus a viscous friction
        within a few per cent, and no second effect then removes what it leaves.  Where the selected model
        still validates :data:`BRANCH_FLOOR` times above the noise floor and a passing runner-up of round one
        validated within :data:`RUNNER_UP` of the winner, the later rounds are run again from the runner-up;
        that branch's model replaces the selection only if its error is below :data:`BRANCH_GAIN` times the
        selection's, compared as every other choice is (:func:`~vsa_gym.identify.fitting.compared`: on the fit
        part where the validation part cannot tell the two apart), so a branch wins on the data, not on a tie.
        """
        if (self.max_effects < 2 or len(first) < 2 or not current.effects
                or current.val_score <= BRANCH_FLOOR * floors["validation"]):
            return current, cands, ambiguous
        winner = min(first, key=lambda p: p[0].val_score)
        runners = [p for p in first if p[1] is not winner[1] and p[0].val_score <= RUNNER_UP * winner[0].val_score]
        if not runners:
            return current, cands, ambiguous
        fm, cand = min(runners, key=lambda p: p[0].val_score)
        branch, more, branch_ambiguous, _ = self._forward(ad, fm, names, masks, floors, 2, solo)
        s_branch, s_current, _ = compared(branch, current, floors["validation"])
        note = (f"the selection from round one's runner-up {cand.name} ({', '.join(branch.effects)}: validation "
                f"{branch.val_score:.4g}) against {', '.join(current.effects)} ({current.val_score:.4g})")
        for c in more:
            c.reason = f"from runner-up {cand.name}: {c.reason}"
        if not (branch.effects != current.effects and s_branch < BRANCH_GAIN * s_current):
            for c in more:
                c.accepted = False
            return current, cands + more, ambiguous
        for c in cands:
            if c.accepted:
                c.accepted = False
                c.reason += f"; replaced by {note}"
        cand.accepted = True
        cand.reason = f"round one's runner-up, adopted: {note}"
        return branch, cands + more, branch_ambiguous


__all__ = ["BRANCH_FLOOR", "BRANCH_GAIN", "LookAheads", "RUNNER_UP"]
