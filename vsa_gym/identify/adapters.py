"""Device adapters: replay a record through a device core with a candidate parameter batch.

An adapter turns ``theta`` -- a dict ``"<effect>.<param>" -> (n,)`` array (and
``"base.<name>"`` for the free nominal parameters) -- into ``n`` simulated,
measured outputs ``(T, n, n_outputs)``.  Keys that are missing mean "absent" /
nominal.  All rows are simulated as one batch through the device core.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from vsa_gym.identify.effects import EffectSpec, MeasurementModel, ParamSpec, sensor_specs
from vsa_gym.identify.record import Record, Signal

Theta = Mapping[str, np.ndarray]
#: the sensor effects' parameters in the order of :meth:`MeasurementModel.apply` (gain, offset, delay)
SENSOR_KEYS: tuple[str, ...] = ("sensor_gain.gain", "sensor_offset.offset", "sensor_delay.delay")


class Adapter:
    """Base class; subclasses implement :meth:`simulate_physical` and set ``effects`` / ``base``."""

    record: Record
    outputs: list[Signal]
    base: list[ParamSpec]
    effects: dict[str, EffectSpec]
    measurement: list[MeasurementModel]

    def __init__(self, record: Record) -> None:
        self.record = record
        self.t = record.t
        self.dt = record.dt
        self.outputs = list(record.outputs.values())
        self.measured = np.stack([record.output(s.quantity) for s in self.outputs], axis=1)
        self.measurement = []
        for s in self.outputs:
            spec = record.meta["outputs"][s.column]
            bias = -0.5 * s.resolution if spec.get("quantizer") == "floor" else 0.0
            self.measurement.append(MeasurementModel(rectify=s.quantity == "speed_abs",
                                                     filter_hz=float(spec.get("filter_hz", 0.0)), bias=bias))

    # -- to implement
    def simulate_physical(self, theta: Theta, n: int) -> np.ndarray:
        raise NotImplementedError

    def for_record(self, record: Record) -> Adapter:
        """The same model replaying another record of the same device (e.g. the test record)."""
        raise NotImplementedError

    #: multiple-shooting window in samples (0: one replay of the whole record)
    shooting: int = 0

    #: effects a multiple-shooting replay cannot see
    SHOOTING_BLIND: tuple[str, ...] = ()

    #: multiple of the substeps the device's own rule asks for (raised by
    #: :func:`vsa_gym.identify.convergence.refined` where the selected model's replay is not converged)
    refine: int = 1

    def can_refine(self) -> bool:
        """Whether :attr:`refine` applies to this adapter's replay (a device adapter may offer it)."""
        return False

    def can_shoot(self) -> bool:
        """Whether :meth:`set_shooting` applies to this record (a device adapter may offer it)."""
        return False

    def observable_effects(self) -> list[str]:
        """The catalogue effects the current replay can see (all, unless it replays on shooting windows)."""
        return [e for e in self.effects if not (self.shooting and e in self.SHOOTING_BLIND)]

    def set_shooting(self, window: float | None) -> None:
        raise ValueError(f"{type(self).__name__} has no multiple-shooting replay")

    def restarts(self, effect: str, theta: Mapping[str, float]) -> dict[str, float]:
        """Values of the model's free base parameters that a candidate ``effect`` is also fitted from, besides
        where the model before it (``theta``) holds them (empty: none).  A nuisance parameter that only matters
        once the effect is in can sit anywhere in its range before (the drive's back-EMF share of ``b``: where
        the damping acts makes no difference to a rigid drive, all the difference once a gap splits it into
        motor and load), and a local fit started there may never leave."""
        return {}

    # -- shared
    def _sensor_effects(self) -> dict[str, EffectSpec]:
        y0 = self.measured[:, 0]
        scale = float(np.std(y0)) or float(np.max(np.abs(y0))) or 1.0
        return sensor_specs(self.outputs[0].column, scale, self.dt, float(self.t[-1] - self.t[0]),
                            self.outputs[0].resolution)

    def simulate(self, theta: Theta, n: int, *, until: int | None = None,
                 rows: np.ndarray | None = None) -> np.ndarray:
        """Measured outputs ``(T, n, n_outputs)`` of ``n`` candidate models.

        ``until``: only the samples before it are wanted (a fit part that ends before the record does); the
        later ones come back NaN, and a device adapter need not simulate them.  ``rows``: only these of the
        ``n`` models are wanted, ``(T, len(rows), n_outputs)``; each comes back exactly as it would in the
        whole batch (a device adapter chooses its integration step for all ``n``).  This base class
        simulates everything and cuts."""
        y = self._measure(theta, self.simulate_physical(theta, n), 0, len(self.t))
        if until is not None:
            y[until:] = np.nan
        return y if rows is None else y[:, np.asarray(rows)]

    def _measure(self, theta: Theta, x: np.ndarray, a: int, b: int) -> np.ndarray:
        """The sensors (measurement model, and the sensor effects of the first output) applied to physical
        outputs ``x`` of rows ``a:b``."""
        out = np.empty_like(x)
        for j, mm in enumerate(self.measurement):
            terms = [theta.get(k) for k in SENSOR_KEYS] if j == 0 else []
            out[:, :, j] = mm.apply(self.t[a:b], x[:, :, j], *terms)
        return out


def theta_column(theta: Theta, key: str, n: int, default: float = 0.0) -> np.ndarray:
    v = theta.get(key)
    return np.full(n, default) if v is None else np.broadcast_to(np.asarray(v, dtype=np.float64), (n,))


def theta_rows(theta: Theta, n: int, rows: np.ndarray) -> dict[str, np.ndarray]:
    """The candidates ``rows`` of an ``n``-row ``theta`` (a scalar entry stands for every row)."""
    return {k: np.broadcast_to(np.asarray(v, dtype=np.float64), (n,))[rows] for k, v in theta.items()}



def make_adapter(record: Record, **kw: Any) -> Adapter:
    """The identification adapter of the record's device (:mod:`vsa_gym.devices`) replaying ``record``."""
    from vsa_gym.devices import device

    try:
        cls = device(record.device).adapter_class()
    except NotImplementedError as exc:
        raise NotImplementedError(f"identification of {record.device!r} records is not implemented yet: the "
                                  "record format and checker cover it, but it has no replay adapter") from exc
    return cls(record, **kw)


def __getattr__(name: str) -> Any:
    """The drive adapter's names, moved to :mod:`vsa_gym.devices.drive.adapter` (kept importable from here)."""
    if name in ("DriveAdapter", "START_SHARE", "EMF_SHARE"):
        from vsa_gym.devices.drive import adapter

        return getattr(adapter, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["SENSOR_KEYS", "Adapter", "Theta", "make_adapter", "theta_column", "theta_rows"]
