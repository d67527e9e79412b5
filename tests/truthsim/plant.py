"""Textbook physics of one electromechanical drive axis, in load coordinates (the truth model).

Everything is written at the load: a translational axis in m, m/s, N, kg; a rotational axis in
rad, rad/s, N m, kg m^2.  A motor quantity is reflected through the transmission ratio ``n``
(motor rad per load unit): rotor inertia ``m_m = J_m n^2``, motor force ``F_m = k_t n i = K i``,
motor position ``x_m = theta_m / n``.

Amplifier (state: winding current ``i`` in A)::

    voltage drive of a DC motor:   L di/dt = u - R i - K v_m          (u in V; back-EMF K v_m)
    current-mode amplifier:        tau_c di/dt = G_a u - i            (u in V or A; tau_c = 1/(2 pi f_bw))

Mesh (rotor -> transmission) with direction-dependent efficiency: the force the rotor puts into the
mesh is ``F_in = F_m - m_m a_m`` (motor force minus rotor inertia force); the mesh passes on::

    F_out = eta_f F_in      if F_in v_m > 0 (motor drives the load, forward)
    F_out = F_in / eta_b    if F_in v_m < 0 (load back-drives the motor)

The direction is decided by the sign of the mesh power, solved exactly (no smoothing); at
``v_m = 0`` the mesh can hold (irreversibility): no direction is consistent and the rotor stays.

Transmission, one of:

* rigid (default; the real shaft is stiff, its mode far above the excitation):
  ``x_m = x_l`` and one body ``m_l a = F_out - F_load``;
* compliant shaft: ``F_t = k_s (x_m - x_l) + c_s (v_m - v_l)``;
* backlash: a sharp dead zone of total width ``2 g`` in series with the shaft.  A massless node ``y``
  sits between the gap and the shaft; gap coordinate ``q = x_m - y``, penetration on side
  ``sigma = +-1``: ``p = sigma q - g``.  The teeth push, never pull::

      F_b = sigma max(0, k_b p + c_b dp/dt)   (p > 0),   F_b = 0 (p <= 0),
      F_s = k_s (y - x_l) + c_s (dy/dt - v_l),   F_b = F_s = F_t  (massless node)

  which fixes ``dy/dt`` uniquely (the contact force falls, the shaft force rises with ``dy/dt``).

Load force (state: Dahl force ``h``)::

    F_load = F_f(v_l) + h + F_0
    F_f(v) = sign(v) (F_c + F_s exp(-(|v| / v_s)^delta)) + b v        (v != 0)
    |F_f(0)| <= F_c + F_s                                              (stiction, set-valued)
    dh/dt = sigma_h (v_l - |v_l| h / F_h)                               (Dahl, |h| <= F_h)

``F_0`` is a constant force opposing +x (gravity ``m_g g`` on a vertical axis with +x up, or a
constant load force).  Stick/slip of the load and of the rotor (mesh holding) are modes of
:mod:`tests.truthsim.integrate`, whose transitions are located as events; the functions here
evaluate the vector field, the event functions and the mode decisions of one mode.

Energy bookkeeping (extra states, integrated with the motion): work in ``W_in`` (``u i`` for a
voltage drive, ``F_m v_m`` for a current amplifier), winding loss ``R i^2``, load friction
``F_f v_l``, mesh loss ``(F_in - F_out) v_m``, transmission damping (shaft, contact, and the
release of contact overlap), Dahl work ``h v_l``.
"""

from __future__ import annotations

import numba
import numpy as np

# parameter vector layout (all in load coordinates, SI)
M_L, M_M, B, F_C, F_S, V_S, DELTA, F_H, SIGMA, F_0, ETA_F, ETA_B, K_S, C_S, GAP, K_B, C_B = range(17)
AMP, K_F, R, L, G_A, TAU_C = range(17, 23)
N_PAR = 23
PAR_NAMES: tuple[str, ...] = ("m_l", "m_m", "b", "F_c", "F_s", "v_s", "delta", "F_h", "sigma_h", "F_0", "eta_f",
                              "eta_b", "k_s", "c_s", "g", "k_b", "c_b", "amp", "K", "R", "L", "G_a", "tau_c")
# state layout
X_L, V_L, X_M, V_M, Y_N, CUR, H_D, W_IN, W_R, W_FR, W_MESH, W_DAMP, W_DAHL = range(13)
N_ST = 13
N_EV = 6  # event functions: load (2), motor (2), backlash contact (2)


