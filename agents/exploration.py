"""A scheduled exploration noise for Gaussian policies: the standard deviation follows a plan, not the gradient.

::

    python -m agents.train --env vsa_gym/VsaUT2-PositionStiffness-v0 --algo ppo --timesteps 6000000 --seed 0 \\
        --params "callback:[{agents.exploration.LogStdSchedule: {start: -1.5, end: -3.0}}]"

PPO learns the log standard deviation of its Gaussian policy with everything else.  Where the noise itself has a
price that the learned policy would not pay, this leaves training rollouts far from what is scored: on the
vsaUT-II a voltage noise of 0.2 of 24 V is a current noise of amperes on the 0.317 Ohm frame motor, whose copper
loss the reward charges as energy (docs/agents.md, "What the training rollouts cost": with their training noise
the agents spend about six times the energy they spend without it).  :class:`LogStdSchedule` takes the deviation
out of the optimisation and moves it linearly in log space from ``start`` to ``end`` over the first
``fraction`` of the run's timesteps, then holds it: early rollouts explore widely, late ones are close to the
deterministic policy that is evaluated.  It is an SB3 callback (the hyperparameters' ``callback`` entry, as in
rl-zoo3); the value is set at the start of every rollout from the run's step count, so a resumed run continues the
same plan.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback


class LogStdSchedule(BaseCallback):
    """``log_std`` = ``start`` + (``end`` - ``start``) min(t / (``fraction`` T), 1), not learned (module docstring).

    ``start`` and ``end`` are a number or one per action component; ``T``: the run's total timesteps (``timesteps``
    when given, else what ``learn`` was asked for, counted from step 0).
    """

    def __init__(self, start: float | Sequence[float] = -1.5, end: float | Sequence[float] = -3.0,
                 fraction: float = 1.0, timesteps: int | None = None, verbose: int = 0) -> None:
        super().__init__(verbose)
        if not 0.0 < float(fraction) <= 1.0:
            raise ValueError(f"fraction must lie in (0, 1], got {fraction}")
        if timesteps is not None and int(timesteps) < 1:
            raise ValueError(f"timesteps must be >= 1, got {timesteps}")
        self.start = np.atleast_1d(np.asarray(start, dtype=np.float64))
        self.end = np.atleast_1d(np.asarray(end, dtype=np.float64))
        if not (np.isfinite(self.start).all() and np.isfinite(self.end).all()):
            raise ValueError(f"start and end must be finite, got {start}, {end}")
        self.fraction, self.timesteps = float(fraction), timesteps

    def value(self, t: int, total: int) -> np.ndarray:
        """The log standard deviation at timestep ``t`` of a run of ``total`` timesteps."""
        x = min(float(t) / (self.fraction * max(int(total), 1)), 1.0)
        return self.start + (self.end - self.start) * x

    def _apply(self) -> None:
        import torch

        log_std = self.model.policy.log_std
        total = self.timesteps if self.timesteps is not None else self.model._total_timesteps  # noqa: SLF001
        v = self.value(self.model.num_timesteps, total)
        if v.size not in (1, log_std.numel()):
            raise ValueError(f"LogStdSchedule: {v.size} values for {log_std.numel()} action components")
        with torch.no_grad():
            log_std.copy_(torch.as_tensor(np.broadcast_to(v, log_std.shape).copy(), dtype=log_std.dtype))

    def _on_training_start(self) -> None:
        log_std = getattr(self.model.policy, "log_std", None)
        if log_std is None or getattr(self.model.policy, "use_sde", False):
            raise TypeError("LogStdSchedule needs a Gaussian policy with a state-independent log_std (PPO, A2C "
                            "without gSDE)")
        log_std.requires_grad_(False)  # the plan sets it; PPO's optimiser skips a parameter without a gradient
        self._apply()

    def _on_rollout_start(self) -> None:
        self._apply()

    def _on_step(self) -> bool:
        return True
