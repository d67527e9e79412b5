"""Selection rules that survive model-structure mismatch, and the look-alike effects.

A record from real hardware never matches the fitted model exactly: friction really sticks, a
gap is sharp, an amplifier has its own dynamics.  After the right effect is in the model the
residual is therefore still coloured, and any further effect can shave a few per cent off it.
BIC on such residuals accepts almost anything (the samples are not independent), so a further
effect must also be *physically significant*:

* **Excess share.**  The noise floor ``sigma_n`` of each output is estimated from the data
  (:func:`noise_floor`); the misfit a model leaves above it is its *excess*.  A further effect must
  remove a large share of the current model's excess validation misfit (:func:`excess_share`), not
  merely a margin of the total, and none is added once the excess is within a few times the floor.
  The right effect removes most of it (a planted effect is the dominant misfit); an effect that
  only soaks up mismatch removes little.
* **Joint refit.**  Every candidate is fitted together with everything already accepted and with
  the free nominal parameters, and after each acceptance the earlier effects are tested again: one
  that the new set no longer needs (validation no worse than ``margin`` without it) is dropped.

Look-alikes (:data:`LOOKALIKE_GROUPS`) are effects that bend the replay in similar ways.  They
are always fitted side by side when one of them ranks first; when the best and a look-alike
validate within ``ambiguity`` of each other, the data cannot tell them apart and the result says
so (:class:`Ambiguity`) with the experiment that would separate them (:data:`SEPARATING`),
instead of asserting either.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from vsa_gym.identify.effects import EffectSpec

#: effects that can explain the same records; one of a group ranking first gets all of them fitted
LOOKALIKE_GROUPS: tuple[tuple[str, ...], ...] = (
    ("backlash", "transmission_compliance", "hysteresis", "coulomb_friction", "gearbox_efficiency"),
    ("stribeck_friction", "sensor_offset", "coulomb_friction"),
    ("coulomb_friction", "force_offset"),
    ("coulomb_friction", "viscous_friction"),
    ("inertia_error", "sensor_gain"),
    # above a transmission mode the motor moves its own inertia only: a compliance changes the inertia a drive
    # appears to move, as an inertia error does at every frequency
    ("inertia_error", "transmission_compliance"),
    # a closed loop that reads a position sensor with a gain error settles where the scaled reading meets the
    # reference, and its loop gains are scaled too: that bends the replay as a loss or a damping on the drive does
    ("sensor_gain", "gearbox_efficiency"),
    ("sensor_gain", "viscous_friction"),
)

#: the experiment that separates two look-alikes
SEPARATING: dict[frozenset[str], str] = {
    frozenset({"backlash", "transmission_compliance"}):
        "a slow reversal at low force: a gap lets the motor move without load force, a compliance deflects "
        "in proportion to the force",
    frozenset({"backlash", "hysteresis"}):
        "small reversals of growing amplitude: hysteresis loops grow with amplitude, a gap gives a fixed dead travel",
    frozenset({"backlash", "coulomb_friction"}):
        "a locked load: a gap shows as free motor travel, friction as a force threshold",
    frozenset({"backlash", "gearbox_efficiency"}):
        "a torque sweep with the load locked: a gap is free travel at zero force, a loss scales the force",
    frozenset({"transmission_compliance", "hysteresis"}):
        "a slow torque sweep with the load locked: a compliance is a single line, hysteresis a loop",
    frozenset({"transmission_compliance", "coulomb_friction"}):
        "a frequency sweep through the transmission mode: a compliance shows a resonance, friction does not",
    frozenset({"transmission_compliance", "gearbox_efficiency"}):
        "a torque sweep with the load locked: a compliance deflects, a loss scales the force",
    frozenset({"hysteresis", "coulomb_friction"}):
        "small reversals below the breakaway travel: presliding hysteresis is elastic there, Coulomb friction is not",
    frozenset({"hysteresis", "gearbox_efficiency"}):
        "a slow constant-speed run at two loads: a loss grows with the transmitted force, hysteresis does not",
    frozenset({"coulomb_friction", "gearbox_efficiency"}):
        "runs at one speed and several load forces: a loss grows with the transmitted force, Coulomb friction is "
        "constant",
    frozenset({"stribeck_friction", "sensor_offset"}):
        "a slow constant-speed run in each direction: Stribeck friction falls with speed, a sensor offset shifts "
        "the position at every speed",
    frozenset({"stribeck_friction", "coulomb_friction"}):
        "slow constant-speed runs at several speeds: Stribeck friction falls with speed, Coulomb friction is flat",
    frozenset({"coulomb_friction", "sensor_offset"}):
        "a record that starts at a known position: an offset shifts it, friction does not",
    frozenset({"coulomb_friction", "force_offset"}):
        "moves in both directions at the same speed: Coulomb friction changes sign with the speed, a constant "
        "load force does not",
    frozenset({"coulomb_friction", "viscous_friction"}):
        "constant-speed runs at several speeds: viscous friction grows in proportion to the speed, Coulomb "
        "friction is flat once built up",
    frozenset({"sensor_gain", "gearbox_efficiency"}):
        "a move over a distance measured independently (a gauge block, a second sensor): a gain error scales the "
        "reading, a loss only the force it takes",
    frozenset({"sensor_gain", "viscous_friction"}):
        "moves of one measured distance at several speeds: viscous friction grows with the speed, a gain error "
        "scales the reading at every speed",
    frozenset({"inertia_error", "transmission_compliance"}):
        "a frequency sweep through the transmission mode: a compliance shows a resonance and, above it, the motor's "
        "inertia alone; an inertia error scales the response at every frequency",
    frozenset({"inertia_error", "sensor_gain"}):
        "a measured force or a second position sensor: an inertia error changes the force-acceleration ratio, "
        "a sensor gain only the reading",
}


def lookalikes(name: str) -> set[str]:
    """The effects that share a look-alike group with ``name`` (without ``name``)."""
    out: set[str] = set()
    for group in LOOKALIKE_GROUPS:
        if name in group:
            out.update(group)
    out.discard(name)
    return out


def shares_force(a: EffectSpec, b: EffectSpec) -> bool:
    """Whether look-alikes ``a`` and ``b`` are forces of one kind at one place (same location, main parameters of
    the same unit): the sliding force of a Dahl loop and of Coulomb friction add up, so the first one fitted
    carries their sum and the second can only be found by taking a share of it (:func:`vsa_gym.identify.starts.
    split_start`)."""
    if b.name not in lookalikes(a.name) or a.location != b.location:
        return False
    return a.main_param[1].unit == b.main_param[1].unit


def separating_experiment(a: str, b: str) -> str:
    return SEPARATING.get(frozenset({a, b}), "an experiment that excites the two effects differently")


def noise_floor(y: np.ndarray, resolution: float = 0.0) -> float:
    """Standard deviation of a measured signal's noise (same unit as ``y``).

    The third difference of white noise has variance ``20 sigma^2`` while a smooth signal's is
    ``O(dt^3)``; a robust spread (1.4826 x the median absolute deviation) ignores the few large
    differences of fast transients.  A quantiser of step ``q`` adds at least ``q / sqrt(12)``.
    """
    y = np.asarray(y, dtype=np.float64)
    if y.size < 8:
        return resolution / math.sqrt(12.0)
    d = np.diff(y, 3)
    mad = 1.4826 * float(np.median(np.abs(d - np.median(d))))
    sd = math.sqrt(float(np.mean(d**2)))
    sigma = min(mad if mad > 0 else sd, sd) / math.sqrt(20.0)
    return max(sigma, resolution / math.sqrt(12.0))


def excess_share(new: float, current: float, floor: float) -> float:
    """Share of the current model's misfit above the noise floor that a new model removes (scores as NRMSE)."""
    ex_cur = current**2 - floor**2
    if ex_cur <= 0.0:
        return 0.0
    return float(1.0 - max(new**2 - floor**2, 0.0) / ex_cur)


