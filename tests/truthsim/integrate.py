"""Event-located RK4 integration of the truth plant, its sensor and the sampled PD controller.

Time stepping: the input is held over each sample interval ``dt`` (zero-order hold) and every
interval is cut into ``n_sub`` sub-steps ``h = dt / n_sub``.  Each sub-step is a classical RK4
step of the vector field *frozen in the current mode* (load direction / stuck, rotor direction /
held, backlash contact side / gap; see :mod:`tests.truthsim.plant`).  If an event function of the
mode changes sign over the step, the crossing is located by the Illinois (modified regula-falsi)
method on the step fraction ``theta`` (each trial re-integrates RK4 over ``theta h`` from the
step start, a 4th-order dense output) to ``|Delta theta| < 1e-10``; the state is advanced to the
crossing, the mode switched (e.g. ``v_l := 0`` and stick or the consistent sliding direction),
and the rest of the sub-step is integrated in the new mode.  No sign is regularised.

Sensor (at every sample ``t_k``, for the declared position output, motor side ``x_m`` or load
``x_l``)::

    y_k = Q( (1 + gain) x(t_k - D) + offset + n_k res )

``x(t_k - D)`` by cubic Hermite interpolation between stored samples from ``(x, v)`` (the axis is at
rest at its initial position before ``t = 0``), ``n_k`` white noise in counts, ``Q`` a floor or
round quantiser of step ``res``.

Closed loop (the EMPS ``pd_cascade`` law on the *measured* position ``q_k = y_k``)::

    u_k = clip(kp kv (ref_k - q_k) - kv (q_k - q_{k-2}) / (2 dt), -sat, sat) + ff_k,   q_{-1} = q_{-2} = q_0
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np

from tests.truthsim.plant import (
    AMP,
    C_B,
    C_S,
    CUR,
    DELTA,
    F_0,
    F_C,
    F_H,
    F_S,
    GAP,
    K_B,
    K_F,
    K_S,
    M_L,
    M_M,
    N_EV,
    N_ST,
    SIGMA,
    TAU_C,
    V_L,
    V_M,
    V_S,
    X_L,
    X_M,
    Y_N,
    B,
    L,
    R,
    apply_event,
    decide_load,
    decide_motor,
    events,
    load_discontinuous,
    motor_discontinuous,
    rhs,
    transmitted_force,
)

MAX_EVENTS = 24  # per sub-step; beyond it the rest of the sub-step is integrated without event location
THETA_TOL = 1e-10


@numba.njit(cache=True)
def _rk4(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray, h: float, out: np.ndarray,
         w: np.ndarray) -> None:
    """One RK4 step of size ``h`` from ``x`` into ``out``; ``w``: (5, N_ST) work space."""
    k1, k2, k3, k4, tmp = w[0], w[1], w[2], w[3], w[4]
    rhs(P, x, u, mode, k1)
    for j in range(N_ST):
        tmp[j] = x[j] + 0.5 * h * k1[j]
    rhs(P, tmp, u, mode, k2)
    for j in range(N_ST):
        tmp[j] = x[j] + 0.5 * h * k2[j]
    rhs(P, tmp, u, mode, k3)
    for j in range(N_ST):
        tmp[j] = x[j] + h * k3[j]
    rhs(P, tmp, u, mode, k4)
    for j in range(N_ST):
        out[j] = x[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])


@numba.njit(cache=True)
def _event_at(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray, h: float, j: int, shift: float,
              xt: np.ndarray, w: np.ndarray, ev: np.ndarray) -> float:
    _rk4(P, x, u, mode, h, xt, w)
    events(P, xt, mode, ev)
    return ev[j] - shift


@numba.njit(cache=True)
def _locate(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray, H: float, j: int, shift: float, fa: float,
            fb: float, xt: np.ndarray, w: np.ndarray, ev: np.ndarray) -> float:
    """Step fraction ``theta`` just past the first crossing of ``ev_j = shift`` (Illinois method)."""
    a, b = 0.0, 1.0
    if fa == 0.0:  # starts on the surface (e.g. just released at v = 0): probe whether it leaves it
        p = 1e-7
        fp = _event_at(P, x, u, mode, p * H, j, shift, xt, w, ev)
        if fp > 0.0:
            return p
        a, fa = p, fp
    side = 0
    for _ in range(80):
        if b - a < THETA_TOL:
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        fc = _event_at(P, x, u, mode, c * H, j, shift, xt, w, ev)
        if fc > 0.0:
            b, fb = c, fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a, fa = c, fc
            if side == 1:
                fb *= 0.5
            side = 1
    return b


@numba.njit(cache=True)
def _tolerances(P: np.ndarray, x: np.ndarray, mode: np.ndarray, tol: np.ndarray) -> None:
    """Round-off tolerance of each event function: 0 for a sliding speed (set exactly to 0 at a switch),
    ``1e-9`` of the force scale for the force-type functions (break-away margins, contact forces), so
    that a state left on a switching surface by round-off does not chatter between two modes."""
    f = P[F_C] + P[F_S] + abs(P[F_0]) + P[F_H] + abs(P[K_F] * x[CUR]) + 1e-300
    for j in range(N_EV):
        tol[j] = 1e-9 * f
    if mode[0] != 0:
        tol[0] = 0.0
    if mode[1] != 0:
        tol[2] = 0.0


@numba.njit(cache=True)
def advance(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray, H: float, w: np.ndarray,
            stats: np.ndarray) -> None:
    """Advance state ``x`` (in place) over ``H`` seconds with event location; ``stats``: [events, overflows]."""
    xe = np.empty(N_ST)
    xt = np.empty(N_ST)
    ev0 = np.empty(N_EV)
    ev1 = np.empty(N_EV)
    evt = np.empty(N_EV)
    tol = np.empty(N_EV)
    t_rem = H
    n_ev = 0
    while t_rem > 1e-15 * H:
        events(P, x, mode, ev0)
        _tolerances(P, x, mode, tol)
        if n_ev < MAX_EVENTS:
            j0 = -1
            for j in range(N_EV):
                if ev0[j] > tol[j]:
                    j0 = j
                    break
            if j0 >= 0:  # inconsistent start (simultaneous events): switch at once
                apply_event(P, x, mode, j0)
                n_ev += 1
                stats[0] += 1
                continue
        _rk4(P, x, u, mode, t_rem, xe, w)
        if n_ev >= MAX_EVENTS:
            stats[1] += 1
            x[:] = xe
            return
        events(P, xe, mode, ev1)
        best, jb = 2.0, -1
        for j in range(N_EV):
            if ev1[j] > tol[j] and ev0[j] <= tol[j]:
                th = _locate(P, x, u, mode, t_rem, j, tol[j], ev0[j] - tol[j], ev1[j] - tol[j], xt, w, evt)
                if th < best:
                    best, jb = th, j
        if jb < 0:
            x[:] = xe
            return
        _rk4(P, x, u, mode, best * t_rem, xt, w)
        x[:] = xt
        apply_event(P, x, mode, jb)
        n_ev += 1
        stats[0] += 1
        t_rem -= best * t_rem


@numba.njit(cache=True)
def _measure(k: int, X: np.ndarray, sens: np.ndarray, noise: float, dt: float) -> float:
    """Sensor reading at sample ``k`` from stored samples ``X[:k + 1]`` (see module docstring)."""
    ix, iv = (X_M, V_M) if sens[0] == 1.0 else (X_L, V_L)
    gain, offset, delay, res = sens[1], sens[2], sens[3], sens[4]
    tau = k * dt - delay
    if delay <= 0.0:
        xv = X[k, ix]
    elif tau <= 0.0:
        xv = X[0, ix]
    else:
        j = int(np.floor(tau / dt))
        if j >= k:
            j = k - 1
        s = tau / dt - j
        x0, x1, v0, v1 = X[j, ix], X[j + 1, ix], X[j, iv] * dt, X[j + 1, iv] * dt
        s2, s3 = s * s, s * s * s
        xv = ((2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * x1 + (s3 - s2) * v1)
    y = (1.0 + gain) * xv + offset + noise * res
    if res <= 0.0:
        return y
    if sens[5] == 0.0:
        return np.floor(y / res) * res
    return np.round(y / res) * res


@numba.njit(cache=True)
def run_kernel(P: np.ndarray, x0: np.ndarray, u_in: np.ndarray, ref: np.ndarray, ff: np.ndarray,
               ctrl: np.ndarray, sens: np.ndarray, noise: np.ndarray, dt: float, n_sub: int,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sampled run over ``T = len(u_in)`` samples.

    ``ctrl = [closed (0/1), kp, kv, sat]``; ``sens = [at_motor (0/1), gain, offset, delay, res,
    quantiser (0 floor, 1 round)]``.  Returns the states ``(T, N_ST)`` at the sample times, the applied
    input, the measured output, the transmitted force, the modes ``(T, 3)`` and ``[events, overflows]``.
    """
    T = u_in.shape[0]
    X = np.empty((T, N_ST))
    U = np.empty(T)
    Y = np.empty(T)
    FT = np.empty(T)
    MODES = np.empty((T, 3), dtype=np.int64)
    stats = np.zeros(2, dtype=np.int64)
    w = np.empty((5, N_ST))
    x = x0.copy()
    mode = np.array([1, 1, 0], dtype=np.int64)
    h = dt / n_sub
    for k in range(T):
        X[k] = x
        Y[k] = _measure(k, X, sens, noise[k], dt)
        if ctrl[0] == 1.0:
            q = Y[k]
            qm2 = Y[k - 2] if k >= 2 else Y[0]
            uk = ctrl[1] * ctrl[2] * (ref[k] - q) - ctrl[2] * (q - qm2) / (2.0 * dt)
            uk = min(max(uk, -ctrl[3]), ctrl[3]) + ff[k]
        else:
            uk = u_in[k]
        U[k] = uk
        if k == 0:
            if load_discontinuous(P):
                decide_load(P, x, mode)
            if motor_discontinuous(P):
                decide_motor(P, x, mode)
            X[0] = x
        FT[k] = transmitted_force(P, x, uk, mode)
        MODES[k] = mode
        for _ in range(n_sub):
            advance(P, x, uk, mode, h, w, stats)
    return X, U, Y, FT, MODES, stats


