"""The paper's rig experiments (steps, FRFs, power sweeps) on the force-tracking environment's task.

``ELPAS-ForceTracking-v0`` draws its own random force reference and hydropulse motion.
The paper's experiments need *prescribed* signals (a step, filtered white noise, a sine,
alpha held at a fixed angle), so :class:`RigExperimentTask` subclasses the environment's
batched task and only replaces where the reference and alpha come from.  Everything else --
the physics core, the paper's 10 kHz PI current loop (``control_mode="current"``), the
sensors, the electrical-energy channel -- is the environment's own code, and the controller
sees exactly the environment's observation vector.

:func:`run_rig` runs a policy (e.g. :class:`baselines.elpas_cascade.ElpasCascade`) on ``n``
rigs at once and returns time series.  The hydropulse force sensor (between wishbone and
hydropulse, Sec. 5.1) also carries the wishbone inertia: from the moment balance about the
pivot, ``F_h = F_act + J_w alpha'' / (l cos alpha)``; it is returned as ``F_hydropulse``
(``J_w`` from :class:`vsa_gym.devices.elpas.params.QuarterCarParams`, [proposed] 0.6 kg m^2).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.env_force_tracking import ForceTrackingTask
from vsa_gym.devices.elpas.params import ElpasParams


class RigExperimentTask(ForceTrackingTask):
    """:class:`ForceTrackingTask` with prescribed ``F_ref[k]`` and ``alpha[k]`` per row, ``(n, T + 1)``.

    The step is the task's own compiled step reading the tables (``prescribed``); this class only starts the
    rows at rest at ``gamma0`` and ``alpha[:, 0]`` instead of drawing them.
    """

    def __init__(self, f_ref: np.ndarray, alpha: np.ndarray, gamma0: np.ndarray, **kwargs: Any) -> None:
        f_ref, alpha = np.atleast_2d(f_ref), np.atleast_2d(alpha)
        if f_ref.shape != alpha.shape:
            raise ValueError(f"f_ref and alpha must have the same shape (n, T+1), got {f_ref.shape}, {alpha.shape}")
        kwargs.setdefault("control_mode", "current")
        # the observation clips force_ref to force_range: widen it to the whole actuator range
        kwargs.setdefault("force_range", (1000.0, 4500.0))
        super().__init__(f_ref.shape[0], prescribed=(f_ref, alpha), **kwargs)
        self.f_traj, self.alpha_traj = self.tables[0], self.tables[1]
        self.gamma0 = np.broadcast_to(np.asarray(gamma0, dtype=np.float64), (self.n,)).copy()

    def _reset_rows(self, rows: np.ndarray) -> None:
        self._reset_drive(rows)
        for i in rows:
            self.s["x"][i] = em.initial_state_rig(self.row_params[int(i)], 1, gamma=self.gamma0[i],
                                                  alpha=self.alpha_traj[i, 0])[0]
        self.s["f_ref"][rows] = self.f_traj[rows, 0]
        self._reset_sensors(rows)


def run_rig(policy: Callable[[np.ndarray], np.ndarray], f_ref: np.ndarray, alpha: np.ndarray,
            gamma0: np.ndarray | float = 0.0, params: ElpasParams | None = None, dt: float = 1e-3,
            i2t_trip_s: float = 1e9, record: Callable[[], dict[str, np.ndarray]] | None = None,
            ) -> dict[str, np.ndarray]:
    """Run ``policy`` on ``n`` rigs following ``f_ref`` / ``alpha`` (``(n, T + 1)``, one sample per ``dt``).

    The I^2 t trip is disabled by default (``i2t_trip_s``) because the paper's worst-case
    experiments deliberately run at the current limit; the end-stop contact still counts and is
    returned as ``failed``.  ``record()`` (optional) is called after every policy call and its
    arrays are stacked (e.g. the controller's internal ``gamma_ref``).

    Returns ``(n, T)`` series (time axis last): ``t``, ``F_act``, ``F_ref``, ``F_hydropulse``, ``gamma``,
    ``alpha``, ``current``, ``P_el`` (W, signed mean over each step), ``P_charged`` (W, regeneration
    clipped), ``failed`` ``(n,)`` (end-stop contact), ``pi_int_max`` ``(n,)`` (largest
    ``|integrator|`` of the environment's current loop, V) plus the recorded keys.
    """
    if policy is None:
        raise ValueError("policy is required")
    task = RigExperimentTask(f_ref, alpha, gamma0, control_dt=dt, params=params, i2t_trip_s=i2t_trip_s)
    task.reset()
    n, T = task.n, task.f_traj.shape[1] - 1
    p = task.params
    keys = ("F_act", "F_ref", "gamma", "alpha", "current", "P_el", "P_charged")
    out = {k: np.empty((n, T)) for k in keys}
    rec: dict[str, list[np.ndarray]] = {}
    failed = np.zeros(n, dtype=bool)
    pi_int_max = np.zeros(n)
    obs = task.observation()
    if hasattr(policy, "reset"):
        policy.reset()
    for k in range(T):
        a = np.asarray(policy(obs), dtype=np.float64).reshape(n, -1)
        if record is not None:
            for key, v in record().items():
                rec.setdefault(key, []).append(np.asarray(v, dtype=np.float64).copy())
        f_now = task.s["f_ref"].copy()
        obs, _, term, info = task.step(a)
        failed |= term
        pi_int_max = np.maximum(pi_int_max, np.abs(task.s["pi_int"]))
        x = task.s["x"]
        out["F_act"][:, k] = em.actuator_force_of(p, x)
        out["F_ref"][:, k] = f_now
        out["gamma"][:, k] = x[:, em.GAMMA]
        out["alpha"][:, k] = x[:, em.ALPHA]
        out["current"][:, k] = x[:, em.CURRENT]
        out["P_el"][:, k] = info["power_el"]
        out["P_charged"][:, k] = info["energy_charged"] / dt
    out["t"] = np.broadcast_to(dt * np.arange(1, T + 1), (n, T)).copy()
    J_w, l = np.asarray(p.car.J_w), np.asarray(p.cone.l)
    acc = np.gradient(np.gradient(out["alpha"], dt, axis=1), dt, axis=1)
    out["F_hydropulse"] = out["F_act"] + np.reshape(J_w, (-1, 1)) * acc / (np.reshape(l, (-1, 1))
                                                                            * np.cos(out["alpha"]))
    for key, vals in rec.items():
        out[key] = np.stack(vals, axis=-1)
    out["failed"] = failed
    out["pi_int_max"] = pi_int_max
    return out
