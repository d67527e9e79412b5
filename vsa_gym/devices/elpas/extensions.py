"""Model extensions: extra moments on gamma and extra forces on the wishbone, with their own states.

An extension adds an effect the nominal model lacks without copying the model (the identified
effects are parameters of the compiled core instead, ``params.effects``; the arm hysteresis, a Dahl
moment about gamma, is one with its own state column):
an *extension* is any object with

* ``name: str`` and ``n_states: int`` (number of extra states, may be 0),
* ``initial_state(n) -> (n, n_states)`` array,
* ``evaluate(ctx, s) -> ExtensionOutput`` for the context ``ctx`` and its own
  states ``s`` of shape ``(n, n_states)``.

Its moment acts on the arm (about gamma, at the arm side of the reductor) and its
force adds to ``F_act`` (pushing body and wheel apart).  The model appends the
extension states after its own, in the order the extensions are given, and
books the power the extensions absorb, ``-(torque * omega + force * dx_ext/dt)``,
in the ``P_EXT`` channel so the energy balance stays closed.  Extension states
are integrated by plain RK4, so they must not be stiff at the substep.  Extensions run on the numpy
path of the core's scheme (:func:`vsa_gym.devices.elpas.model.step_rig`), for prototyping an effect
before it gets a column: one 1 ms step took 2.6 ms of CPU for 1 row and 10 ms for 256 rows, against
31 us and 1.3 ms for the compiled core with the same law as a column
(``python -m benchmarks.elpas_effect_columns_speed``, this machine).
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

from vsa_gym.devices.elpas.params import ElpasParams


class ExtensionContext(NamedTuple):
    """What an extension may read; arrays of shape ``(n,)``."""

    params: ElpasParams
    gamma: np.ndarray  # rad
    omega: np.ndarray  # dgamma/dt, rad/s
    alpha: np.ndarray  # rad
    alpha_dot: np.ndarray  # rad/s
    extension_rate: np.ndarray  # dx_ext/dt = -l cos(alpha) dalpha/dt, m/s
    F_act: np.ndarray  # nominal actuator force, N
    T_gamma: np.ndarray  # nominal spring moment on the arm, N m


class ExtensionOutput(NamedTuple):
    """Contribution of one extension; arrays of shape ``(n,)`` and ``(n, n_states)``."""

    torque_gamma: np.ndarray  # N m on the arm, +gamma direction
    force_act: np.ndarray  # N added to F_act
    state_derivative: np.ndarray  # (n, n_states)


@runtime_checkable
class Extension(Protocol):
    """Protocol of a model extension (see module docstring)."""

    name: str
    n_states: int

    def initial_state(self, n: int) -> np.ndarray: ...

    def evaluate(self, ctx: ExtensionContext, s: np.ndarray) -> ExtensionOutput: ...


def total_states(extensions: tuple[Extension, ...]) -> int:
    """Number of extension states of a tuple of extensions."""
    return int(sum(int(e.n_states) for e in extensions))


def check_extensions(extensions: tuple[Extension, ...]) -> None:
    """Raise ``ValueError`` if an item does not implement the :class:`Extension` protocol."""
    for k, e in enumerate(extensions):
        if not isinstance(e, Extension):
            raise ValueError(f"extensions[{k}]: {e!r} does not implement the Extension protocol "
                             "(name, n_states, initial_state, evaluate)")
        if int(e.n_states) < 0:
            raise ValueError(f"extensions[{k}] ({e.name}): n_states must be >= 0, got {e.n_states}")
