"""What both eLPAS environments share: drive commands, the paper's current loop, sensors, energy, failures.

Physics: :func:`vsa_gym.elpas.model.step_rig` / :func:`~vsa_gym.elpas.model.step_vehicle`;
the energy terms are the core's integrated ``P_EL`` channel.

Commands (``control_mode``):

* ``"voltage"``: ``u = a U_max`` (42 V) held over the control step;
* ``"current"``: ``I_ref = a I_max`` (75 A) tracked by the paper's motor controller
  (eqs. 10-13, Table 2): a PI controller on the torque error ``K_T (I_ref - I)`` with
  ``P_m = 0.1 V/(N m)``, ``I_m = 50 V/(N m s)``, the integrator clamped to ``+-28 V``
  (anti-windup), plus the resistance feed-forward ``R I_ref``.  It runs at 10 kHz:
  the core is stepped every 0.1 ms (``numerics.dt = 1e-4``, one RK4 sub-step) with
  the imposed input (alpha or road height) interpolated linearly.

Sensors: motor encoder (2000 pulses/rev, eq. 8 of the vsaUT-II paper's model of a
quadrature encoder) read as ``gamma = theta_m / N``; a 12-bit absolute encoder on the
wishbone (alpha) [proposed: the paper does not name its sensor]; the drive's current
measurement; the force sensor between wishbone and hydropulse/body (``F_act``);
optional white noise on current and force (``sensor_noise``).

Failures: gamma end-stop contact ``|gamma| >= gamma_max`` (90 deg), I^2 t trip of the
drive (nominal 25 A [proposed], peak 75 A for 2 s).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from vsa_gym.elpas import model as em
from vsa_gym.elpas.params import ElpasParams, NumericsParams
from vsa_gym.envs.randomization import DomainRandomization
from vsa_gym.envs.sensing import NoiseSpec, add_noise, i2t_limit, i2t_update, lowpass_gain, update_velocity
from vsa_gym.envs.task import BatchedTask, ControlMode, ObsChannel, RegenPolicy
from vsa_gym.physics.sensors import AbsoluteEncoder, IncrementalEncoder

CURRENT_LOOP_DT = 1e-4  # s (10 kHz)
SUBSTEP_MAX = 2.5e-4  # s, the core's validated RK4 sub-step


@dataclasses.dataclass(frozen=True)
class ElpasCurrentLoop:
    """Motor controller of the eLPAS paper (eqs. 10-13, Table 2)."""

    P_m: float = 0.1  # V per N m of torque error
    I_m: float = 50.0  # V per N m s
    I_m_max: float = 28.0  # V, integrator clamp


def stack_elpas(rows: list[ElpasParams], numerics: NumericsParams) -> ElpasParams:
    """One batched :class:`ElpasParams` from per-row sets (numerics stay scalar)."""
    groups = ("motor", "friction", "drive", "cone", "car")
    kw = {g: type(getattr(rows[0], g)).stack([getattr(r, g) for r in rows]) for g in groups}
    return ElpasParams(**kw, numerics=numerics)


class ElpasTask(BatchedTask):
    """Shared eLPAS machinery; subclasses choose the configuration (rig or vehicle)."""

    action_names = ("motor command",)
    default_control_dt = 1e-3
    noise_defaults: Mapping[str, float] = {"current": 0.2, "force": 5.0}  # A, N
    vehicle: bool = False

    def __init__(
        self,
        n: int,
        *,
        control_dt: float | None = None,
        control_mode: ControlMode = "voltage",
        params: ElpasParams | None = None,
        domain_randomization: DomainRandomization | Mapping[str, tuple[float, float]] | None = None,
        sensor_noise: NoiseSpec = False,
        regen: RegenPolicy = "clip",
        current_loop: ElpasCurrentLoop | None = None,
        i_nominal: float = 25.0,
        i2t_trip_s: float = 2.0,
        velocity_cutoff_hz: float = 50.0,
    ) -> None:
        super().__init__(n, control_dt=control_dt, control_mode=control_mode, sensor_noise=sensor_noise,
                         domain_randomization=domain_randomization, regen=regen)
        base = ElpasParams() if params is None else params
        if not isinstance(base, ElpasParams):
            raise TypeError(f"params must be an ElpasParams, got {type(base).__name__}")
        bs = base.batch_size
        if bs is not None and bs != self.n:
            raise ValueError(f"params are batched with {bs} sets but there are {self.n} environments")
        if self.randomization is not None:
            self.randomization.check(base)
            if any(k.startswith("numerics.") for k in self.randomization.ranges):
                raise ValueError("domain_randomization: numerics (dt, n_sub) cannot be randomised")
        if control_mode == "current":
            self.n_inner = max(1, int(round(self.control_dt / CURRENT_LOOP_DT)))
        else:
            self.n_inner = 1
        h = self.control_dt / self.n_inner
        self.numerics = NumericsParams(dt=h, n_sub=float(max(1, int(np.ceil(h / SUBSTEP_MAX - 1e-9)))))
        self.base_rows = [base.index(i) if bs is not None else base for i in range(self.n)]
        self.row_params = list(self.base_rows)
        self._build_params()
        self.loop = ElpasCurrentLoop() if current_loop is None else current_loop
        self.i_nominal, self.i2t_trip_s = float(i_nominal), float(i2t_trip_s)
        self.v_gain = lowpass_gain(velocity_cutoff_hz, self.control_dt)
        self.motor_encoder = IncrementalEncoder()
        self.alpha_encoder = AbsoluteEncoder(bits=12.0, gain_mismatch=0.0)
        n_ = self.n
        width = em.N_VEHICLE if self.vehicle else em.N_RIG
        self.s["x"] = np.zeros((n_, width))
        self.s["pi_int"] = np.zeros(n_)
        self.s["i2t"] = np.zeros(n_)
        self.s["meas"] = np.zeros((n_, 2))  # gamma, alpha (quantised)
        self.s["vel"] = np.zeros((n_, 2))
        self.s["cur"] = np.zeros(n_)
        self.s["force"] = np.zeros(n_)
        self.s["e_el"] = np.zeros(n_)
        self.s["e_charged"] = np.zeros(n_)
        self.s["p_last"] = np.zeros(n_)  # mean electrical power of the last step (W), for the traces

    # ------------------------------------------------------------------ parameters
    def _build_params(self) -> None:
        if self.randomization is None and all(p is self.base_rows[0] for p in self.row_params):
            self.params = self.row_params[0].replace(numerics=self.numerics)
        else:
            self.params = stack_elpas(self.row_params, self.numerics)

    def _sample_params(self, rows: np.ndarray) -> None:
        if self.randomization is None:
            return
        for i in rows:
            self.row_params[int(i)] = self.randomization.sample(self.base_rows[int(i)], self.rngs[int(i)])
        self._build_params()

    def _col(self, value: Any) -> np.ndarray:
        """A parameter (float or ``(n,)``) as an ``(n,)`` array, memoised per parameter set (not rebuilt every step)."""
        memo = self.__dict__.get("_col_memo")
        if memo is None or memo[0] is not self.params:
            memo = (self.params, {})
            self._col_memo = memo
        hit = memo[1].get(id(value))
        if hit is None or hit[0] is not value:  # the value is kept alive in the memo, so its id is not reused
            hit = (value, np.broadcast_to(np.asarray(value, dtype=np.float64), (self.n,)))
            memo[1][id(value)] = hit
        return hit[1]

    # ------------------------------------------------------------------ sensors
    def _common_channels(self) -> list[ObsChannel]:
        p = self.base_rows[0]
        g = float(p.cone.gamma_max) + 0.1
        a = float(p.cone.alpha_max) + 0.05
        wg = 1.5 * p.motor.U_max / p.motor.k_e / abs(p.drive.N)
        im = 1.25 * p.motor.I_max
        return [
            ObsChannel("gamma_hat", "rad", -g, g, "arm angle from the motor encoder (theta_m / N)"),
            ObsChannel("gamma_dot_hat", "rad/s", -wg, wg, "arm speed estimate (filtered encoder difference)"),
            ObsChannel("alpha_hat", "rad", -a, a, "wishbone angle, 12-bit absolute encoder"),
            ObsChannel("alpha_dot_hat", "rad/s", -20.0, 20.0, "wishbone speed estimate"),
            ObsChannel("current", "A", -im, im, "motor current (drive measurement)"),
            ObsChannel("force", "N", 0.0, 6000.0, "force sensor: actuator force F_act"),
        ]

    def _measure(self, rows: np.ndarray) -> np.ndarray:
        x = self.s["x"][rows]
        N = self._col(self.params.drive.N)[rows]
        gam = self.motor_encoder.measure(N * x[:, em.GAMMA]) / N
        alp = self.alpha_encoder.measure(x[:, em.ALPHA])
        return np.stack([gam, alp], axis=1)

    def _read_analog(self, rows: np.ndarray) -> None:
        self._F_true = em.actuator_force_of(self.params, self.s["x"])  # true F_act of every row at the current state
        F = self._F_true[rows]
        self.s["cur"][rows] = add_noise(self.s["x"][rows, em.CURRENT], self.noise["current"], self.rngs, rows)
        self.s["force"][rows] = add_noise(F, self.noise["force"], self.rngs, rows)

    def _reset_sensors(self, rows: np.ndarray) -> None:
        self.s["meas"][rows] = self._measure(rows)
        self.s["vel"][rows] = 0.0
        self._read_analog(rows)

    def _update_sensors(self) -> None:
        rows = self._all_rows
        m = self._measure(rows)
        self.s["vel"] = update_velocity(self.s["meas"], m, self.s["vel"], self.control_dt, self.v_gain)
        self.s["meas"] = m
        self._read_analog(rows)

    def _common_obs(self, rows: np.ndarray) -> np.ndarray:
        m, v = self.s["meas"][rows], self.s["vel"][rows]
        return np.stack([m[:, 0], v[:, 0], m[:, 1], v[:, 1], self.s["cur"][rows], self.s["force"][rows]], axis=1)

    # ------------------------------------------------------------------ physics
    def _physics(self, a: np.ndarray, second_end: np.ndarray) -> np.ndarray:
        """One control step; ``second_end`` is alpha (rig) or road height (vehicle) at the end. Returns E_el (J)."""
        p = self.params
        # the cores' steps without their input checks: x, the commands and alpha/road are valid by construction
        step: Callable[..., tuple[np.ndarray, np.ndarray]] = (em._step_vehicle_valid if self.vehicle
                                                               else em._step_rig_valid)
        col = em.Y_R if self.vehicle else em.ALPHA
        x = self.s["x"]
        start = x[:, col].copy()
        e_el = np.zeros(self.n)
        if self.control_mode == "voltage":
            u = a[:, 0] * self._col(p.motor.U_max)
            x, e = step(p, x, np.stack([u, second_end], axis=1), compiled=True)
            e_el = e[:, em.P_EL]
        else:
            m, L = p.motor, self.loop
            i_ref = a[:, 0] * self._col(m.I_max)
            h = self.control_dt / self.n_inner
            for k in range(1, self.n_inner + 1):
                err = m.k_t * (i_ref - x[:, em.CURRENT])
                self.s["pi_int"] = np.clip(self.s["pi_int"] + L.I_m * err * h, -L.I_m_max, L.I_m_max)
                u = L.P_m * err + self.s["pi_int"] + m.R * i_ref
                target = start + (second_end - start) * (k / self.n_inner)
                x, e = step(p, x, np.stack([u, target], axis=1), compiled=True)
                e_el = e_el + e[:, em.P_EL]
        self.s["x"] = x
        self.s["i2t"] = i2t_update(self.s["i2t"], x[:, em.CURRENT] ** 2, self.i_nominal, self.control_dt)
        self._update_sensors()
        return e_el

    def _energy_info(self, e_el: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        charged = self.energy_cost_basis(e_el[:, None])
        self.s["e_el"] += e_el
        self.s["e_charged"] += charged
        self.s["p_last"] = e_el / self.control_dt
        return charged, {"energy_el": e_el.copy(), "energy_charged": charged,
                         "energy_el_total": self.s["e_el"].copy(), "energy_charged_total": self.s["e_charged"].copy(),
                         "power_el": e_el / self.control_dt}

    def _drive_margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        p = self.params
        x = self.s["x"][rows]
        lim = i2t_limit(self._col(p.motor.I_max)[rows], self.i_nominal, self.i2t_trip_s)
        return {"margin_gamma_stop": self._col(p.cone.gamma_max)[rows] - np.abs(x[:, em.GAMMA]),
                "margin_i2t": 1.0 - self.s["i2t"][rows] / lim}

    def _reset_drive(self, rows: np.ndarray) -> None:
        for k in ("pi_int", "i2t", "e_el", "e_charged", "p_last"):
            self.s[k][rows] = 0.0

    # ------------------------------------------------------------------ drawing
    def draw_mechanism(self, ax: Any, i: int) -> None:
        p = self.row_params[i]
        x = self.s["x"][i]
        gam, alp = x[em.GAMMA], x[em.ALPHA]
        c = p.cone
        y0 = x[em.Y_S] if self.vehicle else 0.0
        s = 1.0 / (c.a + 0.15)
        ax.set_xlim(-0.3, 1.5)
        ax.set_ylim(-0.9, 0.9)
        tip = np.array([np.cos(alp), np.sin(alp)]) * c.l * s
        base = np.array([0.0, y0 * s])
        ax.plot([base[0], base[0] + tip[0]], [base[1], base[1] + tip[1]], color="0.3", lw=5, label="wishbone")
        mot = base + np.array([np.cos(alp), np.sin(alp)]) * c.a * s
        up = np.array([-np.sin(alp), np.cos(alp)])
        apex = mot + up * c.h * s
        arm = mot + np.array([np.cos(alp), np.sin(alp)]) * c.r * s * np.sin(gam) + up * 0.0
        ax.plot([mot[0], apex[0]], [mot[1], apex[1]], color="0.6", lw=1, ls="--")
        ax.plot([mot[0], arm[0]], [mot[1], arm[1]], color="tab:red", lw=3, label=f"arm gamma={np.rad2deg(gam):.0f} deg")
        ax.plot([apex[0], arm[0]], [apex[1], arm[1]], color="tab:green", lw=2, label="spring")
        ax.plot(*mot, "o", color="k", ms=6)
        F = float(em.actuator_force_of(self.params, self.s["x"])[i])
        ax.text(-0.25, -0.85, f"F_act = {F:.0f} N\nalpha = {np.rad2deg(alp):.1f} deg", fontsize=7)
        self._draw_extra(ax, i, s)
        ax.legend(fontsize=6, loc="upper left")

    def _draw_extra(self, ax: Any, i: int, scale: float) -> None:
        """Configuration-specific drawing (hydropulse or body and road); subclasses add to the picture."""
        del ax, i, scale
