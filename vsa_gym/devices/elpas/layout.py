"""Column layout of the eLPAS core's arrays: state, inputs, power channels and extension ports.

State (columns of ``x``, shape ``(n, n_states)``): ``GAMMA`` ... ``ALPHA`` for the rig (``N_RIG``), then
``ALPHA_DOT`` ... ``Y_R`` for the quarter car (``N_VEHICLE``); then the effect states that the parameters switch on
(:data:`EFFECT_STATES`), then the extension states.
Power channels (columns of the ``power`` / ``energy`` arrays): ``P_EL`` ... ``P_OUT``, with the balance
``E_el = dE_stored + E_res + E_fric + E_stop + E_damper + E_ext + E_out``
(:func:`vsa_gym.devices.elpas.model.stored_energy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba.extending import register_jitable

from vsa_gym.devices.elpas.extensions import Extension

if TYPE_CHECKING:
    from vsa_gym.devices.elpas.params import ElpasParams

# ----------------------------------------------------------------------------- state layout
GAMMA = 0  # arm angle gamma (rad)
OMEGA = 1  # dgamma/dt (rad/s); motor speed is N * OMEGA
CURRENT = 2  # motor current i (A)
BRISTLE = 3  # LuGre bristle deflection z at the motor (rad)
ALPHA = 4  # wishbone angle alpha (rad); > 0 compresses the suspension
N_RIG = 5
ALPHA_DOT = 5  # dalpha/dt (rad/s), vehicle only
Y_S = 6  # body (sprung mass) height from static equilibrium (m)
V_S = 7  # body velocity (m/s)
Y_R = 8  # road height under the tyre (m)
N_VEHICLE = 9

RIG_STATE_NAMES = ("gamma", "omega", "current", "bristle", "alpha")
VEHICLE_STATE_NAMES = (*RIG_STATE_NAMES, "alpha_dot", "y_s", "v_s", "y_r")
#: States of the stateful effects of ``params.effects`` (:class:`~vsa_gym.devices.elpas.params.ElpasEffects`): the
#: arm hysteresis moment ``h_gamma`` (N m, Dahl).  Its column follows the base states (:func:`effect_column`) when
#: the parameters switch it on (:func:`effect_state_columns`), before any extension's states; absent otherwise.
EFFECT_STATES = ("h_gamma",)
EFFECT_STATE_UNITS = ("N m",)
#: The parameters (dotted paths) whose nonzero value switches a stateful effect, and with it its column, on.
EFFECT_STATE_SWITCHES = ("effects.M_h",)


def effect_state_columns(params: ElpasParams) -> int:
    """Number of effect-state columns (0 or 1) for ``params`` (shared or batched): 1 when some row has arm
    hysteresis (``effects.M_h > 0``).  Cached on ``params`` (frozen; the steps ask every call)."""
    n = params.__dict__.get("_n_effect_states")
    if n is None:
        n = int(bool(np.any(np.asarray(params.effects.M_h) > 0.0)))
        object.__setattr__(params, "_n_effect_states", n)
    return n


@register_jitable
def effect_column(vehicle: bool) -> int:
    """The column of the arm hysteresis state ``h_gamma``: right after the rig's or the quarter car's base states."""
    return N_VEHICLE if vehicle else N_RIG


# ----------------------------------------------------------------------------- inputs
IN_VOLTAGE = 0  # commanded motor voltage u (V)
IN_ALPHA = 1  # rig: step -> alpha at the end of the step (rad); rhs -> dalpha/dt (rad/s)
IN_ROAD = 1  # vehicle: step -> road height at the end of the step (m); rhs -> dy_r/dt (m/s)

# ----------------------------------------------------------------------------- power channels
P_EL = 0  # electrical power from the supply, u_eff i (W)
P_RES = 1  # copper loss R i^2
P_FRIC = 2  # motor + reductor friction (M_fric + b omega_m) omega_m, and the arm hysteresis' |omega| h^2 / M_h
P_STOP = 3  # dissipation in the gamma end stops (and the wishbone bump stops)
P_DAMPER = 4  # parallel damper c_p (l cos(alpha) dalpha/dt)^2 (vehicle)
P_EXT = 5  # power absorbed by the extensions
P_OUT = 6  # rig: work done on the hydropulse, F_apart dx_ext/dt; vehicle: on the road, -F_t dy_r/dt
N_POWER = 7
POWER_NAMES = ("electrical", "resistive", "friction", "end_stop", "damper", "extensions", "external")

# ----------------------------------------------------------------------------- extensions
Extensions = tuple[Extension, ...]
N_PORTS = 2  # extension ports: moment on gamma (N m), force added to F_act (N)
