"""The vsaUT-II model's layout: state and power columns, numerical constants, and the types its equations and
extensions share (:mod:`vsa_gym.devices.vsaut2.model` documents the model)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, NamedTuple, Protocol

import numpy as np

if TYPE_CHECKING:
    from vsa_gym.devices.vsaut2.params import VsaUT2Params

STATE = {name: i for i, name in enumerate(("i1", "th1", "w1", "i2", "th2", "w2", "q2", "q2_dot", "r", "r_dot"))}
N_STATES = len(STATE)
STATE_UNITS = ("A", "rad", "rad/s", "A", "rad", "rad/s", "rad", "rad/s", "rad", "rad/s")
#: States of the stateful effects of ``params.effects`` (:class:`~vsa_gym.devices.vsaut2.params.VsaUT2Effects`): the
#: spring hysteresis torque ``h_phi`` (N m, Dahl).  Its column follows the 10 core states when the parameters switch
#: it on (:func:`effect_state_columns`), before any extension's states; absent otherwise (the nominal layout).
EFFECT_STATE = {"h_phi": N_STATES}
EFFECT_STATE_UNITS = ("N m",)
#: The parameters (dotted paths) whose nonzero value switches a stateful effect, and with it its column, on.
EFFECT_STATE_SWITCHES = ("effects.M_h", "effects.mu_h")
POWER = {name: i for i, name in enumerate(
    ("el_pivot", "el_frame", "ext", "copper", "viscous", "gearbox", "stops"))}
N_POWER = len(POWER)
PORTS: tuple[str, ...] = ("belt_force", "lever_torque", "pivot_force", "motor1", "motor2", "frame", "output")

#: Smoothing widths of the pivot-stroke stop (rad at the motor) and frame stops (rad) -- numerics.
STOP_EPS_MOTOR = 2e-2
STOP_EPS_FRAME = 2e-3
#: The pivot-stroke stops sit this far (10 smoothing widths) outside [0, th1_max], so a pivot parked at
#: either end of the stroke feels no stop force (< 1e-6 N m).
STOP_MARGIN_MOTOR = 10 * STOP_EPS_MOTOR

#: Default RK4 substeps per 1 ms control step (h = 0.1 ms; see tests/vsaut2/test_integrator.py).
SUBSTEPS_PER_MS = 10
#: Default substeps per 1 ms of the opt-in exponential integrator (``integrator="etd"``, h = 0.143 ms):
#: the fewest that keep all five trajectories of tests/vsaut2/test_integrator.py within 1e-3 of Radau
#: (6 per ms gives 1.1e-3 on the saturating-command run, where the frame sits in its end stop).
ETD_SUBSTEPS_PER_MS = 7
#: The integrators of :meth:`VsaUT2Model.step`: ``"rk4"`` (classical RK4, the default) and ``"etd"``
#: (ETDRK4 with the motor currents' ``-R/L i`` decay integrated exactly, see :class:`VsaUT2Model`).
INTEGRATORS = ("rk4", "etd")
#: State columns whose linear decay the ``"etd"`` integrator treats exactly (the motor currents).
ETD_STIFF = (0, 3)


def effect_state_columns(params: VsaUT2Params) -> int:
    """Number of effect-state columns (0 or 1) for ``params`` (shared or batched): 1 when some row has spring
    hysteresis (``effects.M_h > 0`` or ``effects.mu_h > 0``)."""
    e = params.effects
    return int(bool(np.any(np.asarray(e.M_h) > 0.0) or np.any(np.asarray(e.mu_h) > 0.0)))


class Derived(NamedTuple):
    """Constants derived once per model from the parameters (kept off the hot path)."""

    J1: float | np.ndarray  # pivot drive inertia at the motor (kg m^2)
    J2: float | np.ndarray  # frame drive inertia at the motor (kg m^2)
    r_ip: float | np.ndarray  # input pulley radius (m)
    th1_max: float | np.ndarray  # soft end of the pivot stroke, motor angle (rad)


class Kinematics(NamedTuple):
    """Configuration-level quantities every force element and extension may use (all ``(n,)``)."""

    q1: np.ndarray  # pivot position (m)
    q1_dot: np.ndarray  # pivot speed (m/s)
    phi: np.ndarray  # deflection r - q2 (rad)
    phi_dot: np.ndarray
    delta: np.ndarray  # belt stretch (m)
    delta_dot: np.ndarray
    w1: np.ndarray  # pivot motor speed (rad/s)
    w2: np.ndarray  # frame motor speed (rad/s)
    q2_dot: np.ndarray
    r_dot: np.ndarray


class ExtensionOutput(NamedTuple):
    """What an extension returns: additive forces per port, its state derivative, dissipation."""

    forces: Mapping[str, np.ndarray]
    z_dot: np.ndarray  # (n, n_states)
    p_diss: np.ndarray  # (n,) W, power it dissipates (>= 0 for passive effects)


class Extension(Protocol):
    """A model extension inserted at the ports listed in :data:`PORTS`."""

    name: str
    n_states: int

    def initial_state(self, n: int) -> np.ndarray:
        """Extension states at rest, shape ``(n, n_states)``."""
        ...

    def evaluate(self, params: VsaUT2Params, kin: Kinematics, z: np.ndarray) -> ExtensionOutput:
        """Forces, ``dz/dt`` and dissipated power at configuration ``kin``."""
        ...

    def stored_energy(self, params: VsaUT2Params, kin: Kinematics, z: np.ndarray) -> np.ndarray:
        """Energy the extension stores (J), ``(n,)``; zero for purely dissipative effects."""
        ...