def param_vector(**kw: float) -> np.ndarray:
    """Parameter vector from keyword values (names :data:`PAR_NAMES`); defaults: no effect, rigid, eta = 1."""
    P = np.zeros(N_PAR)
    P[[V_S, DELTA, ETA_F, ETA_B, L, G_A, TAU_C]] = (1.0, 2.0, 1.0, 1.0, 1e-3, 1.0, 1e-3)
    for k, v in kw.items():
        P[PAR_NAMES.index(k)] = float(v)
    return P


@numba.njit(cache=True)
def is_rigid(P: np.ndarray) -> bool:
    return P[K_S] <= 0.0


@numba.njit(cache=True)
def is_lossy(P: np.ndarray) -> bool:
    return P[ETA_F] < 1.0 or P[ETA_B] < 1.0


@numba.njit(cache=True)
def load_discontinuous(P: np.ndarray) -> bool:
    """True when the load's equation changes at ``v_l = 0`` (stiction, or a lossy mesh on a rigid axis)."""
    return P[F_C] + P[F_S] > 0.0 or (is_rigid(P) and is_lossy(P))


@numba.njit(cache=True)
def motor_discontinuous(P: np.ndarray) -> bool:
    """True when the rotor's equation changes at ``v_m = 0`` (lossy mesh on a two-mass axis)."""
    return (not is_rigid(P)) and is_lossy(P)


@numba.njit(cache=True)
def mesh_out(P: np.ndarray, f_in: float, s: float) -> float:
    """Force (N) the mesh passes to the load side for input force ``f_in`` moving in direction ``s``."""
    if f_in * s > 0.0:
        return P[ETA_F] * f_in
    return f_in / P[ETA_B]


@numba.njit(cache=True)
def mesh_in(P: np.ndarray, f_t: float, s: float) -> float:
    """Force (N) the rotor must put into the mesh to transmit ``f_t`` while moving in direction ``s``."""
    if f_t * s > 0.0:
        return f_t / P[ETA_F]
    return P[ETA_B] * f_t


@numba.njit(cache=True)
def friction_slip(P: np.ndarray, v: float, s: float) -> float:
    """Load friction (N) while sliding in direction ``s``: ``s (F_c + F_s exp(-(|v|/v_s)^delta)) + b v``."""
    w = max(s * v, 0.0)
    f = P[F_C]
    if P[F_S] > 0.0:
        f += P[F_S] * np.exp(-((w / P[V_S]) ** P[DELTA]))
    return s * f + P[B] * v


@numba.njit(cache=True)
def motor_force(P: np.ndarray, x: np.ndarray, u: float) -> tuple[float, float, float, float]:
    """``(F_m, di/dt, work-in power, winding loss)`` of the amplifier (N, A/s, W, W)."""
    i = x[CUR]
    if P[AMP] == 0.0:
        di = (u - P[R] * i - P[K_F] * x[V_M]) / P[L]
        return P[K_F] * i, di, u * i, P[R] * i * i
    di = (P[G_A] * u - i) / P[TAU_C]
    return P[K_F] * i, di, P[K_F] * i * x[V_M], 0.0


@numba.njit(cache=True)
def transmission(P: np.ndarray, x: np.ndarray, contact: int) -> tuple[float, float, float]:
    """Two-mass transmission: ``(F_t, dy/dt, damping power)`` for backlash contact mode ``contact``.

    ``contact``: 0 no active contact (gap, or an overlap being released), +-1 teeth pushing on that side.
    """
    xl, vl, xm, vm = x[X_L], x[V_L], x[X_M], x[V_M]
    if P[GAP] <= 0.0:
        dv = vm - vl
        return P[K_S] * (xm - xl) + P[C_S] * dv, vm, P[C_S] * dv * dv
    ks, cs, kb, cb, g = P[K_S], P[C_S], P[K_B], P[C_B], P[GAP]
    y = x[Y_N]
    d = y - xl
    if contact == 0:
        yd = vl - ks * d / cs
        pd = cs * (yd - vl) ** 2
        q = xm - y
        pen = abs(q) - g
        if pen > 0.0:  # overlap being released at zero force: its stored energy is dissipated
            sg = 1.0 if q > 0.0 else -1.0
            pd += -kb * pen * sg * (vm - yd)
        return 0.0, yd, pd
    sg = float(contact)
    pen = sg * (xm - y) - g
    yd = (sg * kb * pen + cb * vm - ks * d + cs * vl) / (cb + cs)
    f = sg * kb * pen + cb * (vm - yd)
    return f, yd, cb * (vm - yd) ** 2 + cs * (yd - vl) ** 2