def substeps(P: np.ndarray, dt: float, v_max: float, target: float = 0.4, minimum: int = 2) -> int:
    """Sub-steps per sample keeping ``h lambda <= target`` for the fastest rate ``lambda`` (1/s) of the plant.

    Rates: electrical ``R/L`` and ``K / sqrt(L m)`` (voltage drive) or ``1/tau_c``; viscous ``b/m``;
    Stribeck slope ``delta F_s / (v_s m)``; Dahl ``sigma v_max / F_h`` and ``sqrt(sigma / m)``;
    shaft ``sqrt(k_s / m) + c_s / m``; backlash contact ``sqrt(k_b / m) + c_b / m``, gap relaxation
    ``k_s / c_s`` and node ``(k_b + k_s) / (c_b + c_s)`` (``m``: the smaller body).
    """
    two = P[K_S] > 0.0
    m_tot = P[M_L] + P[M_M]
    m = min(P[M_L], P[M_M]) if two else m_tot
    rates = [P[B] / m]
    if P[AMP] == 0.0:
        rates += [P[R] / P[L], P[K_F] / np.sqrt(P[L] * m_tot)]
    else:
        rates.append(1.0 / P[TAU_C])
    if P[F_S] > 0.0:
        rates.append(P[DELTA] * P[F_S] / (P[V_S] * m))
    if P[F_H] > 0.0:
        rates += [P[SIGMA] * v_max / P[F_H], np.sqrt(P[SIGMA] / m)]
    if two:
        rates.append(np.sqrt(P[K_S] / m) + P[C_S] / m)
        if P[GAP] > 0.0:
            rates += [np.sqrt(P[K_B] / m) + P[C_B] / m, P[K_S] / P[C_S], (P[K_B] + P[K_S]) / (P[C_B] + P[C_S])]
    lam = float(max(rates))
    return int(min(max(minimum, np.ceil(lam * dt / target)), 20000))


