"""The generic drive's effect library (:mod:`vsa_gym.identify.library`): what
:class:`vsa_gym.devices.drive.adapter.DriveAdapter` may name, with bounds scaled to the record (``F_ref``: the peak
nominal drive force, ``v_ref``: the peak speed, ``x_ref``: the position spread, all of the nominal replay, or of
the measured position where that replay runs away, see ``RUNAWAY_SPREAD`` in
:mod:`vsa_gym.devices.drive.adapter`) and the magnitudes the synthetic drive records plant
(:mod:`vsa_gym.devices.drive.synthetic`).  The equations are the drive model's
(:mod:`vsa_gym.devices.drive.model`, parameter mapping in ``DriveAdapter.param_matrix``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vsa_gym.devices.drive.model import E_CORNER, F_CONTACT, ZETA_CONTACT
from vsa_gym.identify.library import Effect, Param

SYNTHETIC = "synthetic_drive"  # the experiment of vsa_gym.devices.drive.synthetic.make_drive_record
SOURCE = "a 2 kg axis driven at 10 N/V (synthetic records): friction of a few per cent of the drive force, " \
    "encoder-scale backlash, a 4-8 Hz transmission mode"


def _lin(a: Any) -> str:
    return a.units[0]


def _rot(a: Any) -> str:
    return a.units[1]


def _resolution(a: Any) -> float:
    """The position sensor's resolution (0 where the record does not give one)."""
    return max((s.resolution for s in a.outputs if s.quantity == "position"), default=0.0)


def _x_min(a: Any) -> float:
    """The smallest presliding travel that is a resolved regime and not a friction that sticks: a few sensor
    counts, or 2e-4 of the position spread."""
    return max(2e-4 * a.x_ref, 4.0 * _resolution(a))


#: friction that truly sticks, the drive model's ``sticks`` switch (exact stick-slip: set-valued at rest, its
#: mode changes located as events): held off (the tanh law, which creeps at a speed of order v_eps under any
#: force below the break-away) unless a stuck load validates better.  Real contacts stick: a closed loop at rest
#: then holds a steady position error that a creeping law runs down (case 11006 of
#: ``benchmarks.identify_truth --seed 11``: the true Stribeck friction validated at 300x the noise floor with the
#: tanh law).  A switch with one "on" value: there is nothing to fit once it is on (``ParamSpec.pinned``).
STICK = Param("sticks", "-", 1.0, 1.0, 0.0, 1.0, main=False, check_bound=False, optional=True)


def _k_typ(a: Any) -> float:
    """A typical transmission stiffness: a mode at 20 Hz on the largest reduced mass ``m / 4`` (frac_m = 0.5)."""
    return 4 * np.pi**2 * 400.0 * float(a.params.m) / 4


def _compliance_max(a: Any) -> float:
    """The softest transmission fitted: a mode of 4 Hz on the model's own reduced mass ``frac_m (1 - frac_m) m``
    (floored at frac_m = 0.01), which is ``25 / _k_typ`` at frac_m = 0.5.  On ``m / 4`` instead, a drive
    with most of its inertia on one side could not reach a real 4-5 Hz shaft mode (case 151023 of
    ``benchmarks.identify_truth --seed 151 --draws 0 --pairs 24``: frac_m 0.19, a 4.6 Hz mode, the fit stopped at
    the bound and was refused)."""
    f = min(max(float(a.params.frac_m), 0.01), 0.99)
    return 1.0 / (_k_typ(a) / 25) * (0.25 / (f * (1.0 - f)))  # the factor is exactly 1 at frac_m = 0.5


def _f_max(a: Any) -> float:
    """The drive's peak force, replayed or recorded (a closed loop's recorded command holds the weight of a
    vertical axis, which the nominal replay does not)."""
    return max(a.F_ref, float(np.max(np.abs(a.params.k_u * a.u))))


#: default damping ratio of a fitted transmission compliance (the ``zeta`` of ``transmission_compliance``)
ZETA_COMPLIANCE = 0.05
AT_LOAD = "at the load"
IN_TRANSMISSION = "in the transmission"


def _geared(a: Any) -> bool:
    """Whether the record's drive has a transmission between motor and load (``model.transmission``): a direct
    drive (a linear motor) has no mesh, gap or shaft to name."""
    return bool(getattr(a, "geared", True))