@numba.njit(cache=True)
def rhs(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray, out: np.ndarray) -> None:
    """Time derivative ``out`` of state ``x`` in mode ``mode = [s_l, s_m, contact]`` under held input ``u``.

    ``s_l``: load direction (+-1 sliding, 0 stuck); ``s_m``: rotor direction at the mesh (+-1, 0 held).
    """
    fm, di, p_in, p_r = motor_force(P, x, u)
    out[CUR] = di
    out[W_IN] = p_in
    out[W_R] = p_r
    vl = x[V_L]
    h = x[H_D]
    out[H_D] = P[SIGMA] * (vl - abs(vl) * h / P[F_H]) if P[F_H] > 0.0 else 0.0
    out[W_DAHL] = h * vl
    s_l = float(mode[0])
    if is_rigid(P):
        a = 0.0
        f_fr = 0.0
        loss = 0.0
        if mode[0] != 0:
            f_fr = friction_slip(P, vl, s_l)
            f_ld = f_fr + P[F_0] + h
            ml, mm = P[M_L], P[M_M]
            if is_lossy(P):
                if (ml * fm + mm * f_ld) * s_l >= 0.0:  # sign of F_in: forward mesh
                    a = (P[ETA_F] * fm - f_ld) / (ml + P[ETA_F] * mm)
                    f_in = fm - mm * a
                    loss = (f_in - P[ETA_F] * f_in) * vl
                else:
                    a = (fm / P[ETA_B] - f_ld) / (ml + mm / P[ETA_B])
                    f_in = fm - mm * a
                    loss = (f_in - f_in / P[ETA_B]) * vl
            else:
                a = (fm - f_ld) / (ml + mm)
        out[X_L] = vl
        out[V_L] = a
        out[X_M] = vl
        out[V_M] = a
        out[Y_N] = vl
        out[W_FR] = f_fr * vl
        out[W_MESH] = loss
        out[W_DAMP] = 0.0
        return
    ft, yd, pd = transmission(P, x, mode[2])
    vm = x[V_M]
    am = 0.0
    loss = 0.0
    if not is_lossy(P):
        am = (fm - ft) / P[M_M]
    elif mode[1] != 0:
        f_in = mesh_in(P, ft, float(mode[1]))
        am = (fm - f_in) / P[M_M]
        loss = (f_in - ft) * vm
    al = 0.0
    f_fr = 0.0
    if mode[0] != 0:
        f_fr = friction_slip(P, vl, s_l)
        al = (ft - f_fr - P[F_0] - h) / P[M_L]
    out[X_L] = vl
    out[V_L] = al
    out[X_M] = vm
    out[V_M] = am
    out[Y_N] = yd
    out[W_FR] = f_fr * vl
    out[W_MESH] = loss
    out[W_DAMP] = pd


@numba.njit(cache=True)
def transmitted_force(P: np.ndarray, x: np.ndarray, u: float, mode: np.ndarray) -> float:
    """Force (N) delivered to the load by the transmission (rigid axis: the mesh output)."""
    if not is_rigid(P):
        return transmission(P, x, mode[2])[0]
    if mode[0] == 0:  # at rest the mesh passes the motor force (static holding is not resolved here)
        return P[K_F] * x[CUR]
    tmp = np.empty(N_ST)
    rhs(P, x, u, mode, tmp)
    return P[M_L] * tmp[V_L] + friction_slip(P, x[V_L], float(mode[0])) + P[F_0] + x[H_D]


@numba.njit(cache=True)
def _load_indicators(P: np.ndarray, x: np.ndarray, mode: np.ndarray) -> tuple[float, float]:
    """Break-away margins ``(e+, e-)`` (N) of the load at rest; > 0: it starts to slide that way."""
    f_st = P[F_C] + P[F_S]
    other = P[F_0] + x[H_D]
    if is_rigid(P):
        fm = P[K_F] * x[CUR]
        if is_lossy(P):
            return mesh_out(P, fm, 1.0) - other - f_st, -(mesh_out(P, fm, -1.0) - other) - f_st
        return fm - other - f_st, -(fm - other) - f_st
    ft = transmission(P, x, mode[2])[0]
    return ft - other - f_st, -(ft - other) - f_st


@numba.njit(cache=True)
def _motor_indicators(P: np.ndarray, x: np.ndarray, mode: np.ndarray) -> tuple[float, float]:
    """Break-away margins ``(e+, e-)`` (N) of a rotor held by the mesh."""
    fm = P[K_F] * x[CUR]
    ft = transmission(P, x, mode[2])[0]
    return fm - mesh_in(P, ft, 1.0), -(fm - mesh_in(P, ft, -1.0))


