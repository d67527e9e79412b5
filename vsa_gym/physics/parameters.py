"""Documented, validated, batchable parameter sets.

Every physical number in vsa-gym lives in a frozen dataclass that derives from
:class:`ParameterSet`, declared with :func:`param`.  Each field carries

* ``symbol`` -- the symbol used in the papers and docstrings,
* ``unit``   -- the SI unit,
* ``source`` -- where the number comes from (paper table / equation, catalog, derivation),
* ``tag``    -- one of ``paper``, ``catalog``, ``derived``, ``proposed`` (see
  ``parameters.md`` in the shared notes; the same tags are used here),
* optional bounds used by validation.

A field holds either a Python float (one parameter set) or a 1-D ``float64``
array of shape ``(n,)`` (a batch of ``n`` parameter sets, e.g. for domain
randomisation).  Physics functions broadcast parameters against state arrays of
shape ``(n, ...)``, so the same code serves one environment, a vector of
environments, or ``n`` candidate models in an identification fit.

Invalid values raise :class:`ValueError` naming the class, the field, the symbol,
the unit and the violated bound -- never a NaN later in the physics.
"""

from __future__ import annotations

import dataclasses
from collections import namedtuple
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Literal, Self

import numpy as np

Tag = Literal["paper", "catalog", "derived", "proposed", "numerics"]
TAGS: tuple[str, ...] = ("paper", "catalog", "derived", "proposed", "numerics")


def param(
    default: Any = dataclasses.MISSING,
    *,
    symbol: str,
    unit: str,
    source: str,
    tag: Tag,
    lower: float | None = None,
    upper: float | None = None,
    strict_lower: bool = False,
    doc: str = "",
) -> Any:
    """Declare a documented parameter field.

    Args:
        default: default value in SI units; omitted for a generic component's field whose value depends on the
            device (a device package then declares a subclass that sets it, with the device's source).
        symbol: symbol as written in the papers (e.g. ``"k_t"``).
        unit: SI unit (``"N m/A"``); ``"-"`` for dimensionless.
        source: where the value comes from, e.g. ``"vsaUT-II Table II"``.
        tag: provenance class, one of :data:`TAGS`.
        lower, upper: inclusive bounds checked on construction.
        strict_lower: if true the lower bound is exclusive (``value > lower``).
        doc: one-line meaning.
    """
    if tag not in TAGS:
        raise ValueError(f"unknown tag {tag!r}; use one of {TAGS}")
    meta = {
        "symbol": symbol,
        "unit": unit,
        "source": source,
        "tag": tag,
        "lower": lower,
        "upper": upper,
        "strict_lower": strict_lower,
        "doc": doc,
    }
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


