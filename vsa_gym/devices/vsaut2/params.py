"""The vsaUT-II parameter set: every number of the model, with symbol, unit and source.

The nested component sets are those of :mod:`vsa_gym.physics`; this module fixes
their vsaUT-II values (Tables II and III, Sec. III) and adds the device-level
inertias, frictions and stops.  ``VsaUT2Params()`` is the nominal model.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from vsa_gym.devices.vsaut2.belt import BeltParams
from vsa_gym.devices.vsaut2.lever import LeverParams, pivot_for_stiffness
from vsa_gym.devices.vsaut2.pivot import PivotParams, sun_angle_for
from vsa_gym.physics.dc_motor import DCMotorParams
from vsa_gym.physics.gearbox import GearboxParams
from vsa_gym.physics.parameters import ParameterSet, param
from vsa_gym.physics.sensors import AbsoluteEncoder, IncrementalEncoder

_AMPLIFIER = {"U_max": "vsaUT-II Table IV row 17", "I_max": "vsaUT-II Table IV row 19"}

RE20Motor = DCMotorParams.variant(
    "RE20Motor", __name__, "Pivot motor, Maxon RE-20 (vsaUT-II Table II; the paper's text names an RE-25, Table II "
    "is used), on the 24 V / 12 A amplifier of Table IV.",
    {"L": 2.38e-4, "R": 2.19, "k_t": 2.34e-2, "k_e": 2.34e-2, "J": 1.07e-6, "b": 6.4e-6, "U_max": 24.0,
     "I_max": 12.0},
    source={**dict.fromkeys(("L", "R", "k_t", "k_e", "J", "b"), "vsaUT-II Table II (RE-20)"), **_AMPLIFIER},
    tag="paper")
RE40Motor = DCMotorParams.variant(
    "RE40Motor", __name__, "Frame motor, Maxon RE-40 (vsaUT-II Table II), on the 24 V / 12 A amplifier of Table IV.",
    {"L": 8.23e-5, "R": 0.317, "k_t": 3.02e-2, "k_e": 3.02e-2, "J": 1.38e-5, "b": 3.0e-6, "U_max": 24.0,
     "I_max": 12.0},
    source={**dict.fromkeys(("L", "R", "k_t", "k_e", "J", "b"), "vsaUT-II Table II (RE-40)"), **_AMPLIFIER},
    tag="paper")
GP26BGearbox = GearboxParams.variant(
    "GP26BGearbox", __name__, "Pivot gearhead, Maxon GP26B (vsaUT-II Table III).",
    {"n": 84.0, "tau_max": 1.3, "eta_max": 0.59, "alpha": 7.0, "J_in": 4e-8},
    source="vsaUT-II Table III (GP26B)", tag="paper")
GP42CGearbox = GearboxParams.variant(
    "GP42CGearbox", __name__, "Frame gearhead, Maxon GP42C (vsaUT-II Table III).",
    {"n": 156.0, "tau_max": 15.0, "eta_max": 0.72, "alpha": 7.0, "J_in": 9.1e-7},
    source="vsaUT-II Table III (GP42C)", tag="paper")


HEDL5540Encoder = IncrementalEncoder.variant(
    "HEDL5540Encoder", __name__, "The motors' quadrature encoders (HEDL 5540, 2000 pulses/rev; vsaUT-II Sec. III-H).",
    {"pulses_per_rev": 2000.0}, source="vsaUT-II Sec. III-H", tag="paper")
AS5043Encoder = AbsoluteEncoder.variant(
    "AS5043Encoder", __name__, "The output's absolute magnetic encoder (AS5043, 10 bit, +-0.15 deg gain mismatch; "
    "vsaUT-II Sec. III-H).",
    {"bits": 10.0, "gain_mismatch": float(np.deg2rad(0.15))}, source="vsaUT-II Sec. III-H", tag="paper")


def re20_motor() -> DCMotorParams:
    """Pivot motor: :class:`RE20Motor` with its defaults."""
    return RE20Motor()


def re40_motor() -> DCMotorParams:
    """Frame motor: :class:`RE40Motor` with its defaults."""
    return RE40Motor()


def gp26b_gearbox() -> GearboxParams:
    """Pivot gearhead: :class:`GP26BGearbox` with its defaults."""
    return GP26BGearbox()


def gp42c_gearbox() -> GearboxParams:
    """Frame gearhead: :class:`GP42CGearbox` with its defaults."""
    return GP42CGearbox()


@dataclasses.dataclass(frozen=True)
class VsaUT2Effects(ParameterSet):
    """Model effects found by identification (:mod:`vsa_gym.identify`), as parameters of the compiled core.

    Every default is zero = the effect is absent, and then the model is the nominal
    one exactly (each term adds ``0.0``).  Friction is smooth Coulomb + Stribeck,
    ``(F_c + F_s exp(-(w / w_s)^2)) tanh(w / w_eps)``, at a joint; backlash is a smooth
    dead zone of half-width ``b_belt`` on the belt stretch.  Effects that are plain
    parameter errors need no field here: inertia (``I_o``, ``I_ad``), viscous friction
    (``c_o``, ``c_ad``), spring stiffness (``lever.k``), belt compliance
    (``belt.C_belt``), gearbox efficiency (``frame_gearbox.eta_max``).

    Spring hysteresis (Dahl) is a stateful effect: a torque ``-h`` along the deflection ``phi`` (on the
    output, ``+h`` on the frame) with ``dh/dt = (M_h phi_dot - |phi_dot| h) / phi_h``, i.e. Dahl's law
    ``sigma_h (phi_dot - |phi_dot| h / M_h)`` with ``sigma_h = M_h / phi_h``: a loop of half-height ``M_h``
    whose branches saturate over the presliding deflection ``phi_h``.  Its state ``h`` is an extra state
    column (``"h_phi"``, :data:`~vsa_gym.devices.vsaut2.layout.EFFECT_STATE`) of the compiled core, present
    when ``M_h > 0`` in some row; with ``M_h = 0`` (the default) there is no such column and the model is the
    nominal one bit for bit.  It stores ``h^2 phi_h / (2 M_h)`` and dissipates ``|phi_dot| h^2 / M_h >= 0``
    (booked in the ``viscous`` power channel with the other friction effects).  ``mu_h`` makes the loop's
    half-height load-proportional, ``M = M_h + mu_h |tau_s|`` with ``tau_s`` the lever spring torque (friction in
    the spring mechanism that grows with the spring load: a loop of a fixed share of the torque at every
    stiffness, Table IV's "12 %"); ``M`` then replaces ``M_h`` in the law, the stored and the dissipated energy,
    and the energy book then misses the integral of ``h^2 phi_h dM/dt / (2 M^2)`` (the stored ``h^2 phi_h / (2 M)``
    changes with the load too): 0.05 J of 21 J dissipated on a 2 s random drive of the as-measured set.
    """

    F_c_o: float = param(0.0, symbol="F_c,o", unit="N m", source="identification effect", tag="proposed",
                         lower=0.0, doc="Coulomb friction at the output joint r (0: absent)")
    F_s_o: float = param(0.0, symbol="F_s,o", unit="N m", source="identification effect", tag="proposed",
                         lower=0.0, doc="Stribeck (static minus Coulomb) friction at the output joint (0: absent)")
    w_s_o: float = param(0.05, symbol="w_s,o", unit="rad/s", source="identification effect", tag="proposed",
                         lower=0.0, strict_lower=True, doc="Stribeck speed at the output joint")
    F_c_ad: float = param(0.0, symbol="F_c,ad", unit="N m", source="identification effect", tag="proposed",
                          lower=0.0, doc="Coulomb friction at the frame joint q2 (0: absent)")
    b_belt: float = param(0.0, symbol="b_belt", unit="m", source="identification effect", tag="proposed",
                          lower=0.0, doc="backlash half-width on the belt stretch (dead zone, 0: absent)")
    w_eps: float = param(1e-2, symbol="w_eps", unit="rad/s", source="smoothing of sign(w)", tag="numerics",
                         lower=0.0, strict_lower=True, doc="speed scale of the smooth Coulomb friction")
    b_eps: float = param(2e-6, symbol="b_eps", unit="m", source="smoothing of the dead zone", tag="numerics",
                         lower=0.0, strict_lower=True, doc="corner width of the smooth backlash dead zone")
    M_h: float = param(0.0, symbol="M_h", unit="N m", source="identification effect; Table IV row 11 (12 % torque "
                       "hysteresis) suggests M_h ~ 0.06 x the swept torque", tag="proposed", lower=0.0,
                       doc="spring hysteresis (Dahl) along the deflection: loop half-height (0: absent, no state "
                           "column)")
    phi_h: float = param(0.02, symbol="phi_h", unit="rad",
                         source="assumed presliding deflection (the paper gives none): about 3 AS5043 counts",
                         tag="proposed", lower=0.0, strict_lower=True,
                         doc="spring hysteresis (Dahl): presliding deflection M_h / sigma_h over which a branch "
                             "saturates (its pole |phi_dot| / phi_h must stay below 2.7 / h for RK4)")
    mu_h: float = param(0.0, symbol="mu_h", unit="-", source="as-measured variant: Table IV row 11 (12 % torque "
                        "hysteresis at every stiffness, i.e. a loop proportional to the spring torque)", tag="proposed",
                        lower=0.0, doc="spring hysteresis (Dahl): load-proportional loop half-height, the loop's "
                                       "half-height is M_h + mu_h |tau_spring| (0: absent; > 0 switches the state "
                                       "column on like M_h)")


@dataclasses.dataclass(frozen=True)
class VsaUT2Params(ParameterSet):
    """All parameters of the vsaUT-II model.

    Nested sets: ``pivot_motor`` (RE-20, Table II), ``pivot_gearbox`` (GP26B),
    ``frame_motor`` (RE-40), ``frame_gearbox`` (GP42C), ``pivot`` (planetary
    mechanism), ``lever`` (springs, stops; ``l`` calibrated), ``belt``, ``effects``
    (identified effects, all absent by default: :class:`VsaUT2Effects`).
    """

    pivot_motor: DCMotorParams = dataclasses.field(default_factory=re20_motor)
    pivot_gearbox: GearboxParams = dataclasses.field(default_factory=gp26b_gearbox)
    frame_motor: DCMotorParams = dataclasses.field(default_factory=re40_motor)
    frame_gearbox: GearboxParams = dataclasses.field(default_factory=gp42c_gearbox)
    pivot: PivotParams = dataclasses.field(default_factory=PivotParams)
    lever: LeverParams = dataclasses.field(default_factory=LeverParams)
    belt: BeltParams = dataclasses.field(default_factory=BeltParams)
    effects: VsaUT2Effects = dataclasses.field(default_factory=VsaUT2Effects)

    I_ad: float = param(1.2e-3, symbol="I_ad", unit="kg m^2", source="vsaUT-II Sec. III-F-1", tag="paper",
                        lower=0.0, strict_lower=True, doc="actuated device (frame) inertia about q2")
    c_ad: float = param(0.55, symbol="c_ad", unit="N m s/rad", source="vsaUT-II Sec. III-F-2, Fig. 9",
                        tag="paper", lower=0.0, doc="extra viscous friction at q2")
    I_o: float = param(1.1e-2, symbol="I_o", unit="kg m^2", source="vsaUT-II Sec. III-G-1 (test bar)",
                       tag="paper", lower=0.0, strict_lower=True, doc="output link inertia")
    c_o: float = param(1.2e-2, symbol="c", unit="N m s/rad", source="vsaUT-II Sec. III-G-2 (2 delta I_o)",
                       tag="paper", lower=0.0, doc="output viscous friction")
    K_min: float = param(0.7, symbol="K_min", unit="N m/rad", source="vsaUT-II Table IV row 9", tag="paper",
                         lower=0.0, strict_lower=True,
                         doc="minimum stiffness: sets the end of the pivot stroke q1_max")
    q2_max: float = param(np.deg2rad(28.6), symbol="q2_max", unit="rad",
                          source="active rotation angle +-28.6 deg, Table IV row 14", tag="derived",
                          lower=0.0, strict_lower=True, doc="frame end stops")
    K_q2: float = param(2000.0, symbol="K_q2", unit="N m/rad", source="frame end-stop stiffness",
                        tag="proposed", lower=0.0, doc="frame end-stop stiffness")
    D_q2: float = param(5.0, symbol="D_q2", unit="N m s/rad", source="frame end-stop damping", tag="proposed",
                        lower=0.0, doc="frame end-stop damping")
    K_s1: float = param(1.0, symbol="K_s1", unit="N m/rad", source="pivot stroke stop stiffness at the motor",
                        tag="proposed", lower=0.0, doc="pivot-stroke stop stiffness (motor shaft)")
    D_s1: float = param(2e-3, symbol="D_s1", unit="N m s/rad", source="pivot stroke stop damping",
                        tag="proposed", lower=0.0, doc="pivot-stroke stop damping (motor shaft)")

    # ------------------------------------------------------------------ named sets
    @classmethod
    def as_measured(cls) -> VsaUT2Params:
        """The as-measured vsaUT-II: nominal plus the named effects fitted to the paper's measured figures
        (Table IV's 12 % torque hysteresis, Fig. 10's 0.77 s period and 0.56 decrement, the 948 N m/rad maximum
        stiffness) by :func:`vsa_gym.devices.vsaut2.as_measured.fit_as_measured`, whose module documents which
        figure sets which parameter; ``tests/vsaut2/test_as_measured.py`` re-runs the fit against these numbers."""
        p = cls()
        return dataclasses.replace(
            p, I_o=AS_MEASURED["I_o"], c_o=AS_MEASURED["c_o"],
            belt=dataclasses.replace(p.belt, C_belt=AS_MEASURED["belt.C_belt"]),
            effects=dataclasses.replace(p.effects, mu_h=AS_MEASURED["effects.mu_h"],
                                        phi_h=AS_MEASURED["effects.phi_h"]))

    @classmethod
    def named(cls, name: str) -> VsaUT2Params:
        """The parameter set of that name (:data:`PARAMETER_SETS`): ``"nominal"`` or ``"as_measured"``."""
        if name not in PARAMETER_SETS:
            raise ValueError(f"unknown vsaUT-II parameter set {name!r}; valid names: {', '.join(PARAMETER_SETS)}")
        return cls() if name == "nominal" else cls.as_measured()

    @classmethod
    def resolve(cls, params: Any) -> VsaUT2Params:
        """``params`` as a set: ``None`` (nominal), a name of :data:`PARAMETER_SETS`, or a :class:`VsaUT2Params`."""
        if params is None:
            return cls()
        if isinstance(params, str):
            return cls.named(params)
        if not isinstance(params, VsaUT2Params):
            raise TypeError(f"params must be a VsaUT2Params or one of the names {PARAMETER_SETS}, "
                            f"got {type(params).__name__}")
        return params

    # ------------------------------------------------------------------ derived quantities
    @property
    def q1_max(self) -> float | np.ndarray:
        """End of the pivot stroke: where the spring stiffness (eq. 6) equals ``K_min`` (m)."""
        return pivot_for_stiffness(self.lever, self.K_min)

    @property
    def theta1_max(self) -> float | np.ndarray:
        """Pivot motor angle at the soft end of the stroke (rad); the stiff end is 0."""
        return self.pivot_gearbox.n * sun_angle_for(self.pivot, self.q1_max)

    @property
    def frame_ratio(self) -> float | np.ndarray:
        """Frame motor angle per frame angle, ``n_GP42C z_out / z_in`` (226.9)."""
        return self.frame_gearbox.n * self.belt.z_out / self.belt.z_in


#: The named parameter sets of ``VsaUT2Params.named`` (and ``gym.make(id, params=NAME)``).
PARAMETER_SETS = ("nominal", "as_measured")
#: The as-measured set's fitted numbers (SI; :mod:`vsa_gym.devices.vsaut2.as_measured`): ``effects.mu_h`` from
#: Table IV row 11, ``I_o`` from Fig. 10's period, ``c_o`` from Fig. 10's decrement, ``belt.C_belt`` from Table IV
#: row 8; ``effects.phi_h`` is assumed (half an AS5043 count).
AS_MEASURED: dict[str, float] = {"effects.mu_h": 0.0870624, "effects.phi_h": 3e-3, "I_o": 1.050377e-2,
                                 "c_o": 1.114954e-2, "belt.C_belt": 574036.0}
