"""What a device declares: its measured-record schema, its identification adapter and synthetic-recovery bench,
its environments, its paper reproduction and datasheet (:mod:`vsa_gym.devices`)."""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Collection, Mapping
from typing import Any


def load_ref(ref: str) -> Any:
    """The object a ``"package.module:attribute"`` reference names (the module alone without ``:``)."""
    module, _, attr = ref.partition(":")
    obj = importlib.import_module(module)
    return getattr(obj, attr) if attr else obj


@dataclasses.dataclass(frozen=True)
class RecordSchema:
    """The quantities a measured record of the device may declare (``vsa-gym data check``).

    ``inputs`` / ``outputs``: quantity -> allowed units.  ``needs``: the record must declare at least one of these
    input quantities (empty: no rule); ``needs_message`` says so when it does not.  ``params``: a reference to the
    names ``model.params`` may give (empty: not checked); ``renamed``: an old name -> what replaced it.
    """

    inputs: Mapping[str, tuple[str, ...]]
    outputs: Mapping[str, tuple[str, ...]]
    needs: frozenset[str] = frozenset()
    needs_message: str = ""
    params: str = ""
    renamed: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def params_problem(self, given: Collection[str]) -> str | None:
        """The problem with the names a sidecar's ``model.params`` gives, or ``None``."""
        if not self.params:
            return None
        names = tuple(load_ref(self.params))
        unknown = sorted(set(given) - set(names))
        if not unknown:
            return None
        hints = "".join(f" ({k}: now {self.renamed[k]})" for k in unknown if k in self.renamed)
        return (f"model.params: unknown parameter(s) {', '.join(map(repr, unknown))}{hints}; the fields are "
                f"{', '.join(names)}")

    def input_problem(self, declared: set[str]) -> str | None:
        """The problem with the declared input quantities, or ``None`` (no inputs declared: nothing to say here)."""
        if self.needs and declared and not declared & self.needs:
            return self.needs_message
        return None


@dataclasses.dataclass(frozen=True)
class EnvEntry:
    """A Gymnasium environment of the device: registered as ``vsa_gym/<name>`` with ``<entry>Env`` and
    ``<entry>VectorEnv`` (``"module:ClassPrefix"``) and a time limit of ``max_episode_steps``."""

    name: str
    entry: str
    max_episode_steps: int


@dataclasses.dataclass(frozen=True)
class DeviceSpec:
    """One device.  References are ``"module:attribute"`` strings, imported on use (:func:`load_ref`).

    ``adapter``: the identification adapter class (``Adapter`` subclass taking a record); ``effects``: its
    effect library (a sequence of :class:`vsa_gym.identify.library.Effect`);
    ``recovery``: the synthetic-recovery bench (an object with ``catalogue()``, ``negative_experiments()``,
    ``main_key(effect)`` and ``identify_case(experiment, effect, seed)``; :mod:`vsa_gym.identify.recovery`);
    ``reproduce``: a module with ``run(out_dir) -> summary``; ``datasheet``: a module with ``compute()`` and
    ``format_table(rows)``.
    """

    name: str
    description: str
    record: RecordSchema
    adapter: str | None = None
    effects: str | None = None
    recovery: str | None = None
    envs: tuple[EnvEntry, ...] = ()
    reproduce: str | None = None
    datasheet: str | None = None

    def adapter_class(self) -> Any:
        if self.adapter is None:
            raise NotImplementedError(f"identification of {self.name!r} records has no replay adapter")
        return load_ref(self.adapter)

    def effect_library(self) -> Any:
        if self.effects is None:
            raise NotImplementedError(f"device {self.name!r} declares no effect library")
        return load_ref(self.effects)

    def recovery_bench(self) -> Any:
        if self.recovery is None:
            raise NotImplementedError(f"device {self.name!r} has no synthetic-recovery bench")
        return load_ref(self.recovery)


__all__ = ["DeviceSpec", "EnvEntry", "RecordSchema", "load_ref"]
