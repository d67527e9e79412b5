"""Declarative effect libraries: each device lists its candidate effects once (as PySINDy and SysIdentPy declare
their libraries of terms), and the adapters, the synthetic generators and the recovery tables derive from it.

An :class:`Effect` entry says what the effect is called, where it acts, how it enters the device's equations,
its parameters (:class:`Param`: unit, bounds, the value meaning "absent", a typical magnitude, which one is the
main parameter), when it applies to a record, the realistic magnitudes a synthetic record plants (per experiment)
and where those come from.  Bounds and typical values may depend on the record: a number, or a function of the
adapter (its reference scales such as ``F_ref``, ``v_ref``, ``x_ref``, its nominal parameters, the free base
parameters).  The equation itself lives where the device's model is written (the adapter's parameter mapping or
the core): a new effect is one entry here plus its equation there.

Measurement effects (sensor gain, offset, delay) are declared with ``measurement=True``: their parameters come
from :func:`vsa_gym.identify.effects.sensor_specs` (the measurement model, kept apart from the physics
parameters); the entry carries their synthetic magnitudes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from vsa_gym.identify.effects import EffectSpec, ParamSpec

Value = float | Callable[[Any], float]
"""A number, or a function of the adapter returning one."""


def _value(v: Value, adapter: Any) -> float:
    return v(adapter) if callable(v) else v


@dataclasses.dataclass(frozen=True)
class Param:
    """A parameter of an effect (see :class:`vsa_gym.identify.effects.ParamSpec`, which it becomes per record)."""

    name: str
    unit: str | Callable[[Any], str]
    lower: Value
    upper: Value
    absent: Value = 0.0
    typical: Value = 1.0
    main: bool = True
    tolerance: Value = 0.0
    check_bound: bool = True
    optional: bool = False
    grid: int = 0
    dead_with: str = ""

    def spec(self, adapter: Any) -> ParamSpec:
        unit = self.unit(adapter) if callable(self.unit) else self.unit
        return ParamSpec(self.name, unit, _value(self.lower, adapter), _value(self.upper, adapter),
                         _value(self.absent, adapter), _value(self.typical, adapter), main=self.main,
                         tolerance=_value(self.tolerance, adapter), check_bound=self.check_bound,
                         optional=self.optional, grid=self.grid, dead_with=self.dead_with)


def _always(adapter: Any) -> bool:
    del adapter
    return True


@dataclasses.dataclass(frozen=True)
class Effect:
    """One candidate effect of a device's library.

    ``where``: where it acts (text, or a function of the adapter); ``enters``: how it enters the equations;
    ``when``: whether it is a candidate for this record (e.g. not when its parameter is already fitted as a
    base parameter); ``synthetic``: realistic magnitudes planted in synthetic records, ``{experiment: {param:
    (low, high)}}`` (``signed``: the sign is drawn too); ``source``: where those magnitudes come from.
    """

    name: str
    where: str | Callable[[Any], str] = ""
    params: tuple[Param, ...] = ()
    enters: str = ""
    when: Callable[[Any], bool] = _always
    measurement: bool = False
    synthetic: Mapping[str, Mapping[str, tuple[float, float]]] = dataclasses.field(default_factory=dict)
    signed: bool = False
    source: str = ""

    @property
    def main(self) -> str:
        """The main parameter (the first one marked ``main``; a measurement effect's own parameter)."""
        if self.measurement:
            return {"sensor_gain": "gain", "sensor_offset": "offset", "sensor_delay": "delay"}[self.name]
        return next(p.name for p in self.params if p.main)

    def spec(self, adapter: Any) -> EffectSpec:
        where = self.where(adapter) if callable(self.where) else self.where
        return EffectSpec(self.name, where, tuple(p.spec(adapter) for p in self.params))


Library = Sequence[Effect]


def physics_specs(library: Library, adapter: Any) -> dict[str, EffectSpec]:
    """The physics effects of ``library`` that apply to the adapter's record, in library order."""
    return {e.name: e.spec(adapter) for e in library if not e.measurement and e.when(adapter)}


def main_parameters(library: Library) -> dict[str, str]:
    """Effect -> main parameter (the recovery tables' reported and tested parameter)."""
    return {e.name: e.main for e in library}


def synthetic_ranges(library: Library, experiment: str) -> dict[str, dict[str, tuple[float, float]]]:
    """Effect -> realistic ranges of its parameters for ``experiment``, for the effects planted there."""
    return {e.name: dict(e.synthetic[experiment]) for e in library if experiment in e.synthetic}


def signed_effects(library: Library) -> set[str]:
    """The effects whose planted sign is drawn at random."""
    return {e.name for e in library if e.signed}


def entry(library: Library, name: str) -> Effect:
    """The library's entry for ``name`` (``KeyError`` naming the known effects otherwise)."""
    for e in library:
        if e.name == name:
            return e
    raise KeyError(f"no effect {name!r} in the library; have {', '.join(e.name for e in library)}")


__all__ = ["Effect", "Library", "Param", "entry", "main_parameters", "physics_specs", "signed_effects",
           "synthetic_ranges"]
