"""The eLPAS parameters packed for the compiled core: named tuples of arrays, one float64 matrix, row subsets.

The compiled functions cannot take an :class:`~vsa_gym.devices.elpas.params.ElpasParams` (a tree of dataclasses whose
fields are floats or ``(n,)`` arrays).  They take

* :func:`params_matrix`: one ``(n, N_PARAM_COLS)`` array, a row per batch row and a column per field in
  ``PARAM_GROUPS`` order -- what the compiled steps take (one array to unbox per call);
* :func:`params_tuple`: the module-level named tuples (:class:`ElpasT`) of ``(n,)`` arrays, whose fields a
  caller can change by name (the identification adapter's effects); :func:`tuple_matrix` turns it into the matrix.

Inside a compiled row loop, :func:`matrix_row_params` gives row ``i`` as an :class:`ElpasT` of scalars, which the
point equations (:mod:`vsa_gym.devices.elpas.equations`) read exactly as they read an ``ElpasParams``.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.params import ElpasParams
from vsa_gym.physics.parameters import ParameterSet


class MotorT(NamedTuple):
    """:class:`~vsa_gym.physics.dc_motor.DCMotorParams` fields (``(n,)`` arrays or, for one row, scalars)."""

    L: np.ndarray
    R: np.ndarray
    k_t: np.ndarray
    k_e: np.ndarray
    J: np.ndarray
    b: np.ndarray
    U_max: np.ndarray
    I_max: np.ndarray


class FrictionT(NamedTuple):
    """:class:`~vsa_gym.physics.friction.LuGreParams` fields."""

    s0: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    F_c: np.ndarray
    F_s: np.ndarray
    omega_s: np.ndarray


class DriveT(NamedTuple):
    """:class:`~vsa_gym.devices.elpas.params.DriveParams` fields (reductor, gamma end stops)."""

    N: np.ndarray
    J_r: np.ndarray
    k_stop: np.ndarray
    d_stop: np.ndarray


class ConeT(NamedTuple):
    """:class:`~vsa_gym.devices.elpas.params.ConeGeometry` fields."""

    a: np.ndarray
    l: np.ndarray
    h: np.ndarray
    r: np.ndarray
    C_a: np.ndarray
    F_s0: np.ndarray
    gamma_max: np.ndarray
    alpha_max: np.ndarray


class CarT(NamedTuple):
    """:class:`~vsa_gym.devices.elpas.params.QuarterCarParams` fields."""

    m_s: np.ndarray
    m_u: np.ndarray
    k_t: np.ndarray
    c_p: np.ndarray
    J_w: np.ndarray
    k_bump: np.ndarray
    d_bump: np.ndarray


class EffectsT(NamedTuple):
    """:class:`~vsa_gym.devices.elpas.params.ElpasEffects` fields (arm hysteresis)."""

    M_h: np.ndarray
    phi_h: np.ndarray


class ElpasT(NamedTuple):
    """The groups of :class:`~vsa_gym.devices.elpas.params.ElpasParams` read by the compiled core (numerics
    excepted)."""

    motor: MotorT
    friction: FrictionT
    drive: DriveT
    cone: ConeT
    car: CarT
    effects: EffectsT


PARAM_GROUPS: tuple[tuple[str, type], ...] = (("motor", MotorT), ("friction", FrictionT), ("drive", DriveT),
                                              ("cone", ConeT), ("car", CarT), ("effects", EffectsT))
"""The packed groups in column order, with their tuple classes (whose fields give the columns' order)."""
N_PARAM_COLS = sum(len(cls._fields) for _, cls in PARAM_GROUPS)  # 35


@register_jitable
def matrix_row_params(P: np.ndarray, i: int) -> ElpasT:
    """Row ``i`` of :func:`params_matrix` as the scalar named tuple (columns in ``PARAM_GROUPS`` order)."""
    r = P[i]
    return ElpasT(MotorT(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]),
                  FrictionT(r[8], r[9], r[10], r[11], r[12], r[13]),
                  DriveT(r[14], r[15], r[16], r[17]),
                  ConeT(r[18], r[19], r[20], r[21], r[22], r[23], r[24], r[25]),
                  CarT(r[26], r[27], r[28], r[29], r[30], r[31], r[32]),
                  EffectsT(r[33], r[34]))


def params_matrix(p: ElpasParams, n: int) -> np.ndarray:
    """The parameters as one ``(n, N_PARAM_COLS)`` float64 array, cached on ``p``.

    The compiled per-row steps take this instead of the named tuple of :func:`params_tuple`: numba
    unboxes one array per call instead of 33 (the tuple alone cost about 20 us per call).
    """
    t = p.__dict__.get("_nb_matrix")
    if t is None or t[0] != n:
        cols = [np.broadcast_to(np.asarray(getattr(getattr(p, g), f), dtype=np.float64), (n,))
                for g, cls in PARAM_GROUPS for f in cls._fields]
        t = (n, np.ascontiguousarray(np.stack(cols, axis=1)))
        object.__setattr__(p, "_nb_matrix", t)
    return t[1]


def params_tuple(p: ElpasParams, n: int) -> ElpasT:
    """The parameters as module-level named tuples of ``(n,)`` float64 arrays, cached on ``p``.

    Read-only by convention (cached): copy the arrays before changing them.
    """
    t = p.__dict__.get("_nb_tuple")
    if t is None or t[0] != n:
        def conv(ps: ParameterSet, cls: type) -> NamedTuple:
            return cls(*(np.array(np.broadcast_to(np.asarray(getattr(ps, f), dtype=np.float64), (n,)))
                         for f in cls._fields))

        t = (n, ElpasT(*(conv(getattr(p, g), cls) for g, cls in PARAM_GROUPS)))
        object.__setattr__(p, "_nb_tuple", t)
    return t[1]


def tuple_matrix(t: ElpasT) -> np.ndarray:
    """:func:`params_matrix` of a named tuple of ``(n,)`` arrays (:func:`params_tuple`, possibly changed)."""
    return np.ascontiguousarray(np.stack([np.asarray(a, dtype=np.float64) for g in t for a in g], axis=1))


def take_rows(p: ElpasParams, rows: np.ndarray) -> ElpasParams:
    """The parameter sets of the given batch rows (scalars are shared)."""

    def sub(ps: ParameterSet) -> ParameterSet:
        changes: dict[str, object] = {}
        for f in dataclasses.fields(ps):
            v = getattr(ps, f.name)
            if isinstance(v, ParameterSet):
                changes[f.name] = sub(v)
            elif isinstance(v, np.ndarray):
                changes[f.name] = v[rows]
        return dataclasses.replace(ps, **changes) if changes else ps

    return sub(p)  # type: ignore[return-value]
