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
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
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
