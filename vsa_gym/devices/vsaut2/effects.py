"""The vsaUT-II's effect library (:mod:`vsa_gym.identify.library`): what
:class:`vsa_gym.devices.vsaut2.adapter.Vsaut2Adapter` may name, with bounds scaled to the record (``T_ref``: the
peak torque of the joint that moves, ``v_ref``: its peak speed, ``x_ref``: its angle spread, of the nominal
replay), and the magnitudes the synthetic records of the paper's experiments plant
(:mod:`vsa_gym.devices.vsaut2.synthetic`).  The equations are the core's (``VsaUT2Params.effects``, the lever,
belt and gearbox laws; the spring hysteresis is a state column of the core), the mapping ``Vsaut2Adapter.changes``.
"""

from __future__ import annotations

from typing import Any

from vsa_gym.identify.library import Effect, Param

FREE, SINE, SWEEP = "free_oscillation", "constant_current", "torque_sweep"  # the synthetic experiments
SOURCE = "the paper's Fig. 10 discrepancy (the measured free oscillation decays faster than linear friction) " \
    "and the datasheets' tolerances (inertia, spring rate, GP42C efficiency, AS5043 gain)"


def _joint(a: Any) -> str:
    return f"at the {a.joint} joint"


def _keys(a: Any) -> tuple[str, str]:
    """The viscous-friction and inertia parameters of the joint that moves."""
    return ("c_o", "I_o") if a.joint == "output" else ("c_ad", "I_ad")


LIBRARY: tuple[Effect, ...] = (
    Effect("coulomb_friction", _joint, (Param("F_c", "N m", 0.0, lambda a: 0.5 * a.T_ref, 0.0,
                                              lambda a: 0.03 * a.T_ref),),
           enters="adds F_c to the joint's Coulomb friction (effects.F_c_o or effects.F_c_ad)",
           synthetic={FREE: {"F_c": (3e-3, 1e-2)}, SINE: {"F_c": (0.1, 0.3)}, SWEEP: {"F_c": (5e-3, 2e-2)}},
           source=SOURCE),
    Effect("stribeck_friction", _joint, (
        Param("F_s", "N m", 0.0, lambda a: 0.5 * a.T_ref, 0.0, lambda a: 0.03 * a.T_ref),
        Param("w_s", "rad/s", lambda a: 0.005 * a.v_ref, lambda a: 0.5 * a.v_ref, lambda a: 0.05 * a.v_ref,
              lambda a: 0.05 * a.v_ref, main=False)),
           enters="adds a static excess F_s with Stribeck speed w_s at the output (effects.F_s_o, effects.w_s_o)",
           when=lambda a: a.joint == "output"),
    Effect("viscous_friction", _joint, (Param("b", "N m s/rad", 0.0, lambda a: 2 * a.T_ref / a.v_ref, 0.0,
                                              lambda a: 0.05 * a.T_ref / a.v_ref),),
           enters="adds b to the joint's viscous damping (c_o or c_ad)", when=lambda a: _keys(a)[0] not in a.free,
           synthetic={FREE: {"b": (4e-3, 1.2e-2)}}, source=SOURCE),
    Effect("inertia_error", lambda a: f"of the {a.joint} ({_keys(a)[1]})", (Param("rel", "-", -0.5, 1.0, 0.0, 0.05),),
           enters="scales the joint's inertia (I_o or I_ad) by (1 + rel)", when=lambda a: _keys(a)[1] not in a.free,
           synthetic={FREE: {"rel": (0.1, 0.3)}, SINE: {"rel": (0.2, 0.5)}}, signed=True, source=SOURCE),
    Effect("spring_stiffness_drift", "in the lever springs (k)", (Param("drift", "-", -0.5, 0.5, 0.0, 0.05),),
           enters="scales the lever spring rate lever.k by (1 + drift)", when=lambda a: "lever.k" not in a.free,
           synthetic={FREE: {"drift": (0.06, 0.15)}, SWEEP: {"drift": (0.06, 0.15)}}, signed=True, source=SOURCE),
    Effect("transmission_compliance", "in the belt", (
        Param("compliance", "m/N", 0.0, lambda a: 3.0 / float(a.params.belt.C_belt), 0.0,
              lambda a: 0.2 / float(a.params.belt.C_belt)),),
           enters="adds a compliance in series with the belt: 1 / C_belt -> 1 / C_belt + compliance"),
    Effect("backlash", "in the belt (half-width of the stretch dead zone)", (
        Param("width", "m", 0.0, lambda a: 0.1 * float(a.params.belt.r_op) * a.x_ref + 2e-4, 0.0, 2e-5),),
           enters="adds to the half-width of the belt stretch's dead zone (effects.b_belt)"),
    Effect("gearbox_efficiency", "in the GP42C frame gearbox", (Param("loss", "-", 0.0, 0.6, 0.0, 0.05),),
           enters="scales the frame gearbox's peak efficiency by (1 - loss)", when=lambda a: a.frame_actuated,
           synthetic={SINE: {"loss": (0.1, 0.25)}}, source=SOURCE),
    Effect("force_offset", "on the output (constant torque)", (
        Param("F_0", "N m", lambda a: -0.3 * a.T_ref, lambda a: 0.3 * a.T_ref, 0.0, lambda a: 0.02 * a.T_ref),),
           enters="a constant torque F_0 added to the external torque on the output", signed=True),
    # a stateful effect: its state is the core's extra column EFFECT_STATE["h_phi"] (the equation is in
    # equations.rhs_point).  Offered where an external torque sweeps the deflection through its loop (the torque
    # sweep: Table IV's torque hysteresis is measured so); a presliding deflection of a few AS5043 counts or less is
    # not resolved, and the loop then looks like Coulomb friction at the output
    Effect("hysteresis", "in the lever springs (a Dahl torque along the deflection phi)", (
        Param("M_h", "N m", 0.0, lambda a: 0.5 * a.T_ref, 0.0, lambda a: 0.03 * a.T_ref),
        Param("phi_h", "rad", 3e-3, lambda a: max(0.3 * a.x_ref, 0.06), 0.02, 0.02, main=False)),
           enters="a torque -h on the output along phi (+h on the frame), dh/dt = (M_h phi_dot - |phi_dot| h) / phi_h "
                  "(effects.M_h, effects.phi_h; Dahl's sigma_h = M_h / phi_h)",
           when=lambda a: a.torque_driven,
           synthetic={SWEEP: {"M_h": (0.01, 0.03), "phi_h": (0.02, 0.05)}},
           source="Table IV row 11 (maximum torque hysteresis 12 %: a loop of half-height about 6 % of the swept "
                  "torque, 0.024 N m at the sweep's 0.4 N m; the range is 5-15 %); the presliding deflection is "
                  "assumed (3-8 AS5043 counts: the paper gives none)"),
    Effect("sensor_gain", measurement=True, synthetic={SWEEP: {"gain": (0.04, 0.1)}}, signed=True,
           source="the AS5043's look-alike of the spring drift in the linear range"),
    Effect("sensor_offset", measurement=True, synthetic={FREE: {"offset": (0.01, 0.03)}}, signed=True,
           source=SOURCE),
    Effect("sensor_delay", measurement=True),
)

__all__ = ["FREE", "LIBRARY", "SINE", "SWEEP"]
