"""Generic compiled row steppers: classical RK4 and exponential RK4 (ETDRK4) over a device's point right-hand side.

The device contract is one *point right-hand side*::

    rhs(ctx, y, dy, pw) -> None

``y`` ``(n_states,)`` is one row's state, ``ctx`` whatever the device needs held over the step (its parameter
row, held inputs, ...: a tuple, passed through untouched), ``dy`` ``(n_states,)`` receives ``dy/dt`` and ``pw``
``(n_power,)`` the instantaneous power channels (``n_power`` may be 0).  ``rhs`` must be jitable
(``numba.extending.register_jitable`` or ``numba.njit``); the steppers are built once per device by
:func:`rk4_row_stepper` / :func:`etd_row_stepper` and are jitable themselves, so a device's compiled row loop
(serial, ``prange`` or, later, a GPU kernel) calls them per row, and with ``NUMBA_DISABLE_JIT=1`` the same code
runs as plain Python for debugging.

The arithmetic is that of :func:`vsa_gym.physics.integrate.rk4` and
:func:`vsa_gym.physics.integrate.exponential_rk4` (same operations in the same order), so the batched numpy
reference and the compiled rows agree to round-off; the weights come from
:func:`vsa_gym.physics.integrate.etdrk4_weights`.

Scratch arrays are the caller's (allocating small arrays per row costs more than the arithmetic): see the
``Args`` of the returned functions.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba.extending import register_jitable

PointRhs = Callable[[Any, np.ndarray, np.ndarray, np.ndarray], None]


def rk4_row_stepper(rhs: PointRhs) -> Callable[..., None]:
    """The classical RK4 stepper of one row over ``rhs`` (see the module docstring for the contract).

    Returns ``rk4_row(ctx, y, h, n_sub, k, q, yt, e)``: ``n_sub`` substeps of length ``h`` applied to ``y`` in
    place, each substep's energy (the RK4 quadrature of the power channels) added to ``e`` ``(n_power,)``.
    Scratch: ``k`` ``(4, n_states)``, ``q`` ``(4, n_power)``, ``yt`` ``(n_states,)``.
    """

    # inline="always": numba inlines the stepper into the device's row loop (as a call it cost about 5 % of a step)
    @register_jitable(inline="always")
    def rk4_row(ctx: Any, y: np.ndarray, h: float, n_sub: int, k: np.ndarray, q: np.ndarray, yt: np.ndarray,
                e: np.ndarray) -> None:
        nx = y.shape[0]
        npw = e.shape[0]
        for _ in range(n_sub):
            rhs(ctx, y, k[0], q[0])
            for j in range(nx):
                yt[j] = y[j] + 0.5 * h * k[0, j]
            rhs(ctx, yt, k[1], q[1])
            for j in range(nx):
                yt[j] = y[j] + 0.5 * h * k[1, j]
            rhs(ctx, yt, k[2], q[2])
            for j in range(nx):
                yt[j] = y[j] + h * k[2, j]
            rhs(ctx, yt, k[3], q[3])
            for j in range(nx):
                y[j] = y[j] + (h / 6.0) * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            for j in range(npw):
                e[j] = e[j] + (h / 6.0) * (q[0, j] + 2.0 * q[1, j] + 2.0 * q[2, j] + q[3, j])

    return rk4_row


def etd_row_stepper(rhs: PointRhs, stiff: tuple[int, ...]) -> Callable[..., None]:
    """The exponential RK4 stepper (Cox & Matthews 2002) of one row over ``rhs``, with a stiff linear decay
    ``dy_c/dt = -lam_s y_c + N_s(y)`` on the columns ``c = stiff[s]``.

    Returns ``etd_row(ctx, y, h, n_sub, lam, w, k, q, ya, yb, yc, nl, e)``: ``n_sub`` substeps of ``h`` applied to
    ``y`` in place with the decay rates ``lam`` ``(len(stiff),)`` (1/s) held over the call and their weights
    ``w = etdrk4_weights(lam, h)`` (computed by the caller, once when they are shared by many rows); the stiff
    columns are integrated exactly in their linear part, the others by classical RK4, the power channels by the
    RK4 quadrature, added to ``e``.  Scratch: ``k`` ``(4, n_states)``, ``q`` ``(4, n_power)``, ``ya``, ``yb``,
    ``yc`` ``(n_states,)``, ``nl`` ``(4, len(stiff))``.
    """
    n_stiff = len(stiff)

    @register_jitable(inline="always")
    def etd_row(ctx: Any, y: np.ndarray, h: float, n_sub: int, lam: np.ndarray, w: Any, k: np.ndarray,
                q: np.ndarray, ya: np.ndarray, yb: np.ndarray, yc: np.ndarray, nl: np.ndarray,
                e: np.ndarray) -> None:
        e_half, w_half, e_full, f_u, f_ab, f_c = w
        nx = y.shape[0]
        npw = e.shape[0]
        for _ in range(n_sub):
            rhs(ctx, y, k[0], q[0])
            for j in range(nx):
                ya[j] = y[j] + 0.5 * h * k[0, j]
            for s in range(n_stiff):
                c = stiff[s]
                nl[0, s] = k[0, c] + lam[s] * y[c]
                ya[c] = e_half[s] * y[c] + w_half[s] * nl[0, s]
            rhs(ctx, ya, k[1], q[1])
            for j in range(nx):
                yb[j] = y[j] + 0.5 * h * k[1, j]
            for s in range(n_stiff):
                c = stiff[s]
                nl[1, s] = k[1, c] + lam[s] * ya[c]
                yb[c] = e_half[s] * y[c] + w_half[s] * nl[1, s]
            rhs(ctx, yb, k[2], q[2])
            for j in range(nx):
                yc[j] = y[j] + h * k[2, j]
            for s in range(n_stiff):
                c = stiff[s]
                nl[2, s] = k[2, c] + lam[s] * yb[c]
                yc[c] = e_half[s] * ya[c] + w_half[s] * (2.0 * nl[2, s] - nl[0, s])
            rhs(ctx, yc, k[3], q[3])
            for s in range(n_stiff):
                c = stiff[s]
                nl[3, s] = k[3, c] + lam[s] * yc[c]
            for s in range(n_stiff):  # the stiff columns' update uses y at the start of the substep
                c = stiff[s]
                ya[c] = e_full[s] * y[c] + h * (f_u[s] * nl[0, s] + f_ab[s] * (nl[1, s] + nl[2, s])
                                                + f_c[s] * nl[3, s])
            for j in range(nx):
                y[j] = y[j] + (h / 6.0) * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
            for s in range(n_stiff):
                y[stiff[s]] = ya[stiff[s]]
            for j in range(npw):
                e[j] = e[j] + (h / 6.0) * (q[0, j] + 2.0 * q[1, j] + 2.0 * q[2, j] + q[3, j])

    return etd_row


# -- the tuple form: a pure point right-hand side over a row held in scalars
#
# The array form above passes the state through small scratch arrays; numba cannot prove that those arrays, the
# parameter row and the output do not overlap, so every stage stores to memory and reloads the parameters.  With
# the row held as a tuple of floats (a pure ``dy = rhs(ctx, y)``), LLVM keeps the whole substep in registers: about
# twice as fast on the generic drive (docs/performance.md, "the drive's row in registers").  The element-wise tuple
# expressions are written out for a given number of states (numba has no loop over a tuple that builds a tuple), from
# the templates below; the arithmetic is that of the array form, operation for operation, so both give the same bits.


def _generated(name: str, source: str, namespace: dict[str, Any], inline: bool = True) -> Callable[..., Any]:
    """Compile ``source`` (one ``def name``) in ``namespace`` and return it jitable (plain Python under
    ``NUMBA_DISABLE_JIT=1``), inlined into its callers or (``inline=False``) compiled once as a function of its own."""
    code = compile(source, f"<vsa_gym.physics.steppers.{name}>", "exec")
    exec(code, namespace)  # the source is this module's template, filled in with state indices only
    return register_jitable(inline="always" if inline else "never")(namespace[name])


def _each(n: int, item: str) -> str:
    """``item`` written out for ``j = 0 .. n - 1``, comma separated (the elements of a tuple expression)."""
    return ", ".join(item.format(j=j) for j in range(n))


def tuple_io(n_states: int) -> tuple[Callable[[np.ndarray], tuple[float, ...]], Callable[..., None]]:
    """``(load, store)`` for a row of ``n_states`` floats: ``load(a) -> (a[0], ..., a[n - 1])`` and ``store(a, y)``
    writing the tuple ``y`` back into the array ``a`` (jitable, inlined)."""
    items = _each(n_states, "a[{j}]")
    load = _generated("load", f"def load(a):\n    return ({items},)\n", {})
    store = _generated("store", f"def store(a, y):\n    {items}, = y\n", {})
    return load, store


def rk4_tuple_stepper(rhs: Callable[[Any, tuple[float, ...]], tuple[float, ...]], n_states: int,
                      inline: bool = True) -> Callable[..., tuple[float, ...]]:
    """The classical RK4 stepper of one row held as a tuple, over a pure point right-hand side.

    ``rhs(ctx, y) -> dy``: ``y`` and ``dy`` are tuples of ``n_states`` floats; ``ctx`` as in the array form.
    Returns ``rk4(ctx, y, h, n_sub) -> y``: ``n_sub`` substeps of length ``h`` (no power channels; a device with
    energy bookkeeping uses :func:`rk4_row_stepper`).  Same operations in the same order as :func:`rk4_row_stepper`:
    the stage sum ``k0 + 2 k1 + 2 k2 + k3`` is accumulated left to right as Python evaluates it there.  The four
    stages are a loop around one call of ``rhs``, so numba inlines (and types) the right-hand side once, not four
    times (four call sites made compiling the drive's roll-out several times slower).
    """
    n = n_states
    source = f"""def rk4(ctx, y, h, n_sub):
    for _ in range(n_sub):
        yt = y
        acc = y
        for stage in range(4):
            k = rhs(ctx, yt)
            if stage == 0:
                acc = k
                yt = ({_each(n, "y[{j}] + 0.5 * h * k[{j}]")},)
            elif stage == 1:
                acc = ({_each(n, "acc[{j}] + 2.0 * k[{j}]")},)
                yt = ({_each(n, "y[{j}] + 0.5 * h * k[{j}]")},)
            elif stage == 2:
                acc = ({_each(n, "acc[{j}] + 2.0 * k[{j}]")},)
                yt = ({_each(n, "y[{j}] + h * k[{j}]")},)
            else:
                acc = ({_each(n, "acc[{j}] + k[{j}]")},)
        y = ({_each(n, "y[{j}] + (h / 6.0) * acc[{j}]")},)
    return y
"""
    return _generated("rk4", source, {"rhs": rhs}, inline)


def etd_tuple_stepper(rhs: Callable[[Any, tuple[float, ...]], tuple[float, ...]], n_states: int, stiff: int,
                      inline: bool = True) -> Callable[..., tuple[float, ...]]:
    """The exponential RK4 stepper (:func:`etd_row_stepper`) of one row held as a tuple, with one stiff column.

    Returns ``etd(ctx, y, h, lam, w) -> y``: one substep of ``h`` with the decay rate ``lam`` (1/s) of column
    ``stiff`` and its weights ``w = etdrk4_weights_scalar(lam, h)`` (the caller takes both at the substep's start);
    the other columns by classical RK4.  Same operations in the same order as :func:`etd_row_stepper`; one call
    site of ``rhs``, as in :func:`rk4_tuple_stepper`.
    """
    n, c = n_states, stiff

    def stage_state(w: str, z: str) -> str:
        """The next stage's input: RK4's ``y + w k`` on the plain columns, ``z`` on the stiff one."""
        return ", ".join(z if j == c else f"y[{j}] + {w} * k[{j}]" for j in range(n))

    source = f"""def etd(ctx, y, h, lam, w):
    e_half, w_half, e_full, f_u, f_ab, f_c = w
    yt = y
    acc = y
    n0 = n1 = n2 = n3 = z_a = 0.0
    for stage in range(4):
        k = rhs(ctx, yt)
        nl = k[{c}] + lam * yt[{c}]
        if stage == 0:
            acc = k
            n0 = nl
            z_a = e_half * y[{c}] + w_half * n0
            yt = ({stage_state("0.5 * h", "z_a")},)
        elif stage == 1:
            acc = ({_each(n, "acc[{j}] + 2.0 * k[{j}]")},)
            n1 = nl
            yt = ({stage_state("0.5 * h", f"e_half * y[{c}] + w_half * n1")},)
        elif stage == 2:
            acc = ({_each(n, "acc[{j}] + 2.0 * k[{j}]")},)
            n2 = nl
            yt = ({stage_state("h", "e_half * z_a + w_half * (2.0 * n2 - n0)")},)
        else:
            acc = ({_each(n, "acc[{j}] + k[{j}]")},)
            n3 = nl
    z = e_full * y[{c}] + h * (f_u * n0 + f_ab * (n1 + n2) + f_c * n3)
    return ({", ".join("z" if j == c else f"y[{j}] + (h / 6.0) * acc[{j}]" for j in range(n))},)
"""
    return _generated("etd", source, {"rhs": rhs}, inline)
