"""The eLPAS cascade controller of the paper (Sec. 4, eqs. 10-14, Table 2) as a policy object.

Three levels, innermost first:

* **current loop** (eqs. 10-13): PI on the torque error with the integrator clamped at
  ``I_m^max = 28 V`` (anti-windup) plus the resistance feed-forward ``R I_ref``.  It is *not*
  re-implemented here: the policy drives the environment with ``control_mode="current"``,
  whose 10 kHz loop is exactly that controller (:class:`vsa_gym.devices.elpas.task.ElpasCurrentLoop`);
  the policy's action is ``I_ref / I_max``.
* **angle loop** (eq. 14): ``C_a(s) = -P_a (s + D_a)/(s + L_a) - I_a/s |_{I_a^max}`` on the error
  ``gamma_ref - gamma_hat``; its output is the reference moment at the motor (N m), hence
  ``I_ref = T_ref / K_T``.  The gain is negative because the reductor ratio ``N = -59`` is.
  The lead-lag is discretised with Tustin's rule, the integrator with forward Euler and a clamp
  at ``+-I_a^max`` (anti-windup), both at the policy rate ``dt`` (the environment's
  ``control_dt``, 1 kHz on the force-tracking rig).
* **force level** (Sec. 4.3): the force reference passes a first-order 10 Hz low-pass
  (discretised exactly for a held input) and the 2-D lookup ``gamma_ref(F_ref)`` built from the
  cone model at ``alpha = 0``; there is no force feedback (open-loop force control, as in the
  paper).  ``alpha_compensation=True`` switches to the 3-D lookup ``gamma_ref(F_ref, alpha_hat)``
  that the paper mentions and uses for the "flying carpet" experiment (Fig. 17 right).

The policy reads only the observation (``gamma_hat``, ``force_ref`` and, with alpha
compensation, ``alpha_hat``); it never touches the simulator state.  All arithmetic is batched:
an observation of shape ``(n_obs,)`` gives an action ``(1,)``, ``(n, n_obs)`` gives ``(n, 1)``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from scipy import signal

from vsa_gym.devices.elpas.cone import spring_unchecked
from vsa_gym.devices.elpas.params import ElpasParams

ELPAS_FORCE_OBS = ("gamma_hat", "gamma_dot_hat", "alpha_hat", "alpha_dot_hat", "current", "force", "force_ref",
                   "force_err")
"""Observation layout of ``ELPAS-ForceTracking-v0`` (see its docstring)."""


@dataclasses.dataclass(frozen=True)
class ElpasCascadeConfig:
    """Gains of the eLPAS cascade (Table 2 of the paper) and the discretisation."""

    P_a: float = 1500.0  # N m per rad: angle loop gain (motor moment per rad of arm angle error)
    D_a: float = 94.2  # 1/s: lead-lag zero
    L_a: float = 377.0  # 1/s: lead-lag pole
    I_a: float = 750.0  # N m per rad s: integral gain
    I_a_max: float = 2.0  # N m: integrator clamp (anti-windup)
    force_filter_hz: float = 10.0  # first-order low-pass on F_ref (Sec. 4.3)
    gamma_ref_max: float = float(np.deg2rad(85.0))  # rad, [proposed] lookup range inside the +-90 deg stops
    alpha_compensation: bool = False  # True: 3-D lookup gamma_ref(F_ref, alpha_hat) (flying carpet)
    dt: float = 1e-3  # s, policy rate (must equal the environment's control_dt)
    lookup_points: int = 721  # gamma grid of the lookup table

    def __post_init__(self) -> None:
        for name in ("P_a", "D_a", "L_a", "I_a", "I_a_max", "force_filter_hz", "dt"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"ElpasCascadeConfig.{name} must be finite and > 0, got {v!r}")
        if not 0 < self.gamma_ref_max <= np.pi / 2:
            raise ValueError(f"gamma_ref_max must lie in (0, pi/2], got {self.gamma_ref_max}")


class ForceLookup:
    """``gamma_ref(F_ref[, alpha])``: inverse of the cone model's ``F_act(gamma, alpha)`` on a grid.

    The 2-D table (``alpha = 0``) is the paper's; the 3-D table adds a grid over alpha and
    interpolates linearly between the two neighbouring alpha rows.  Each row is made monotone
    in gamma (where ``F_act`` is not, e.g. near ``alpha = -15 deg``, the extreme gammas are unused).
    """

    def __init__(self, params: ElpasParams, gamma_max: float, n_gamma: int = 721,
                 alphas: np.ndarray | None = None) -> None:
        c = params.cone
        self.gamma = np.linspace(-gamma_max, gamma_max, n_gamma)
        self.alphas = np.zeros(1) if alphas is None else np.asarray(alphas, dtype=np.float64)
        F = spring_unchecked(c, self.gamma[None, :], self.alphas[:, None]).F_act
        self.F = np.maximum.accumulate(F, axis=1)  # monotone rows for np.interp

    def __call__(self, F_ref: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
        F_ref = np.atleast_1d(np.asarray(F_ref, dtype=np.float64))
        if alpha is None or self.alphas.size == 1:
            return np.interp(F_ref, self.F[0], self.gamma)
        a = np.clip(np.broadcast_to(alpha, F_ref.shape), self.alphas[0], self.alphas[-1])
        k = np.clip(np.searchsorted(self.alphas, a) - 1, 0, self.alphas.size - 2)
        w = (a - self.alphas[k]) / (self.alphas[k + 1] - self.alphas[k])
        out = np.empty_like(F_ref)
        for j in range(F_ref.size):
            g0 = np.interp(F_ref[j], self.F[k[j]], self.gamma)
            g1 = np.interp(F_ref[j], self.F[k[j] + 1], self.gamma)
            out[j] = (1 - w[j]) * g0 + w[j] * g1
        return out


class ElpasCascade:
    """The paper's cascade as a policy: ``reset()``, then ``policy(obs) -> action`` (see module docstring).

    Args:
        config: gains and rate.
        params: the eLPAS parameters the controller is designed with (nominal by default):
            the lookup table, ``K_T`` and ``I_max`` come from them.
        obs_names: observation channel names of the environment (``ELPAS-ForceTracking-v0``
            layout by default; the quarter car uses the same first six channels).
    """

    def __init__(self, config: ElpasCascadeConfig | None = None, params: ElpasParams | None = None,
                 obs_names: Sequence[str] = ELPAS_FORCE_OBS) -> None:
        self.config = ElpasCascadeConfig() if config is None else config
        self.params = ElpasParams() if params is None else params
        cfg = self.config
        self.k_t = float(self.params.motor.k_t)
        self.i_max = float(self.params.motor.I_max)
        alphas = np.linspace(-float(self.params.cone.alpha_max), float(self.params.cone.alpha_max), 121)
        self.lookup = ForceLookup(self.params, cfg.gamma_ref_max, cfg.lookup_points,
                                  alphas if cfg.alpha_compensation else None)
        # lead-lag -P_a (s + D_a)/(s + L_a), Tustin: y_k = -a1 y_{k-1} + b0 e_k + b1 e_{k-1}
        num, den, _ = signal.cont2discrete(([-cfg.P_a, -cfg.P_a * cfg.D_a], [1.0, cfg.L_a]), cfg.dt,
                                           method="bilinear")
        num = np.ravel(num)
        self._b0, self._b1, self._a1 = float(num[0]), float(num[1]), float(den[1])
        self._lp = 1.0 - np.exp(-2.0 * np.pi * cfg.force_filter_hz * cfg.dt)
        self.idx = {name: k for k, name in enumerate(obs_names)}
        for need in ("gamma_hat", "alpha_hat"):
            if need not in self.idx:
                raise ValueError(f"observation has no channel {need!r}: {tuple(obs_names)}")
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Clear the filter and integrator states (sized on the next call)."""
        self.n: int | None = None
        self.f_filt = np.zeros(0)
        self.integ = np.zeros(0)
        self.ll_y = np.zeros(0)
        self.ll_e = np.zeros(0)
        self.last: dict[str, np.ndarray] = {}

    def _init(self, n: int, f_ref: np.ndarray) -> None:
        self.n = n
        self.f_filt = f_ref.copy()
        self.integ = np.zeros(n)
        self.ll_y = np.zeros(n)
        self.ll_e = np.zeros(n)

    # ------------------------------------------------------------------ levels
    def force_reference(self, obs: np.ndarray) -> np.ndarray:
        """The force reference (N) this policy tracks; the force-tracking env observes it directly."""
        return obs[:, self.idx["force_ref"]].astype(np.float64)

    def gamma_reference(self, f_ref: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """Force level: 10 Hz low-pass, then the lookup (updates the filter state)."""
        self.f_filt = self.f_filt + self._lp * (f_ref - self.f_filt)
        alpha = obs[:, self.idx["alpha_hat"]].astype(np.float64) if self.config.alpha_compensation else None
        return self.lookup(self.f_filt, alpha)

    def angle_loop(self, gamma_ref: np.ndarray, gamma: np.ndarray) -> np.ndarray:
        """Eq. 14: reference moment at the motor (N m) from the angle error (updates the states)."""
        cfg = self.config
        e = gamma_ref - gamma
        y = -self._a1 * self.ll_y + self._b0 * e + self._b1 * self.ll_e
        self.ll_y, self.ll_e = y, e
        self.integ = np.clip(self.integ - cfg.I_a * e * cfg.dt, -cfg.I_a_max, cfg.I_a_max)
        return y + self.integ

    # ------------------------------------------------------------------ policy
    def __call__(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float64)
        single = o.ndim == 1
        o = np.atleast_2d(o)
        f_ref = self.force_reference(o)
        if self.n != o.shape[0]:
            self._init(o.shape[0], f_ref)
        gamma_ref = self.gamma_reference(f_ref, o)
        gamma = o[:, self.idx["gamma_hat"]]
        T_ref = self.angle_loop(gamma_ref, gamma)
        i_ref = T_ref / self.k_t
        a = np.clip(i_ref / self.i_max, -1.0, 1.0)
        self.last = {"f_ref": f_ref, "f_filt": self.f_filt.copy(), "gamma_ref": gamma_ref, "T_ref": T_ref,
                     "i_ref": i_ref, "integ": self.integ.copy()}
        return a[0, None].astype(np.float32) if single else a[:, None].astype(np.float32)


def elpas_cascade_factory(config: ElpasCascadeConfig | None = None):  # noqa: ANN201
    """``policy_factory(env) -> ElpasCascade`` for :func:`baselines.metrics.evaluate_policy` (reads the
    env's observation names and control_dt)."""

    def make(env) -> ElpasCascade:  # noqa: ANN001
        task = env.unwrapped.task
        cfg = config or ElpasCascadeConfig()
        cfg = dataclasses.replace(cfg, dt=float(task.control_dt))
        return ElpasCascade(cfg, task.base_rows[0], [c.name for c in task.obs_channels])

    return make