@dataclasses.dataclass
class Ambiguity:
    """Two (or more) look-alike effects the record cannot tell apart."""

    between: list[str]
    round: int
    validation_nrmse: dict[str, float]
    values: dict[str, dict[str, float]]
    experiment: str

    def statement(self, describe: dict[str, str]) -> str:
        names = [describe.get(n, n) for n in self.between]
        scores = ", ".join(f"{describe.get(n, n)} {v:.4g}" for n, v in self.validation_nrmse.items())
        return (f"Ambiguous between {' and '.join(names)}: they validate alike (NRMSE {scores}); neither is "
                f"asserted. To separate them: {self.experiment}.")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def separated_by_swap(ambiguous: list[Ambiguity], gone: set[str], came: set[str]
                      ) -> tuple[list[Ambiguity], list[Ambiguity]]:
    """``(kept, separated)``: the ambiguities a swap that took out ``gone`` and put in ``came`` separates (it
    replaced one of their look-alikes by another) and the others.  The caller decides whether the swap's
    gain was decisive."""
    hit = [a for a in ambiguous if gone & set(a.between) and came & set(a.between)]
    return [a for a in ambiguous if a not in hit], hit


__all__ = ["LOOKALIKE_GROUPS", "SEPARATING", "Ambiguity", "excess_share", "lookalikes", "noise_floor",
           "separated_by_swap", "separating_experiment", "shares_force"]
