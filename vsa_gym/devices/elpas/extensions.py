"""Model extensions: extra moments on gamma and extra forces on the wishbone, with their own states.

The identification work adds effects the nominal model lacks (hysteresis near
gamma = +-90 deg, an alpha offset, spring drift, ...) without copying the model:
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
are integrated by plain RK4, so they must not be stiff at the substep.
"""

from __future__ import annotations

import dataclasses
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


@dataclasses.dataclass(frozen=True)
class DahlHysteresis:
    """Rate-independent hysteresis moment on gamma (Dahl model), one state ``h`` (N m).

    ``dh/dt = sigma (omega - |omega| h / M_h)``, moment on the arm ``-h``: a loop of
    half-height ``M_h`` whose branches have initial slope ``sigma``.  A candidate
    cause of the hysteresis the paper sees as gamma -> 90 deg (wishbone bending).

    Attributes:
        M_h: loop half-height in N m (>= 0).
        sigma: initial stiffness in N m/rad (> 0; keep ``sigma |omega| / M_h * h_sub`` < 2.7).
    """

    M_h: float = 20.0
    sigma: float = 2000.0
    name: str = "dahl_hysteresis"
    n_states: int = 1

    def __post_init__(self) -> None:
        if not np.isfinite(self.M_h) or self.M_h < 0.0:
            raise ValueError(f"DahlHysteresis.M_h: must be finite and >= 0 N m, got {self.M_h!r}")
        if not np.isfinite(self.sigma) or self.sigma <= 0.0:
            raise ValueError(f"DahlHysteresis.sigma: must be finite and > 0 N m/rad, got {self.sigma!r}")

    def initial_state(self, n: int) -> np.ndarray:
        return np.zeros((n, 1))

    def evaluate(self, ctx: ExtensionContext, s: np.ndarray) -> ExtensionOutput:
        h = s[:, 0]
        w = ctx.omega
        # M_h = 0: no hysteresis, h stays at its initial value
        dh = self.sigma * (w - np.abs(w) * h / self.M_h) if self.M_h > 0.0 else np.zeros_like(h)
        zero = np.zeros_like(h)
        return ExtensionOutput(torque_gamma=-h, force_act=zero, state_derivative=dh[:, None])


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
