"""Parameter sets of the eLPAS actuator (eLPAS paper Table 1 + proposed geometry and vehicle).

The classes nest: :class:`ElpasParams` holds the motor (:class:`DCMotorParams`
built with the eLPAS Table 1 numbers), the LuGre friction at the motor shaft
(:class:`LuGreParams`, as :data:`ElpasFriction`), the reductor and inertias (:class:`DriveParams`), the
3-D cone geometry (:class:`ConeGeometry`) and the quarter-car / cabin corner
(:class:`QuarterCarParams`).  Every field is documented (symbol, SI unit,
source, tag); any field may be an ``(n,)`` array to batch ``n`` devices.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vsa_gym.physics.dc_motor import DCMotorParams
from vsa_gym.physics.friction import LuGreParams
from vsa_gym.physics.parameters import ParameterSet, param
from vsa_gym.physics.sensors import AbsoluteEncoder, IncrementalEncoder

GRAVITY = 9.81
"""Gravitational acceleration (m/s^2) used by the vehicle model."""


def elpas_motor() -> DCMotorParams:
    """The eLPAS brushless DC motor and its 42 V / 75 A amplifier (eLPAS Table 1, eqs. 1-4).

    ``J`` is the eLPAS ``J_r = 0.70 kg m^2`` reflected to the motor shaft
    (``J_r / N^2``); the model uses :attr:`DriveParams.J_r` as the *total*
    inertia about gamma and does not add ``J`` again.  ``b = 0``: the viscous
    friction of motor and reductor is the LuGre ``s_2``.
    """
    return ElpasMotorParams()


ElpasMotorEncoder = IncrementalEncoder.variant(
    "ElpasMotorEncoder", __name__, "The motor's quadrature encoder: 2000 pulses/rev (proposed; the eLPAS paper names "
    "no encoder, this is the vsaUT-II's HEDL 5540).",
    {"pulses_per_rev": 2000.0}, source="proposed (eLPAS paper silent; vsaUT-II Sec. III-H encoder)", tag="proposed")
ElpasAlphaEncoder = AbsoluteEncoder.variant(
    "ElpasAlphaEncoder", __name__, "The absolute encoder of the cone angle alpha: 12 bit, no gain mismatch (proposed).",
    {"bits": 12.0, "gain_mismatch": 0.0}, source="proposed (eLPAS paper silent)", tag="proposed")
ElpasFriction = LuGreParams.variant(
    "ElpasFriction", __name__, "LuGre friction of the eLPAS at the motor shaft, before the reductor (eLPAS Table 1).",
    {"s0": 15.0, "s1": 0.1, "s2": 0.0042, "F_c": 0.2, "F_s": 0.555, "omega_s": 11.8},
    source="eLPAS Table 1", tag="paper")


@dataclasses.dataclass(frozen=True)
class ElpasMotorParams(DCMotorParams):
    """:class:`DCMotorParams` with the eLPAS Table 1 defaults (see :func:`elpas_motor`)."""

    L: float = param(2.5e-4, symbol="L", unit="H", source="eLPAS Table 1", tag="paper",
                     lower=0.0, strict_lower=True, doc="armature inductance")
    R: float = param(0.13, symbol="R", unit="ohm", source="eLPAS Table 1", tag="paper",
                     lower=0.0, strict_lower=True, doc="armature resistance")
    k_t: float = param(0.095, symbol="K_T", unit="N m/A", source="eLPAS Table 1, eq. 4", tag="paper",
                       lower=0.0, strict_lower=True, doc="torque constant")
    k_e: float = param(0.095, symbol="K_E", unit="V s/rad", source="eLPAS Table 1, eq. 2", tag="paper",
                       lower=0.0, strict_lower=True, doc="back-EMF constant")
    J: float = param(0.70 / 59.0**2, symbol="J_r/N^2", unit="kg m^2",
                     source="derived: eLPAS Table 1 J_r / N^2", tag="derived", lower=0.0,
                     strict_lower=True, doc="J_r reflected to the motor (information only)")
    b: float = param(0.0, symbol="b_m", unit="N m s/rad", source="eLPAS: viscous part is LuGre s_2",
                     tag="derived", lower=0.0, doc="extra rotor viscous friction (none)")
    U_max: float = param(42.0, symbol="U_max", unit="V", source="eLPAS Table 1 / Sec. 3.2", tag="paper",
                         lower=0.0, strict_lower=True, doc="amplifier voltage limit")
    I_max: float = param(75.0, symbol="I_max", unit="A", source="eLPAS Table 1", tag="paper",
                         lower=0.0, strict_lower=True, doc="amplifier current limit")


@dataclasses.dataclass(frozen=True)
class DriveParams(ParameterSet):
    """Reductor and inertia of the gamma drive (eq. 3: ``T_r = (K_T I - M_fric) N``)."""

    N: float = param(-59.0, symbol="N", unit="-", source="eLPAS Table 1", tag="paper",
                     doc="reductor ratio, omega_m = N dgamma/dt (negative: direction reverses)")
    J_r: float = param(0.70, symbol="J_r", unit="kg m^2", source="eLPAS Table 1", tag="paper",
                       lower=0.0, strict_lower=True,
                       doc="total inertia of motor + reductor + arm about the gamma axis")
    k_stop: float = param(2.0e5, symbol="k_stop", unit="N m/rad", source="bump stops of Sec. 5.3.1; "
                          "stiffness chosen so J_r/k_stop gives 530 rad/s", tag="proposed", lower=0.0,
                          doc="stiffness of the gamma end stops beyond +-gamma_max")
    d_stop: float = param(0.5, symbol="d_stop", unit="s/rad", source="Hunt-Crossley damping, chosen",
                          tag="proposed", lower=0.0,
                          doc="end-stop damping: moment k_stop p (1 + d_stop dp/dt), p = penetration")

    def __post_init__(self) -> None:
        super().__post_init__()
        if np.any(np.asarray(self.N) == 0.0):
            raise ValueError("DriveParams.N (N, -): reductor ratio must be nonzero")


@dataclasses.dataclass(frozen=True)
class ConeGeometry(ParameterSet):
    """3-D cone geometry of the eLPAS (parameters.md, eLPAS 'Not given -- proposals').

    Pivot O at the origin, wishbone along x rotating by alpha about y; motor M at
    distance ``a`` from O; cone apex H at height ``h`` above M (at alpha = 0); arm
    MS of radius ``r`` turned by gamma.  Compression spring of rate ``C_a`` and
    preload ``F_s0`` at the cone length ``L0 = sqrt(h^2 + r^2)``.  The reference set
    gives ``F_act(0, 0) = 2555 N`` (paper Sec. 5.3.4).
    """

    a: float = param(0.30, symbol="a", unit="m", source="parameters.md eLPAS reference set",
                     tag="proposed", lower=0.0, strict_lower=True, doc="pivot O to motor M along the wishbone")
    l: float = param(0.30, symbol="l", unit="m", source="parameters.md eLPAS reference set",
                     tag="proposed", lower=0.0, strict_lower=True, doc="wishbone length (O to force point)")
    h: float = param(0.25, symbol="h", unit="m", source="parameters.md eLPAS reference set",
                     tag="proposed", lower=0.0, strict_lower=True, doc="cone height HM")
    r: float = param(0.09, symbol="r", unit="m", source="parameters.md eLPAS reference set",
                     tag="proposed", lower=0.0, strict_lower=True, doc="arm radius MS")
    C_a: float = param(20e3, symbol="C_a", unit="N/m", source="parameters.md eLPAS reference set",
                       tag="proposed", lower=0.0, doc="spring rate")
    F_s0: float = param(2716.0, symbol="F_s^0", unit="N", source="parameters.md; gives F_act(0,0)=2555 N",
                        tag="proposed", lower=0.0, doc="spring precompression force at L0")
    gamma_max: float = param(1.5707963267948966, symbol="gamma_max", unit="rad",
                             source="eLPAS Sec. 5.3.1 (gamma in [-90, 90] deg)", tag="paper",
                             lower=0.0, strict_lower=True, doc="arm angle range (bump stops)")
    alpha_max: float = param(0.2617993877991494, symbol="alpha_max", unit="rad",
                             source="eLPAS Sec. 5.2 (alpha in [-15, 15] deg)", tag="paper",
                             lower=0.0, strict_lower=True, doc="wishbone angle range")


@dataclasses.dataclass(frozen=True)
class QuarterCarParams(ParameterSet):
    """Quarter car / cabin corner carried by the eLPAS (parameters.md proposal).

    The sprung mass hangs on the wishbone pivot O; the unsprung mass sits at the
    wishbone tip, ``y_u = y_s + l sin(alpha)``; the tyre is a unilateral spring.
    """

    m_s: float = param(260.4, symbol="m_s", unit="kg", source="parameters.md: 2555 N / g",
                       tag="proposed", lower=0.0, strict_lower=True, doc="sprung mass")
    m_u: float = param(40.0, symbol="m_u", unit="kg", source="parameters.md", tag="proposed",
                       lower=0.0, strict_lower=True, doc="unsprung mass")
    k_t: float = param(200e3, symbol="k_t", unit="N/m", source="parameters.md", tag="proposed",
                       lower=0.0, strict_lower=True, doc="tyre stiffness")
    c_p: float = param(1.2e3, symbol="c_p", unit="N s/m", source="parameters.md (optional damper)",
                       tag="proposed", lower=0.0, doc="damper parallel to the actuator (0 to remove)")
    J_w: float = param(0.6, symbol="J_w", unit="kg m^2", source="parameters.md", tag="proposed",
                       lower=0.0, doc="wishbone inertia about the pivot O")
    k_bump: float = param(5.0e4, symbol="k_bump", unit="N m/rad", source="chosen (suspension bump stops)",
                          tag="proposed", lower=0.0, doc="wishbone end-stop stiffness beyond +-alpha_max")
    d_bump: float = param(0.5, symbol="d_bump", unit="s/rad", source="Hunt-Crossley damping, chosen",
                          tag="proposed", lower=0.0, doc="wishbone end-stop damping")


@dataclasses.dataclass(frozen=True)
class ElpasEffects(ParameterSet):
    """Effects the nominal eLPAS lacks, run by the compiled core when their parameters are nonzero (all zero, the
    default, is the nominal model bit for bit).

    Arm hysteresis (Dahl, a stateful effect): a moment ``-h`` on the arm about gamma with
    ``dh/dt = (M_h omega - |omega| h) / phi_h`` (``omega = dgamma/dt``), i.e. Dahl's law
    ``sigma_h (omega - |omega| h / M_h)`` with ``sigma_h = M_h / phi_h``: a loop of half-height ``M_h`` whose
    branches saturate over the presliding angle ``phi_h``; a candidate cause of the hysteresis the paper sees as
    gamma -> 90 deg (wishbone bending).  Its state ``h`` is an extra state column of the core
    (:data:`~vsa_gym.devices.elpas.layout.EFFECT_STATE`), present when ``M_h > 0`` in some row.  It stores
    ``h^2 phi_h / (2 M_h)`` (in :func:`~vsa_gym.devices.elpas.model.stored_energy`) and dissipates
    ``|omega| h^2 / M_h >= 0`` (booked in the friction channel).  Keep ``|omega| h_sub / phi_h`` below 2.7
    (RK4's stability on the substep ``h_sub``).
    """

    M_h: float = param(0.0, symbol="M_h", unit="N m", source="identification effect", tag="proposed", lower=0.0,
                       doc="arm hysteresis (Dahl) about gamma: loop half-height (0: absent, no state column)")
    phi_h: float = param(0.01, symbol="phi_h", unit="rad", source="assumed presliding angle (M_h / sigma_h = "
                         "20 N m / 2000 N m/rad, the former DahlHysteresis extension's defaults)", tag="proposed",
                         lower=0.0, strict_lower=True,
                         doc="arm hysteresis (Dahl): presliding angle M_h / sigma_h over which a branch saturates")


@dataclasses.dataclass(frozen=True)
class NumericsParams(ParameterSet):
    """Integration settings (not physics)."""

    dt: float = param(1e-3, symbol="dt", unit="s", source="control step of the envs", tag="numerics",
                      lower=0.0, strict_lower=True, doc="control step (zero-order hold of the voltage)")
    n_sub: float = param(4.0, symbol="n_sub", unit="-", source="tests/elpas/test_reference.py",
                         tag="numerics", lower=1.0,
                         doc="RK4 substeps per control step (h = 0.25 ms << L/R = 1.9 ms)")


@dataclasses.dataclass(frozen=True)
class ElpasParams(ParameterSet):
    """The whole eLPAS device (actuator + optional vehicle corner)."""

    motor: DCMotorParams = dataclasses.field(default_factory=elpas_motor)
    friction: LuGreParams = dataclasses.field(default_factory=ElpasFriction)
    drive: DriveParams = dataclasses.field(default_factory=DriveParams)
    cone: ConeGeometry = dataclasses.field(default_factory=ConeGeometry)
    car: QuarterCarParams = dataclasses.field(default_factory=QuarterCarParams)
    effects: ElpasEffects = dataclasses.field(default_factory=ElpasEffects)
    numerics: NumericsParams = dataclasses.field(default_factory=NumericsParams)

    def __post_init__(self) -> None:
        super().__post_init__()
        sizes = {
            name: getattr(self, name).batch_size
            for name in ("motor", "friction", "drive", "cone", "car", "effects")
        }
        batched = {k: v for k, v in sizes.items() if v is not None}
        if len(set(batched.values())) > 1:
            raise ValueError(f"ElpasParams: nested batch sizes differ: {batched}")
        if self.numerics.batch_size is not None:
            raise ValueError("ElpasParams.numerics (dt, n_sub) must be scalars, not batched")

    @classmethod
    def markdown_tables(cls) -> str:
        """All nested parameter tables as markdown (for the reproduction report)."""
        proto = cls()
        parts = []
        for f in dataclasses.fields(proto):
            sub = getattr(proto, f.name)
            parts.append(f"**{f.name}** ({type(sub).__name__})\n\n{type(sub).markdown_table()}")
        return "\n\n".join(parts)
