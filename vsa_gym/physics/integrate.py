"""Fixed-step integration of the batched cores, and the stiff reference used to check it.

All device cores expose a right-hand side of the form::

    rhs(x) -> (dxdt, power)        x, dxdt: (n, n_states)   power: (n, n_channels)

where ``power`` holds instantaneous energy-flow channels (electrical power in,
dissipation, external work, ...).  :func:`rk4` integrates both together, so the
energy integrals reported by a step are consistent with the state update to the
integrator's own accuracy -- the environments' energy terms and the energy
balance tests rely on that.

Inputs are held constant over one call (zero-order hold at the control rate);
the call is split into ``n_sub`` classical Runge-Kutta-4 substeps.  The device
modules choose ``n_sub`` from their fastest time constant so that the step is
well inside RK4's stability region (|h lambda| < 2.7) and accurate to the
1e-3 bound checked against :func:`reference_solution`.

Components with a stiff *linear* decay ``dx_j/dt = -lam_j x_j + N_j(x)`` (a LuGre bristle, a
motor current behind its ``L/R`` pole) are integrated exactly in their linear part by the
exponential RK4 of Cox & Matthews (ETDRK4, :func:`exponential_rk4`); its weights
(:func:`etdrk4_weights`, from :func:`phi_functions`) are jitable and shared by the numpy step
and the compiled device cores, so the scheme is written once.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numba.extending import register_jitable
from scipy.integrate import solve_ivp

Rhs = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def rk4(rhs: Rhs, x: np.ndarray, dt: float, n_sub: int) -> tuple[np.ndarray, np.ndarray]:
    """Advance ``x`` by ``dt`` with ``n_sub`` RK4 substeps.

    Returns ``(x_new, energy)``: the state after ``dt`` and the time integral of
    each power channel over ``dt`` (J), both batched over the leading axis.
    """
    h = dt / n_sub
    energy: np.ndarray | None = None
    for _ in range(n_sub):
        k1, p1 = rhs(x)
        k2, p2 = rhs(x + 0.5 * h * k1)
        k3, p3 = rhs(x + 0.5 * h * k2)
        k4, p4 = rhs(x + h * k3)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        de = (h / 6.0) * (p1 + 2.0 * p2 + 2.0 * p3 + p4)
        energy = de if energy is None else energy + de
    assert energy is not None
    return x, energy


@register_jitable
def phi_functions(zeta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``exp(zeta)`` and ``phi_k(zeta) = (exp(zeta) - sum_{j<k} zeta^j / j!) / zeta^k`` for k = 1, 2, 3.

    ``phi_3`` from its Taylor series for ``|zeta| < 0.1`` (truncation < 1e-11
    relative) and from the closed form elsewhere; ``phi_2 = 1/2 + zeta phi_3`` and
    ``phi_1 = 1 + zeta phi_2`` by the exact recurrence, so nothing cancels at
    ``zeta -> 0`` (``zeta = 0`` gives 1, 1/2, 1/6).
    """
    z = np.asarray(zeta, dtype=np.float64)
    ez = np.exp(z)
    small = np.abs(z) < 0.1
    zl = np.where(small, 1.0, z)
    series = 1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z * (1.0 / 720.0 + z * (1.0 / 5040.0 + z / 40320.0))))
    p3 = np.where(small, series, (ez - 1.0 - zl - 0.5 * zl * zl) / (zl * zl * zl))
    p2 = 0.5 + z * p3
    p1 = 1.0 + z * p2
    return ez, p1, p2, p3


@register_jitable
def etdrk4_weights(lam: Any, h: float) -> tuple[Any, Any, Any, Any, Any, Any]:
    """ETDRK4 weights for decay rates ``lam`` (1/s, array) and step ``h``.

    Returns ``(e_half, w_half, e_full, f_u, f_ab, f_c)``: ``exp(-lam h/2)``, ``h/2 phi_1(-lam h/2)``,
    ``exp(-lam h)`` and the final-stage weights ``phi_1 - 3 phi_2 + 4 phi_3``, ``2 (phi_2 - 2 phi_3)``,
    ``4 phi_3 - phi_2`` at ``-lam h`` (Cox & Matthews 2002, eq. 26).  Shapes follow ``lam``.
    """
    e_half, p1_half, _, _ = phi_functions(-0.5 * h * lam)
    e_full, p1, p2, p3 = phi_functions(-h * lam)
    return e_half, 0.5 * h * p1_half, e_full, p1 - 3.0 * p2 + 4.0 * p3, 2.0 * (p2 - 2.0 * p3), 4.0 * p3 - p2


@register_jitable
def phi_scalar(z: float) -> tuple[float, float, float, float]:
    """:func:`phi_functions` of one float ``z``, without arrays: ``(exp(z), phi_1, phi_2, phi_3)``."""
    ez = np.exp(z)
    if abs(z) < 0.1:
        p3 = 1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z * (1.0 / 720.0 + z * (1.0 / 5040.0 + z / 40320.0))))
    else:
        p3 = (ez - 1.0 - z - 0.5 * z * z) / (z * z * z)
    p2 = 0.5 + z * p3
    return ez, 1.0 + z * p2, p2, p3


