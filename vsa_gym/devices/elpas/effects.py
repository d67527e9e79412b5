"""The eLPAS's effect library (:mod:`vsa_gym.identify.library`): what
:class:`vsa_gym.devices.elpas.adapter.ElpasAdapter` may name on a hydropulse-rig force test, with bounds relative
to the nominal friction of Table 1 (``F_c``, ``F_s``, ``s2`` of the adapter's nominal parameters), and the
magnitudes the synthetic rig records plant (:mod:`vsa_gym.devices.elpas.synthetic`).  The equations are the
core's (LuGre friction, cone spring, drive); the mapping is ``ElpasAdapter.param_tuple`` and the imposed angle.
"""

from __future__ import annotations

from typing import Any

from vsa_gym.identify.library import Effect, Param

RIG = "rig"  # the synthetic rig force tests (sine and step) of vsa_gym.devices.elpas.synthetic
MOTOR = "at the motor shaft (LuGre)"
SOURCE = "Table 1's friction, which the paper calls underestimated (+75 ... +175 %), and the tolerances of the " \
    "cone spring rate, the arm inertia, the drive's efficiency and the wishbone encoder's alignment"


def _fr(a: Any) -> Any:
    return a.nominal.friction


LIBRARY: tuple[Effect, ...] = (
    Effect("coulomb_friction", MOTOR, (
        Param("F_c", "N m", lambda a: -0.75 * float(_fr(a).F_c), lambda a: 5.0 * float(_fr(a).F_c), 0.0,
              lambda a: 0.25 * float(_fr(a).F_c)),),
           enters="adds F_c to the LuGre Coulomb level F_c and to the static level F_s",
           synthetic={RIG: {"F_c": (0.15, 0.35)}}, source=SOURCE),
    Effect("stribeck_friction", MOTOR, (
        Param("F_s", "N m", lambda a: -0.5 * (float(_fr(a).F_s) - float(_fr(a).F_c)),
              lambda a: 3.0 * float(_fr(a).F_s), 0.0, lambda a: 0.2 * float(_fr(a).F_s)),),
           enters="adds F_s to the LuGre static level F_s", synthetic={RIG: {"F_s": (0.3, 0.6)}}, source=SOURCE),
    Effect("viscous_friction", MOTOR, (
        Param("s2", "N m s/rad", lambda a: -0.75 * float(_fr(a).s2), lambda a: 10.0 * float(_fr(a).s2), 0.0,
              lambda a: 0.5 * float(_fr(a).s2)),),
           enters="adds s2 to the LuGre viscous coefficient", synthetic={RIG: {"s2": (0.006, 0.015)}},
           source=SOURCE),
    Effect("spring_stiffness_drift", "of the cone spring rate C_a", (Param("drift", "-", -0.3, 0.3, 0.0, 0.03),),
           enters="scales the cone spring rate C_a by (1 + drift)", synthetic={RIG: {"drift": (0.05, 0.12)}},
           signed=True, source=SOURCE),
    Effect("inertia_error", "about the gamma axis (J_r)", (Param("rel", "-", -0.5, 1.0, 0.0, 0.1),),
           enters="scales the arm inertia J_r by (1 + rel)", synthetic={RIG: {"rel": (0.3, 0.6)}}, signed=True,
           source=SOURCE),
    Effect("gearbox_efficiency", "of motor and reductor", (Param("loss", "-", 0.0, 0.5, 0.0, 0.05),),
           enters="scales the torque constant k_t by (1 - loss)", synthetic={RIG: {"loss": (0.1, 0.25)}},
           source=SOURCE),
    Effect("alpha_offset", "of the wishbone angle (alignment)", (Param("offset", "rad", -0.05, 0.05, 0.0, 0.005),),
           enters="adds a constant offset to the imposed wishbone angle alpha",
           synthetic={RIG: {"offset": (0.01, 0.02)}}, signed=True, source=SOURCE),
    Effect("sensor_gain", measurement=True, synthetic={RIG: {"gain": (0.03, 0.06)}}, signed=True, source=SOURCE),
    Effect("sensor_offset", measurement=True, synthetic={RIG: {"offset": (30.0, 60.0)}}, signed=True,
           source=SOURCE),
    Effect("sensor_delay", measurement=True, synthetic={RIG: {"delay": (0.004, 0.010)}}, source=SOURCE),
)

__all__ = ["LIBRARY", "RIG"]