@dataclasses.dataclass(frozen=True)
class ParameterSet:
    """Base class of all parameter dataclasses (subclass with ``frozen=True``).

    Values are validated and normalised on construction: scalars stay Python
    floats, sequences become read-only ``float64`` arrays of shape ``(n,)``.
    All batched fields of one set must share the same ``n``.
    """

    def __post_init__(self) -> None:
        n_batch: int | None = None
        batch_field = ""
        for f in dataclasses.fields(self):
            if "symbol" not in f.metadata:
                continue
            raw = getattr(self, f.name)
            value = _normalise(type(self).__name__, f, raw)
            if isinstance(value, np.ndarray):
                if n_batch is not None and value.shape[0] != n_batch:
                    raise ValueError(
                        f"{type(self).__name__}.{f.name}: batch size {value.shape[0]} differs from "
                        f"{batch_field} ({n_batch}); all batched parameters must share one size"
                    )
                n_batch, batch_field = value.shape[0], f.name
            object.__setattr__(self, f.name, value)

    # ------------------------------------------------------------------ introspection
    @classmethod
    def describe(cls) -> list[dict[str, Any]]:
        """One row per parameter: name, symbol, unit, default, source, tag, doc."""
        rows = []
        for f in dataclasses.fields(cls):
            if "symbol" not in f.metadata:
                continue
            m = f.metadata
            rows.append(
                {
                    "name": f.name,
                    "symbol": m["symbol"],
                    "unit": m["unit"],
                    "default": None if f.default is dataclasses.MISSING else f.default,
                    "source": m["source"],
                    "tag": m["tag"],
                    "doc": m["doc"],
                }
            )
        return rows

    @classmethod
    def markdown_table(cls) -> str:
        """The parameter table as markdown (used in reports and docs)."""
        lines = ["| name | symbol | unit | default | tag | source |", "|---|---|---|---|---|---|"]
        for r in cls.describe():
            default = "required" if r["default"] is None else f"{r['default']:.6g}"
            lines.append(
                f"| `{r['name']}` | {r['symbol']} | {r['unit']} | {default} | {r['tag']} | {r['source']} |"
            )
        return "\n".join(lines)

    def field_names(self) -> list[str]:
        return [f.name for f in dataclasses.fields(self) if "symbol" in f.metadata]

    # ------------------------------------------------------------------ batching
    @property
    def batch_size(self) -> int | None:
        """``n`` if any field (or nested set) is batched, else ``None``."""
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                return int(v.shape[0])
            if isinstance(v, ParameterSet) and v.batch_size is not None:
                return v.batch_size
        return None

    @classmethod
    def variant(
        cls,
        name: str,
        module: str,
        doc: str,
        values: Mapping[str, float],
        *,
        source: str | Mapping[str, str],
        tag: Tag,
    ) -> type[Self]:
        """A subclass of this (generic) component whose fields in ``values`` default to a device's numbers.

        Symbol, unit, bounds and meaning stay the component's; ``source`` (one string, or one per field) and
        ``tag`` replace its generic provenance, so the device's parameter tables name where each number comes
        from.  The subclass is named ``name`` in ``module`` (assign it there under that name: pickling finds it)
        and shares the component's compiled named tuple type (:meth:`as_tuple`).
        """
        known = {f.name: f for f in dataclasses.fields(cls) if "symbol" in f.metadata}
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ValueError(f"{cls.__name__}.variant({name!r}): unknown fields {unknown}; fields: {sorted(known)}")
        fields = []
        for key, value in values.items():
            meta = dict(known[key].metadata)
            meta["source"] = source if isinstance(source, str) else source[key]
            meta["tag"] = tag
            fields.append((key, float, dataclasses.field(default=float(value), metadata=meta)))
        sub = dataclasses.make_dataclass(name, fields, bases=(cls,), frozen=True, namespace={"__doc__": doc})
        sub.__module__ = module
        return sub

    def replace(self, **changes: Any) -> Self:
        """A copy with some fields changed (validated)."""
        unknown = set(changes) - set(f.name for f in dataclasses.fields(self))
        if unknown:
            raise ValueError(f"{type(self).__name__} has no field(s) {sorted(unknown)}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, ParameterSet):
                out[f.name] = v.to_dict()
            elif isinstance(v, np.ndarray):
                out[f.name] = v.tolist()
            else:
                out[f.name] = v
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Self:
        kwargs: dict[str, Any] = {}
        names = {f.name: f for f in dataclasses.fields(cls)}
        for key, value in data.items():
            if key not in names:
                raise ValueError(f"{cls.__name__} has no field {key!r}")
            sub = _nested_type(cls, key)
            if sub is not None and isinstance(value, Mapping):
                kwargs[key] = sub.from_dict(value)
            else:
                kwargs[key] = value
        return cls(**kwargs)

    def index(self, i: int) -> Self:
        """The ``i``-th parameter set of a batch (scalars are shared)."""
        changes: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                changes[f.name] = float(v[i])
            elif isinstance(v, ParameterSet):
                changes[f.name] = v.index(i)
        return dataclasses.replace(self, **changes)

    def broadcast(self, n: int) -> Self:
        """Every field as an array of shape ``(n,)``."""
        changes: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, ParameterSet):
                changes[f.name] = v.broadcast(n)
            elif "symbol" in f.metadata:
                arr = np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()
                changes[f.name] = arr
        return dataclasses.replace(self, **changes)

    @classmethod
    def stack(cls, sets: Sequence[Self]) -> Self:
        """Stack ``n`` parameter sets into one batched set of size ``n``."""
        if not sets:
            raise ValueError(f"{cls.__name__}.stack needs at least one parameter set")
        kwargs: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            values = [getattr(s, f.name) for s in sets]
            if isinstance(values[0], ParameterSet):
                kwargs[f.name] = type(values[0]).stack(values)
            elif "symbol" in f.metadata:
                kwargs[f.name] = np.array([float(np.asarray(v)) for v in values], dtype=np.float64)
            else:
                kwargs[f.name] = values[0]
        return cls(**kwargs)

    def as_tuple(self) -> tuple[Any, ...]:
        """The same values as an immutable named tuple (nested sets become nested tuples).

        Named tuples are what the compiled (numba) kernels take: the physics
        functions read ``p.<field>`` either way, so one implementation serves both.
        """
        cls = _field_owner(type(self))
        tuple_cls = _TUPLE_TYPES.get(cls)
        names = [f.name for f in dataclasses.fields(self)
                 if "symbol" in f.metadata or isinstance(getattr(self, f.name), ParameterSet)]
        if tuple_cls is None:
            # defined as a module attribute so pickle (numba's on-disk cache) can find it again
            tuple_cls = namedtuple(f"{cls.__name__}Tuple", names)  # type: ignore[misc]
            tuple_cls.__module__ = __name__
            globals()[tuple_cls.__name__] = tuple_cls
            _TUPLE_TYPES[cls] = tuple_cls
        values = []
        for name in names:
            v = getattr(self, name)
            values.append(v.as_tuple() if isinstance(v, ParameterSet) else v)
        return tuple_cls(*values)

    def __iter__(self) -> Iterator[tuple[str, Any]]:
        for name in self.field_names():
            yield name, getattr(self, name)


