"""Domain randomisation: uniform ranges over named parameters, resampled on every reset.

Parameters are addressed by dotted paths into the physics core's parameter set,
e.g. ``"lever.k"`` or ``"I_o"`` for :class:`vsa_gym.devices.vsaut2.params.VsaUT2Params`,
``"friction.F_c"`` or ``"car.m_s"`` for :class:`vsa_gym.devices.elpas.params.ElpasParams`::

    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0",
                   domain_randomization={"lever.k": (1700.0, 2100.0), "I_o": (0.009, 0.013)})

Each reset draws one value per path (in sorted path order) from the row's own
generator, so randomised rollouts are reproducible from the reset seed.  The
randomised set is validated by the parameter classes (bounds), so an invalid
range fails on the first reset with the parameter's name and unit.
:func:`relative_ranges` builds ``+-fraction`` ranges around a parameter set.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from vsa_gym.physics.parameters import ParameterSet


def _resolve(params: ParameterSet, path: str) -> Any:
    obj: Any = params
    for part in path.split("."):
        if not isinstance(obj, ParameterSet) or part not in {f for f in obj.__dataclass_fields__}:
            raise ValueError(f"domain_randomization: {path!r} is not a parameter of {type(params).__name__}")
        obj = getattr(obj, part)
    if isinstance(obj, ParameterSet):
        raise ValueError(f"domain_randomization: {path!r} names a parameter group, not a parameter")
    return obj


def set_param(params: ParameterSet, path: str, value: float) -> ParameterSet:
    """A copy of ``params`` with the dotted ``path`` set to ``value`` (validated by the parameter class)."""
    head, _, rest = path.partition(".")
    if not rest:
        return params.replace(**{head: value})
    return params.replace(**{head: set_param(getattr(params, head), rest, value)})


class DomainRandomization:
    """Uniform ranges ``{path: (low, high)}`` over parameters (see the module docstring)."""

    def __init__(self, ranges: Mapping[str, tuple[float, float]]) -> None:
        checked: dict[str, tuple[float, float]] = {}
        for path, rng in ranges.items():
            try:
                lo, hi = (float(v) for v in rng)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"domain_randomization[{path!r}] must be a (low, high) pair, got {rng!r}") from exc
            if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
                raise ValueError(f"domain_randomization[{path!r}]: need finite low <= high, got {rng!r}")
            checked[path] = (lo, hi)
        self.ranges = dict(sorted(checked.items()))

    def check(self, params: ParameterSet) -> None:
        """Raise ``ValueError`` if a path does not name a scalar parameter of ``params``."""
        for path in self.ranges:
            _resolve(params, path)

    def sample(self, base: ParameterSet, rng: np.random.Generator) -> ParameterSet:
        """``base`` with every randomised parameter drawn uniformly from its range."""
        out = base
        for path, (lo, hi) in self.ranges.items():
            out = set_param(out, path, float(rng.uniform(lo, hi)))
        return out


def relative_ranges(params: ParameterSet, fractions: Mapping[str, float]) -> dict[str, tuple[float, float]]:
    """``{path: (v (1 - f), v (1 + f))}`` around the values of ``params``."""
    out = {}
    for path, f in fractions.items():
        v = float(_resolve(params, path))
        lo, hi = sorted((v * (1.0 - f), v * (1.0 + f)))
        out[path] = (lo, hi)
    return out
