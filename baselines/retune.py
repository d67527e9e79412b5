"""Retune a model-based baseline on a given simulator: rebuild its model, then a small gain search.

The vsaUT-II decoupled controller (:mod:`baselines.vsaut2_decoupled`) is model-based: the stiffness
reference is inverted through the lever model (eqs. 5-6, ``lever.k``), the feed-forward balances the
modelled spring and friction torques, and the position shaping uses ``I_o``.  "Retuning on a model"
here means two things, both done on that model's environment only:

1. **rebuild** the controller with the model's parameter set (:class:`~vsa_gym.devices.vsaut2.params.VsaUT2Params`,
   e.g. the identified one);
2. **search** a few gains: two log-scale multipliers, one on the pivot PID (``kp_pivot``, ``ki_pivot``,
   ``kd_pivot``) and one on the frame PID (``kp_frame``, ``ki_frame``, ``kd_frame``), by Nelder-Mead
   (:func:`scipy.optimize.minimize`) on :func:`objective` over the tuning seeds: the environment's
   reward per step (tracking, energy) plus a price on episodes ended early.  Not the plain episode
   return: an episode that ends early (end stop, I^2 t) stops accumulating tracking cost, so the
   return can *improve* by failing sooner -- a search on it drifts to gains that fail more.

The same procedure applied to the nominal model gives the "tuned on nominal" controller, so a
comparison on the measured plant isolates what the identified model adds.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy.optimize import minimize

from baselines.metrics import PolicyFactory, evaluate_policy
from baselines.vsaut2_decoupled import VsaUT2Decoupled, VsaUT2DecoupledConfig
from vsa_gym.devices.vsaut2.params import VsaUT2Params

PS_ENV = "vsa_gym/VsaUT2-PositionStiffness-v0"

#: the gains each search coordinate scales (one log multiplier per group)
GAIN_GROUPS: tuple[tuple[str, ...], ...] = (("kp_pivot", "ki_pivot", "kd_pivot"), ("kp_frame", "ki_frame", "kd_frame"))
#: bound of each log multiplier (a factor exp(+-1.5) = 0.22 ... 4.5 on the gains)
LOG_BOUND = 1.5
#: price of an episode ended early, in units of the mean per-step cost (about 0.4-0.6 for the paper's gains)
FAIL_WEIGHT = 1.0


def objective(row: Mapping[str, Any]) -> float:
    """Search objective (lower is better) from an :func:`~baselines.metrics.evaluate_policy` row.

    ``-return / steps`` (the mean cost per step of the env's reward, over the alive steps) plus
    ``FAIL_WEIGHT`` times the fraction of episodes that ended early.
    """
    return float(-row["return"] / max(row["steps"], 1.0) + FAIL_WEIGHT * row["violations"] / row["episodes"])


def scaled_config(base: VsaUT2DecoupledConfig, x: Sequence[float]) -> VsaUT2DecoupledConfig:
    """``base`` with each group of :data:`GAIN_GROUPS` multiplied by ``exp(x[k])`` (``x`` clipped to +-LOG_BOUND)."""
    if len(x) != len(GAIN_GROUPS):
        raise ValueError(f"x must have {len(GAIN_GROUPS)} entries (one per gain group), got {len(x)}")
    kw: dict[str, float] = {}
    for xk, names in zip(np.clip(np.asarray(x, dtype=np.float64), -LOG_BOUND, LOG_BOUND), GAIN_GROUPS, strict=True):
        for name in names:
            kw[name] = float(getattr(base, name) * np.exp(xk))
    return dataclasses.replace(base, **kw)


def decoupled_factory(config: VsaUT2DecoupledConfig, design: VsaUT2Params) -> PolicyFactory:
    """``policy_factory(env)`` of the decoupled controller designed with ``design`` -- *not* the env's parameters.

    (:func:`baselines.vsaut2_decoupled.vsaut2_decoupled_factory` designs with the env's own parameters,
    which on a "measured" plant would be the truth the controller cannot know.)
    """

    def make(env: Any) -> VsaUT2Decoupled:
        task = env.unwrapped.task
        cfg = dataclasses.replace(config, dt=float(task.control_dt))
        return VsaUT2Decoupled(cfg, design, [c.name for c in task.obs_channels])

    return make


@dataclasses.dataclass
class RetuneResult:
    """Outcome of :func:`retune_decoupled`: the config, the search coordinates and the objective history."""

    config: VsaUT2DecoupledConfig
    design: VsaUT2Params
    x: list[float]
    objective_start: float  # :func:`objective` with the starting gains (tuning seeds)
    objective: float  # :func:`objective` with the tuned gains (tuning seeds)
    evaluations: int
    seconds: float
    history: list[tuple[list[float], float]] = dataclasses.field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """JSON-able summary (gains by name, objective before/after, cost)."""
        names = [n for g in GAIN_GROUPS for n in g]
        return {"log_multipliers": self.x, "gains": {n: float(getattr(self.config, n)) for n in names},
                "objective_start": self.objective_start, "objective": self.objective,
                "evaluations": self.evaluations, "seconds": self.seconds}


def retune_decoupled(design: VsaUT2Params, seeds: Sequence[int], *, base: VsaUT2DecoupledConfig | None = None,
                     max_evals: int = 16, episode_steps: int | None = None, env_id: str = PS_ENV,
                     env_kwargs: Mapping[str, Any] | None = None,
                     log: Callable[[str], None] | None = None) -> RetuneResult:
    """Rebuild the decoupled controller on ``design`` and search its gains on the env built with ``design``.

    Args:
        design: the model: the controller is designed with it *and* the tuning environment runs it
            (``gym.make(env_id, params=design)``); never pass the measured plant's truth here.
        seeds: episode seeds of the tuning runs (keep them apart from the evaluation seeds).
        base: starting gains (the paper's defaults).
        max_evals: budget of distinct objective evaluations (Nelder-Mead, two coordinates; points outside
            +-LOG_BOUND are clipped); 0 or 1 = rebuild only.
        episode_steps: episode length of the tuning runs (default: the env's time limit).
        env_kwargs: further keyword arguments of the environment (``params`` is set to ``design``).
        log: optional progress printer.
    """
    base = VsaUT2DecoupledConfig() if base is None else base
    kw = {**dict(env_kwargs or {}), "params": design}
    history: list[tuple[list[float], float]] = []
    t0 = time.perf_counter()

    def fun(x: np.ndarray) -> float:
        x = np.clip(np.asarray(x, dtype=np.float64), -LOG_BOUND, LOG_BOUND)
        for xh, fh in history:  # Nelder-Mead re-evaluates its start point; the runs are deterministic
            if np.array_equal(xh, x):
                return fh
        row = evaluate_policy(env_id, decoupled_factory(scaled_config(base, x), design), seeds,
                              episode_steps=episode_steps, env_kwargs=kw)
        f = objective(row)
        history.append(([float(v) for v in x], f))
        if log is not None:
            log(f"  retune eval {len(history)}: x = {np.round(x, 3).tolist()}  objective = {f:.4g} "
                f"(return {row['return']:.4g}, {row['violations']} ended early)")
        return f

    x0 = np.zeros(len(GAIN_GROUPS))
    f0 = fun(x0)
    x_best, f_best = x0, f0
    if max_evals > 1:
        simplex = np.vstack([x0, np.diag(np.full(len(x0), 0.5))])
        res = minimize(fun, x0, method="Nelder-Mead",
                       options={"maxfev": max_evals - 1, "initial_simplex": simplex, "xatol": 0.05, "fatol": 1e-3})
        # the optimiser's x may be a point it did not evaluate last; take the best evaluated one
        del res
        k = int(np.argmin([f for _, f in history]))
        x_best, f_best = np.asarray(history[k][0]), history[k][1]
    return RetuneResult(scaled_config(base, x_best), design, [float(v) for v in x_best], f0, f_best, len(history),
                        time.perf_counter() - t0, history)


__all__ = ["FAIL_WEIGHT", "GAIN_GROUPS", "RetuneResult", "decoupled_factory", "objective", "retune_decoupled",
           "scaled_config"]
