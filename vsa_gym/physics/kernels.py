"""Helpers that let one physics implementation run on column arrays (numpy) and on scalars (numba).

The physics functions of :mod:`vsa_gym.physics` are written once, element-wise.  The
numpy path calls them with ``(n,)`` columns; the compiled cores call them per row with
floats inside a numba loop over rows (no array temporaries).  Two things differ
between those worlds and are bridged here:

* :func:`select` -- ``np.where`` in Python; in numba a branch for a scalar condition
  (``np.where`` on scalars returns a 0-d array there) and ``np.where`` for arrays.  The
  value is the same either way, so results do not change.
* :func:`scalar_shortcut` -- ``False`` in Python and for arrays; the condition itself when
  compiled with a scalar one.  A physics function uses it to skip work on the per-row
  compiled path where the skipped formula is known to give exactly the shortcut's value
  (a stop far from contact, an effect whose parameters are zero); the numpy path always
  runs the full formula, so the two paths still agree bit for bit.
* :func:`flatten_rows` / :func:`row_reader` -- the parameters as one ``(m, n_leaves)``
  array (``m = 1``: shared by every row; one numba signature whether or not they are
  batched), and a jitable reader that rebuilds row ``i`` as the parameters' named tuple
  of floats, so the physics reads ``p.<field>`` as everywhere else.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import types
from numba.extending import overload, register_jitable


def select(cond: Any, a: Any, b: Any) -> Any:
    """``np.where(cond, a, b)``; a scalar branch when compiled with a scalar ``cond``."""
    return np.where(cond, a, b)


@overload(select)
def _select_nb(cond, a, b):  # type: ignore[no-untyped-def]  # (numba: no annotations on overloads)
    if isinstance(cond, types.Boolean):
        def impl_scalar(cond, a, b):  # type: ignore[no-untyped-def]
            return a if cond else b

        return impl_scalar

    def impl_array(cond, a, b):  # type: ignore[no-untyped-def]
        return np.where(cond, a, b)

    return impl_array


def scalar_shortcut(cond: Any) -> bool:
    """``False`` here (the numpy path runs the full formula); compiled: ``cond`` if it is a scalar, else ``False``."""
    return False


@overload(scalar_shortcut)
def _scalar_shortcut_nb(cond):  # type: ignore[no-untyped-def]  # (numba: no annotations on overloads)
    if isinstance(cond, types.Boolean):
        def impl_scalar(cond):  # type: ignore[no-untyped-def]
            return cond

        return impl_scalar

    def impl_array(cond):  # type: ignore[no-untyped-def]
        return False

    return impl_array


def _leaves(t: Any) -> list[Any]:
    if isinstance(t, tuple) and hasattr(t, "_fields"):
        return [leaf for v in t for leaf in _leaves(v)]
    return [t]


def flatten_rows(t: Any) -> np.ndarray:
    """The leaves of a (nested) named tuple of floats / ``(n,)`` arrays as one ``(m, n_leaves)`` float64 array.

    ``m`` is the batch size (1 when nothing is batched: the row is shared).  One array
    keeps the compiled call cheap (numba unboxes one argument instead of one per field).
    """
    cols = [np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in _leaves(t)]
    m = max(c.shape[0] for c in cols)
    return np.ascontiguousarray(np.stack([np.broadcast_to(c, (m,)) for c in cols], axis=1))


def row_reader(proto: Any) -> Any:
    """A jitable ``read(P, i)``: row ``i`` of :func:`flatten_rows` output rebuilt as ``proto``'s named tuple type.

    Works in Python too (then the leaves are floats).  ``proto`` fixes the nesting and the
    field order (that of :func:`flatten_rows`).
    """
    ns: dict[str, Any] = {}
    counter = [0]

    def build(t: Any) -> str:
        if isinstance(t, tuple) and hasattr(t, "_fields"):
            name = f"_cls{len(ns)}"
            ns[name] = type(t)
            return f"{name}({', '.join(build(v) for v in t)})"
        j = counter[0]
        counter[0] += 1
        return f"P[r, {j}]"

    expr = build(proto)
    # ``i - i`` (not 0): the index keeps the type of ``i`` (a prange index may be unsigned; unifying it
    # with a signed literal would give a float)
    src = f"def read(P, i):\n    r = i if P.shape[0] > 1 else i - i\n    return {expr}\n"
    exec(src, ns)  # noqa: S102 - fixed template over the tuple's own field structure
    return register_jitable(ns["read"])
