"""The device registry: one declaration per device replaces the device lists of the CLI, the record checker,
the recovery benchmark, the environment table and the identification adapter's if-chain.

A device is a :class:`DeviceSpec` (:mod:`vsa_gym.devices.spec`) declared once in ``vsa_gym/devices/<name>.py``
as ``DEVICE``; the modules it points to (adapter, synthetic-recovery bench, environments, paper reproduction,
datasheet) are named as ``"module:attribute"`` strings and imported only when used, so reading the registry is
cheap and import cycles cannot form.  Adding a device is one new declaration module plus its entry in
:data:`DECLARATIONS`.

Use::

    from vsa_gym.devices import device, devices
    device("elpas").adapter_class()          # the identification adapter
    [d.name for d in devices() if d.reproduce]  # devices with a paper reproduction
"""

from __future__ import annotations

import importlib

from vsa_gym.devices.spec import DeviceSpec, EnvEntry, RecordSchema

#: the declaration modules, in the order devices are listed (record format, CLI choices, documentation)
DECLARATIONS: tuple[str, ...] = ("vsa_gym.devices.drive", "vsa_gym.devices.vsaut2", "vsa_gym.devices.elpas")

_REGISTRY: dict[str, DeviceSpec] = {}


def _load() -> dict[str, DeviceSpec]:
    if not _REGISTRY:
        for mod in DECLARATIONS:
            spec = importlib.import_module(mod).DEVICE
            if spec.name in _REGISTRY:
                raise RuntimeError(f"device {spec.name!r} declared twice ({mod})")
            _REGISTRY[spec.name] = spec
    return _REGISTRY


def devices() -> tuple[DeviceSpec, ...]:
    """Every registered device, in declaration order."""
    return tuple(_load().values())


def device_names() -> tuple[str, ...]:
    """The names of every registered device."""
    return tuple(_load())


def device(name: str) -> DeviceSpec:
    """The device called ``name`` (``ValueError`` naming the known devices otherwise)."""
    reg = _load()
    if name not in reg:
        raise ValueError(f"unknown device {name!r}; the registered devices are {', '.join(reg)}")
    return reg[name]


__all__ = ["DECLARATIONS", "DeviceSpec", "EnvEntry", "RecordSchema", "device", "device_names", "devices"]
