"""Column layout of the eLPAS core's arrays: state, inputs, power channels and extension ports.

State (columns of ``x``, shape ``(n, n_states)``): ``GAMMA`` ... ``ALPHA`` for the rig (``N_RIG``), then
``ALPHA_DOT`` ... ``Y_R`` for the quarter car (``N_VEHICLE``); extension states follow the base states.
Power channels (columns of the ``power`` / ``energy`` arrays): ``P_EL`` ... ``P_OUT``, with the balance
``E_el = dE_stored + E_res + E_fric + E_stop + E_damper + E_ext + E_out``
(:func:`vsa_gym.devices.elpas.model.stored_energy`).
"""

from __future__ import annotations

from vsa_gym.devices.elpas.extensions import Extension

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

# ----------------------------------------------------------------------------- inputs
IN_VOLTAGE = 0  # commanded motor voltage u (V)
IN_ALPHA = 1  # rig: step -> alpha at the end of the step (rad); rhs -> dalpha/dt (rad/s)
IN_ROAD = 1  # vehicle: step -> road height at the end of the step (m); rhs -> dy_r/dt (m/s)

# ----------------------------------------------------------------------------- power channels
P_EL = 0  # electrical power from the supply, u_eff i (W)
P_RES = 1  # copper loss R i^2
P_FRIC = 2  # motor + reductor friction (M_fric + b omega_m) omega_m
P_STOP = 3  # dissipation in the gamma end stops (and the wishbone bump stops)
P_DAMPER = 4  # parallel damper c_p (l cos(alpha) dalpha/dt)^2 (vehicle)
P_EXT = 5  # power absorbed by the extensions
P_OUT = 6  # rig: work done on the hydropulse, F_apart dx_ext/dt; vehicle: on the road, -F_t dy_r/dt
N_POWER = 7
POWER_NAMES = ("electrical", "resistive", "friction", "end_stop", "damper", "extensions", "external")

# ----------------------------------------------------------------------------- extensions
Extensions = tuple[Extension, ...]
N_PORTS = 2  # extension ports: moment on gamma (N m), force added to F_act (N)