@register_jitable
def etdrk4_weights_scalar(lam: float, h: float) -> tuple[float, float, float, float, float, float]:
    """:func:`etdrk4_weights` for one decay rate ``lam`` (1/s, a float), without arrays.

    For a compiled row loop whose rate changes every substep (a Dahl or bristle state whose decay is ``sigma |v|``):
    the array form allocates its temporaries on each call, which costs more than the substep it serves.
    :func:`phi_scalar` holds the same expressions as :func:`phi_functions`; ``tests/test_integrate.py`` checks
    that both forms agree to round-off on both of its branches.
    """
    e_half, p1_half, _, _ = phi_scalar(-0.5 * h * lam)
    e_full, p1, p2, p3 = phi_scalar(-h * lam)
    return e_half, 0.5 * h * p1_half, e_full, p1 - 3.0 * p2 + 4.0 * p3, 2.0 * (p2 - 2.0 * p3), 4.0 * p3 - p2


def exponential_rk4(
    rhs: Rhs,
    x: np.ndarray,
    dt: float,
    n_sub: int,
    stiff: Sequence[int],
    rates: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """Exponential RK4 (ETDRK4, Cox & Matthews 2002) with a stiff linear decay on some components.

    For each component ``j`` in ``stiff`` the right-hand side is split as
    ``dx_j/dt = -lam_j x_j + N_j(x)`` with ``N_j = dx_j/dt + lam_j x_j``, where
    ``lam = rates(x)`` (shape ``(n, len(stiff))``, 1/s, >= 0) is evaluated at the
    start of each substep and held.  The linear part is integrated exactly through
    the phi-functions, so the scheme is stable for any ``lam h`` and exact when
    ``N`` is constant (an exact relaxation ``z -> z_ss + (z - z_ss) exp(-lam h)``
    with ``omega`` frozen is the special case of a constant ``N``).  The other
    components see ``lam = 0``, for which ETDRK4 *is* classical RK4.  The power
    channels are integrated with the RK4 weights over the same stages.

    Args:
        rhs: ``x -> (dxdt, power)`` with ``x`` of shape ``(n, n_states)`` and
            ``power`` of shape ``(n, n_channels)``.
        x: state ``(n, n_states)``.
        dt: step length (s), split into ``n_sub`` substeps.
        stiff: indices of the components with a stiff linear decay.
        rates: ``x -> lam``.

    Returns:
        ``(x_new, energy)``: the state after ``dt`` and the integral of every power
        channel over ``dt`` (J), shapes ``(n, n_states)`` and ``(n, n_channels)``.
    """
    if n_sub < 1:
        raise ValueError(f"n_sub must be >= 1, got {n_sub}")
    idx = np.asarray(stiff, dtype=np.intp)
    h = dt / n_sub
    energy: np.ndarray | None = None
    for _ in range(n_sub):
        lam = rates(x)
        e_half, w_half, e_full, f_u, f_ab, f_c = etdrk4_weights(lam, h)
        xs = x[:, idx]

        k1, q1 = rhs(x)
        n1 = k1[:, idx] + lam * xs
        xa = x + 0.5 * h * k1
        xa[:, idx] = e_half * xs + w_half * n1
        k2, q2 = rhs(xa)
        n2 = k2[:, idx] + lam * xa[:, idx]
        xb = x + 0.5 * h * k2
        xb[:, idx] = e_half * xs + w_half * n2
        k3, q3 = rhs(xb)
        n3 = k3[:, idx] + lam * xb[:, idx]
        xc = x + h * k3
        xc[:, idx] = e_half * xa[:, idx] + w_half * (2.0 * n3 - n1)
        k4, q4 = rhs(xc)
        n4 = k4[:, idx] + lam * xc[:, idx]
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x[:, idx] = e_full * xs + h * (f_u * n1 + f_ab * (n2 + n3) + f_c * n4)
        de = (h / 6.0) * (q1 + 2.0 * q2 + 2.0 * q3 + q4)
        energy = de if energy is None else energy + de
    assert energy is not None
    return x, energy


def reference_solution(
    rhs_factory: Callable[[int], Rhs],
    x0: np.ndarray,
    dt: float,
    n_steps: int,
    rtol: float = 1e-9,
    atol: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiff reference: ``scipy.integrate.solve_ivp`` (Radau) through the same inputs.

    ``rhs_factory(k)`` returns the right-hand side with the inputs of control
    step ``k`` applied (zero-order hold); Radau restarts at every control
    boundary so the input discontinuities are resolved exactly.  ``x0`` has shape
    ``(n_states,)`` (one trajectory).  Returns ``(states, energy)`` with shapes
    ``(n_steps + 1, n_states)`` and ``(n_steps + 1, n_channels)`` (energy cumulative).
    """
    x = np.asarray(x0, dtype=np.float64).copy()
    _, p0 = rhs_factory(0)(x[None, :])
    n_ch = p0.shape[1]
    states = [x.copy()]
    energies = [np.zeros(n_ch)]
    e = np.zeros(n_ch)
    ns = x.shape[0]
    first_step: float | None = None
    for k in range(n_steps):
        rhs = rhs_factory(k)

        def f(_t: float, y: np.ndarray, rhs: Rhs = rhs) -> np.ndarray:
            dx, p = rhs(y[None, :ns])
            return np.concatenate([dx[0], p[0]])

        sol = solve_ivp(f, (0.0, dt), np.concatenate([x, np.zeros(n_ch)]), method="Radau",
                        rtol=rtol, atol=atol, first_step=first_step)
        if not sol.success:
            raise RuntimeError(f"reference integration failed at step {k}: {sol.message}")
        y = sol.y[:, -1]
        # restart the next interval with the step size Radau settled on (no cold start each interval)
        first_step = min(float(np.diff(sol.t)[-1]) if sol.t.size > 1 else dt, dt) if sol.t.size > 1 else None
        x = y[:ns]
        e = e + y[ns:]
        states.append(x.copy())
        energies.append(e.copy())
    return np.array(states), np.array(energies)