_TUPLE_TYPES: dict[type, Any] = {}


def _field_owner(cls: type) -> type:
    """The most basic class of ``cls``'s MRO with the same fields: a device's subclass that only sets the
    defaults of a generic component (an ``RE40Motor(DCMotorParams)``) shares the component's named tuple type,
    so the compiled kernels see one type whatever the device."""
    names = [f.name for f in dataclasses.fields(cls)]
    owner = cls
    for base in cls.__mro__[1:]:
        if base is ParameterSet or not dataclasses.is_dataclass(base):
            break
        if [f.name for f in dataclasses.fields(base)] != names:
            break
        owner = base
    return owner


def _nested_type(cls: type, name: str) -> type[ParameterSet] | None:
    for f in dataclasses.fields(cls):
        if f.name == name and f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
            proto = f.default_factory()  # type: ignore[misc]
            if isinstance(proto, ParameterSet):
                return type(proto)
    return None


def _normalise(owner: str, f: dataclasses.Field[Any], raw: Any) -> float | np.ndarray:
    m = f.metadata
    where = f"{owner}.{f.name} ({m['symbol']}, {m['unit']})"
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: not a number: {raw!r}") from exc
    if arr.ndim > 1:
        raise ValueError(f"{where}: expected a scalar or a 1-D batch, got shape {arr.shape}")
    if arr.ndim == 1 and arr.shape[0] == 0:
        raise ValueError(f"{where}: empty batch")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{where}: must be finite, got {raw!r}")
    lo, hi = m["lower"], m["upper"]
    if lo is not None:
        bad = arr <= lo if m["strict_lower"] else arr < lo
        if np.any(bad):
            op = ">" if m["strict_lower"] else ">="
            raise ValueError(f"{where}: must be {op} {lo}, got {raw!r}")
    if hi is not None and np.any(arr > hi):
        raise ValueError(f"{where}: must be <= {hi}, got {raw!r}")
    if arr.ndim == 0:
        return float(arr)
    out = arr.copy()
    out.setflags(write=False)
    return out


def as_batch(name: str, value: Any, n: int | None = None, width: int | None = None) -> np.ndarray:
    """Validate an input array and return it as float64 of shape ``(n,)`` or ``(n, width)``.

    Raises ``ValueError`` naming ``name`` for a wrong shape or a non-finite entry
    (and which component / row is bad), so that bad input never reaches the physics.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: not numeric: {value!r}") from exc
    if width is None:
        if arr.ndim == 0 and n is not None:
            arr = np.full(n, float(arr))
        if arr.ndim != 1 or (n is not None and arr.shape[0] != n):
            raise ValueError(f"{name}: expected shape ({n if n is not None else 'n'},), got {arr.shape}")
    else:
        if arr.ndim == 1 and arr.shape[0] == width and (n is None or n == 1):
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != width or (n is not None and arr.shape[0] != n):
            raise ValueError(
                f"{name}: expected shape ({n if n is not None else 'n'}, {width}), got {arr.shape}"
            )
    bad = ~np.isfinite(arr)
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        raise ValueError(f"{name}: non-finite value {arr[tuple(idx)]!r} at index {tuple(int(i) for i in idx)}")
    return arr