@dataclasses.dataclass
class SimResult:
    """Sampled run: states ``x (T, N_ST)`` (layout :mod:`tests.truthsim.plant`), applied input ``u``,
    measured output ``y``, transmitted force ``f_t``, modes ``(T, 3)``, sub-steps and event counts."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    y: np.ndarray
    f_t: np.ndarray
    modes: np.ndarray
    n_sub: int
    events: int
    overflows: int


def initial_state(P: np.ndarray, position: float, gap_position: float = 0.0) -> np.ndarray:
    """At rest at ``position`` (load), the motor ``gap_position`` (m or rad, |.| <= g) inside the backlash gap."""
    x0 = np.zeros(N_ST)
    x0[X_L] = x0[Y_N] = position
    x0[X_M] = position + (gap_position if P[GAP] > 0.0 else 0.0)
    return x0


def simulate(P: np.ndarray, dt: float, n: int, *, u: np.ndarray | None = None, ref: np.ndarray | None = None,
             ff: np.ndarray | None = None, controller: tuple[float, float, float] | None = None,
             sensor: tuple[int, float, float, float, float, int] = (0, 0.0, 0.0, 0.0, 0.0, 0),
             noise: np.ndarray | None = None, x0: np.ndarray | None = None, n_sub: int | None = None,
             v_max: float = 1.0) -> SimResult:
    """Simulate ``n`` samples of step ``dt`` (s); open loop from ``u`` or closed loop (``controller = (kp, kv,
    sat)``) from ``ref`` (+ ``ff``).  ``sensor = (at_motor, gain, offset, delay, resolution, quantiser)``;
    ``noise``: per-sample sensor noise in counts.  ``n_sub``: sub-steps (default :func:`substeps`)."""
    z = np.zeros(n)
    arr = lambda a: z if a is None else np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    ctrl = np.zeros(4) if controller is None else np.array([1.0, *controller], dtype=np.float64)
    ns = substeps(P, dt, v_max) if n_sub is None else int(n_sub)
    x_init = initial_state(P, 0.0) if x0 is None else np.asarray(x0, dtype=np.float64)
    X, U, Y, FT, MODES, stats = run_kernel(np.ascontiguousarray(P, dtype=np.float64), x_init.copy(), arr(u), arr(ref),
                                           arr(ff), ctrl, np.asarray(sensor, dtype=np.float64), arr(noise), float(dt),
                                           ns)
    t = np.round(np.arange(n) * dt, 12)
    return SimResult(t, X, U, Y, FT, MODES, ns, int(stats[0]), int(stats[1]))


__all__ = ["SimResult", "advance", "initial_state", "run_kernel", "simulate", "substeps"]