LIBRARY: tuple[Effect, ...] = (
    Effect("coulomb_friction", AT_LOAD, (Param("F_c", _rot, 0.0, lambda a: 0.5 * a.F_ref, 0.0,
                                               lambda a: 0.03 * a.F_ref),
                                         # the speed over which the friction builds up, F_c tanh(v / v_t): held at
                                         # the model's regularisation v_eps (a sharp sign) unless freeing it
                                         # validates better (a lubricated contact that creeps instead of sticking);
                                         # a friction that sticks (sticks on) has no tanh, so v_t is held then
                                         Param("v_t", lambda a: f"{a.units[0]}/s", lambda a: a.params.v_eps,
                                               lambda a: 0.2 * a.v_ref, lambda a: a.params.v_eps,
                                               lambda a: a.params.v_eps, main=False, check_bound=False,
                                               optional=True, dead_with=STICK.name), STICK),
           enters="adds F_c to the drive's Coulomb friction F_c tanh(v / v_t) (v_t: the model's v_eps unless "
                  "freed); with sticks = 1 the load sticks below the break-away force instead (exact stick-slip)",
           when=lambda a: "F_c" not in a.free,
           synthetic={SYNTHETIC: {"F_c": (0.6, 2.0)}}, source=SOURCE),
    Effect("stribeck_friction", AT_LOAD, (
        Param("F_s", _rot, 0.0, lambda a: 0.5 * a.F_ref, 0.0, lambda a: 0.03 * a.F_ref),
        Param("v_s", lambda a: f"{a.units[0]}/s", lambda a: 0.005 * a.v_ref, lambda a: 0.5 * a.v_ref,
              lambda a: 0.05 * a.v_ref, lambda a: 0.05 * a.v_ref, main=False),
        # the decay's shape: 2 (LuGre's Gaussian) to 1 (Tustin's exponential; Armstrong-Helouvry et al. 1994);
        # below 1 the decay is so slow that it mimics Coulomb friction.  Held at 2 unless freeing it validates
        # better: with the shape fixed at 2 a near-exponential decay came out with F_s 22 % low (independent
        # record, case 7005), but in a closed loop that crosses zero speed fast only F_s v_s is seen and a free
        # shape trades against F_s
        Param("delta", "-", 1.0, 2.0, 2.0, 2.0, main=False, check_bound=False, optional=True), STICK),
           enters="the static excess of the Stribeck steady state: F_f = (F_c + F_s exp(-|v/v_s|^delta)) "
                  "tanh(v/v_eps) + b v, or sticking below F_c + F_s with sticks = 1",
           synthetic={SYNTHETIC: {"F_s": (1.0, 2.5), "v_s": (0.02, 0.05)}}, source=SOURCE),
    Effect("viscous_friction", AT_LOAD, (Param("b", lambda a: f"{a.units[1]} s/{a.units[0]}", 0.0,
                                               lambda a: 2 * a.F_ref / a.v_ref, 0.0,
                                               lambda a: 0.05 * a.F_ref / a.v_ref),),
           enters="adds b to the viscous damping", when=lambda a: "b" not in a.free,
           synthetic={SYNTHETIC: {"b": (4.0, 10.0)}}, source=SOURCE),
    Effect("backlash", IN_TRANSMISSION, (
        Param("width", _lin, 0.0, lambda a: 0.2 * a.x_ref, 0.0, lambda a: 0.005 * a.x_ref),
        # the contact's mode (Hz) and damping ratio on the reduced mass, held at the drive model's stiff, well
        # damped contact unless freeing them validates better (teeth behind a shaft ring and bounce)
        Param("f_contact", "Hz", 10.0, 300.0, F_CONTACT, F_CONTACT, main=False, check_bound=False, optional=True,
              grid=9),
        Param("zeta_contact", "-", 0.02, 1.0, ZETA_CONTACT, ZETA_CONTACT, main=False, check_bound=False,
              optional=True),
        # where in the gap the motor sat at the first sample (a share of the half gap, -1..1): a record does not
        # say, and in an open-loop replay the load position it leads to stays shifted ever after (a sensor offset
        # stood in for it); fitted with the gap, like the amplifier's start share.  A start pressed to the bound
        # is the gap standing in for something else (EMPS at commit 85b4fa3, `vsa-gym identify emps`: a 22 mm
        # "gap" with the motor held at its edge validated 2 % better than Coulomb friction), so the bound is
        # checked like a shape parameter's.  The range ends where the dead zone's corners begin (1 - E_CORNER of
        # the half gap): a start there is a motor already in contact, which the gap's start cannot tell from a
        # gap standing in for something else (EMPS with the sharp dead zone: a 24 mm "gap" started 0.998 of the
        # way to the tooth, 0.2 % inside the old bound of 1)
        Param("start", "-", -(1.0 - E_CORNER), 1.0 - E_CORNER, 0.0, 0.0, main=False)),
           enters="a dead zone of total width `width` in the transmission between motor and load (one-sided "
                  "contact of mode f_contact and damping ratio zeta_contact on the reduced mass); the motor starts "
                  "at `start` x width / 2 from the middle of the gap",
           when=lambda a: _geared(a) and "backlash" not in a.free,
           synthetic={SYNTHETIC: {"width": (2e-3, 5e-3)}}, source=SOURCE),
    Effect("transmission_compliance", IN_TRANSMISSION, (
        Param("compliance", lambda a: f"{a.units[0]}/{a.units[1]}", 0.0, _compliance_max, 0.0,
              lambda a: 1.0 / _k_typ(a)),
        # the mode's damping ratio on the reduced mass: held at 0.05 unless freeing it validates better (a
        # shaft rings at 0.02-0.1; held too high or too low, the missing damping is named viscous friction)
        Param("zeta", "-", 0.005, 0.5, ZETA_COMPLIANCE, ZETA_COMPLIANCE, main=False, check_bound=False,
              optional=True)),
           enters="a spring of stiffness 1 / compliance between motor and load (a rigid drive: k_c = 0), damped "
                  "at the ratio zeta on the reduced mass m_r = frac_m (1 - frac_m) m",
           when=lambda a: _geared(a) and float(a.params.k_c) == 0.0,
           synthetic={SYNTHETIC: {"compliance": (1 / (4 * np.pi**2 * 8.0**2 * 0.5),
                                                 1 / (4 * np.pi**2 * 4.0**2 * 0.5))}}, source=SOURCE),
    Effect("spring_stiffness_drift", "in the transmission spring", (Param("drift", "-", -0.5, 0.5, 0.0, 0.05),),
           enters="scales the transmission spring k_c by (1 + drift)",
           when=lambda a: float(a.params.k_c) != 0.0 and "k_c" not in a.free, signed=True),
    # forward loss 1 - eta; back-driven loss 1 - eta_b (same start: a symmetric mesh)
    Effect("gearbox_efficiency", IN_TRANSMISSION, (
        Param("loss", "-", 0.0, 0.7, 0.0, 0.05),
        Param("loss_back", "-", 0.0, 0.8, 0.0, 0.05, main=False, check_bound=False)),
           enters="mesh efficiency eta = 1 - loss when the motor drives (the load receives eta F_mesh), "
                  "eta_b = 1 - loss_back back-driven (it receives F_mesh / eta_b)", when=_geared,
           synthetic={SYNTHETIC: {"loss": (0.1, 0.3)}}, source=SOURCE),
    # Dahl force F_h and its presliding travel x_h = F_h / sigma_h; a travel of a few sensor counts or less is
    # not a resolved presliding regime but a friction that sticks (Coulomb friction); the travel is searched with
    # the force for the fit's start (``grid``), since a loop fitted from a travel far from its own slides to the
    # shortest one
    Effect("hysteresis", AT_LOAD, (
        Param("F_h", _rot, 0.0, lambda a: 0.5 * a.F_ref, 0.0, lambda a: 0.03 * a.F_ref),
        Param("x_h", _lin, _x_min, lambda a: 0.3 * a.x_ref, lambda a: max(0.01 * a.x_ref, 2 * _x_min(a)),
              lambda a: max(0.01 * a.x_ref, 2 * _x_min(a)), main=False, grid=5)),
           enters="a Dahl force h on the load: dh/dt = sigma_h (v - |v| h / F_h), sigma_h = F_h / x_h",
           synthetic={SYNTHETIC: {"F_h": (0.8, 2.0)}}, source=SOURCE),
    Effect("inertia_error", "of the moving parts", (Param("rel", "-", -0.5, 1.0, 0.0, 0.05, tolerance=0.05),),
           enters="scales the moving mass m by (1 + rel)", when=lambda a: "m" not in a.free,
           synthetic={SYNTHETIC: {"rel": (0.15, 0.4)}}, signed=True, source=SOURCE),
    # up to the drive's peak force (the weight can take most of it); below 1 % of the peak drive force it is
    # within an amplifier's zero offset (a per cent of full scale)
    Effect("force_offset", AT_LOAD, (Param("F_0", _rot, lambda a: -_f_max(a), _f_max, 0.0,
                                           lambda a: 0.02 * a.F_ref, tolerance=lambda a: 0.01 * a.F_ref),),
           enters="a constant force F_0 on the load (weight, cable, amplifier zero offset)",
           when=lambda a: "F_0" not in a.free,
           synthetic={SYNTHETIC: {"F_0": (0.4, 1.5)}}, signed=True, source=SOURCE),
    Effect("sensor_gain", measurement=True, synthetic={SYNTHETIC: {"gain": (0.03, 0.08)}}, signed=True,
           source=SOURCE),
    Effect("sensor_offset", measurement=True, synthetic={SYNTHETIC: {"offset": (2e-3, 5e-3)}}, signed=True,
           source=SOURCE),
    Effect("sensor_delay", measurement=True, synthetic={SYNTHETIC: {"delay": (0.004, 0.012)}}, source=SOURCE),
)

__all__ = ["LIBRARY", "SYNTHETIC", "ZETA_COMPLIANCE"]