@numba.njit(cache=True)
def events(P: np.ndarray, x: np.ndarray, mode: np.ndarray, ev: np.ndarray) -> None:
    """Event functions of the current mode; an event fires when one becomes > 0 (inactive: -1).

    0/1 load: ``-s_l v_l`` (sliding reverses) or the break-away margins; 2/3 rotor: the same at the mesh;
    4/5 backlash: ``min(k_b p, k_b p + c_b dp/dt)`` on each side in the gap (contact closes), or
    ``-sigma F_t`` in contact (teeth would pull: contact opens).
    """
    for j in range(N_EV):
        ev[j] = -1.0
    if load_discontinuous(P):
        if mode[0] != 0:
            ev[0] = -float(mode[0]) * x[V_L]
        else:
            ev[0], ev[1] = _load_indicators(P, x, mode)
    if motor_discontinuous(P):
        if mode[1] != 0:
            ev[2] = -float(mode[1]) * x[V_M]
        else:
            ev[2], ev[3] = _motor_indicators(P, x, mode)
    if P[GAP] > 0.0 and not is_rigid(P):
        if mode[2] == 0:
            kb, cb, g = P[K_B], P[C_B], P[GAP]
            y = x[Y_N]
            yd = x[V_L] - P[K_S] * (y - x[X_L]) / P[C_S]
            q = x[X_M] - y
            for j, sg in ((4, 1.0), (5, -1.0)):
                pen = sg * q - g
                ev[j] = min(kb * pen, kb * pen + cb * sg * (x[V_M] - yd))
        else:
            ev[4] = -float(mode[2]) * transmission(P, x, mode[2])[0]


@numba.njit(cache=True)
def decide_load(P: np.ndarray, x: np.ndarray, mode: np.ndarray) -> None:
    """At ``v_l = 0``: set the speed to exactly zero and pick stick (0) or the consistent sliding direction."""
    x[V_L] = 0.0
    if is_rigid(P):
        x[V_M] = 0.0
    mode[0] = 0
    ep, em = _load_indicators(P, x, mode)
    if ep > 0.0:
        mode[0] = 1
    elif em > 0.0:
        mode[0] = -1


@numba.njit(cache=True)
def decide_motor(P: np.ndarray, x: np.ndarray, mode: np.ndarray) -> None:
    """At ``v_m = 0`` on a lossy two-mass axis: rotor held by the mesh (0) or moving (+-1)."""
    x[V_M] = 0.0
    mode[1] = 0
    ep, em = _motor_indicators(P, x, mode)
    if ep > 0.0:
        mode[1] = 1
    elif em > 0.0:
        mode[1] = -1


@numba.njit(cache=True)
def apply_event(P: np.ndarray, x: np.ndarray, mode: np.ndarray, j: int) -> None:
    """Mode transition for the event function ``j`` that fired."""
    if j <= 1:
        decide_load(P, x, mode)
    elif j <= 3:
        decide_motor(P, x, mode)
    elif mode[2] == 0:
        mode[2] = 1 if j == 4 else -1
    else:
        mode[2] = 0


def stored_energy(P: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Kinetic + magnetic + elastic + potential energy (J) of states ``x`` (T, N_ST), relative to x_l = 0.

    ``E = m_l v_l^2/2 + m_m v_m^2/2 + L i^2/2 + k_s delta^2/2 + k_b p_+^2/2 + F_0 x_l``
    (rigid: ``(m_l + m_m) v^2 / 2``; the Dahl force is counted as dissipation, ``W_dahl``).
    """
    x = np.atleast_2d(x)
    e = 0.5 * P[M_L] * x[:, V_L] ** 2 + 0.5 * P[M_M] * x[:, V_M] ** 2 + P[F_0] * x[:, X_L]
    if P[AMP] == 0.0:
        e = e + 0.5 * P[L] * x[:, CUR] ** 2
    if P[K_S] > 0.0:
        if P[GAP] > 0.0:
            e = e + 0.5 * P[K_S] * (x[:, Y_N] - x[:, X_L]) ** 2
            pen = np.maximum(np.abs(x[:, X_M] - x[:, Y_N]) - P[GAP], 0.0)
            e = e + 0.5 * P[K_B] * pen**2
        else:
            e = e + 0.5 * P[K_S] * (x[:, X_M] - x[:, X_L]) ** 2
    return e


__all__ = ["N_EV", "N_PAR", "N_ST", "PAR_NAMES", "apply_event", "decide_load", "decide_motor", "events",
           "param_vector", "rhs", "stored_energy", "transmitted_force"]
