"""What both vsaUT-II environments share: drive commands, sensors, energy, failures, drawing.

Nothing here integrates physics: every step calls :meth:`VsaUT2Model.step` of the
core, and the energy terms are the core's integrated power channels
``el_pivot``/``el_frame``.

Commands (``control_mode``):

* ``"voltage"``: ``u_j = a_j U_max,j`` (V), held over the control step;
* ``"current"``: ``i_ref,j = a_j I_max,j`` (A); a current-mode amplifier law
  (:func:`vsa_gym.physics.dc_motor.current_control_voltage`: ``R i_ref + k_e w + L 2 pi f_c (i_ref - i)``,
  ``f_c = current_bandwidth_hz``) runs at 10 kHz: the core is called every 0.1 ms
  with the voltage recomputed from the current state (Fig. 9 of the paper drives the frame with a constant
  current).  The amplifier's voltage and current limits act inside the core in both modes.

Sensors (:mod:`vsa_gym.physics.sensors`): incremental encoders (2000 pulses/rev,
eq. 8) on both motor shafts, the AS5043 absolute encoder (10 bit, gain mismatch) on
the output, the drives' current measurements (optional white noise).

Failures (``terminated``): frame end stop contact ``|q2| >= q2_max``, deflection end
stop contact ``|phi| >= phi_max``, and an I^2 t over-current trip of either drive
(:mod:`vsa_gym.envs.sensing`; nominal current 4 A, Table IV, peak 12 A for ``i2t_trip_s``).
Each drive's I^2 t utilisation (heating state over its trip threshold, 1 = trip) is observed
(``i2t_1``, ``i2t_2``), as servo drives report it (e.g. maxon EPOS): without it the trip is a
hidden state that neither a controller nor an agent could anticipate.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numba
import numpy as np
from numba.extending import register_jitable

from vsa_gym.envs.randomization import DomainRandomization
from vsa_gym.envs.sensing import NoiseSpec, add_noise, i2t_limit, i2t_update, lowpass_gain, update_velocity
from vsa_gym.envs.task import BatchedTask, ControlMode, ObsChannel, RegenPolicy
from vsa_gym.physics.belt import belt_stiffness_at_frame, series_stiffness
from vsa_gym.physics.dc_motor import current_control_voltage
from vsa_gym.physics.lever import lever_ratio, spring_stiffness
from vsa_gym.physics.pivot import pivot_position
from vsa_gym.physics.sensors import AbsoluteEncoder, IncrementalEncoder
from vsa_gym.vsaut2.model import _P_ROW, INTEGRATORS, POWER, STATE, VsaUT2Model
from vsa_gym.vsaut2.params import VsaUT2Params

CURRENT_LOOP_DT = 1e-4  # s, 10 kHz current loop in current mode
K_FLOOR = 0.1  # N m/rad, floor of the stiffness before taking its log (eq. 6 turns negative past 45 deg)
N_COMMON_OBS = 11  # channels of VsaUT2Task._common_channels (the tasks append theirs after these)

# eq. (6) of the lever, made callable from the compiled sensing below (the same functions, not a copy)
register_jitable(lever_ratio)
register_jitable(spring_stiffness)
register_jitable(series_stiffness)
# the sensing updates of sensing.py, compiled for _sense_update (the same functions, not a copy)
register_jitable(update_velocity)
register_jitable(i2t_update)
# state columns (STATE) as constants the compiled sensing can fold
_I1, _TH1, _I2, _TH2, _Q2, _R = STATE["i1"], STATE["th1"], STATE["i2"], STATE["th2"], STATE["q2"], STATE["r"]


class VsaUT2Task(BatchedTask):
    """Shared vsaUT-II machinery; subclasses add references, reward and extra observations."""

    action_names = ("pivot motor command", "frame motor command")
    default_control_dt = 2e-3
    noise_defaults: Mapping[str, float] = {"current": 0.02}  # A, drive current measurement

    def __init__(
        self,
        n: int,
        *,
        control_dt: float | None = None,
        control_mode: ControlMode = "voltage",
        params: VsaUT2Params | None = None,
        domain_randomization: DomainRandomization | Mapping[str, tuple[float, float]] | None = None,
        sensor_noise: NoiseSpec = False,
        regen: RegenPolicy = "clip",
        current_bandwidth_hz: float = 1000.0,
        i_nominal: float = 4.0,
        i2t_trip_s: float = 2.0,
        velocity_cutoff_hz: float = 50.0,
        integrator: str = "rk4",
    ) -> None:
        super().__init__(n, control_dt=control_dt, control_mode=control_mode, sensor_noise=sensor_noise,
                         domain_randomization=domain_randomization, regen=regen)
        base = VsaUT2Params() if params is None else params
        if not isinstance(base, VsaUT2Params):
            raise TypeError(f"params must be a VsaUT2Params, got {type(base).__name__}")
        bs = base.batch_size
        if bs is not None and bs != self.n:
            raise ValueError(f"params are batched with {bs} sets but there are {self.n} environments")
        self.base_rows = [base.index(i) if bs is not None else base for i in range(self.n)]
        self.row_params = list(self.base_rows)
        if self.randomization is not None:
            self.randomization.check(base)
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
        self.integrator = integrator  # numerics of the core (VsaUT2Model.integrator); "rk4" is the default
        self._build_model()
        self.current_bandwidth_hz = float(current_bandwidth_hz)
        self.i_nominal = float(i_nominal)
        self.i2t_trip_s = float(i2t_trip_s)
        self.v_gain = lowpass_gain(velocity_cutoff_hz, self.control_dt)
        self.motor_encoder = IncrementalEncoder()
        self.output_encoder = AbsoluteEncoder()
        # the encoders' quantisers as numbers for the compiled sensing (step 0: encoder disabled, exact angle)
        me, oe = self.motor_encoder, self.output_encoder
        self._enc = np.array([me.resolution if me.enabled else 0.0, oe.resolution if oe.enabled else 0.0,
                              oe.gain_mismatch if oe.enabled else 0.0])
        if control_mode == "current":
            self.n_inner = max(1, int(round(self.control_dt / CURRENT_LOOP_DT)))
        else:
            self.n_inner = 1
        n_ = self.n
        self.s["x"] = np.zeros((n_, self.model.n_states))
        self.s["i2t"] = np.zeros((n_, 2))
        self.s["meas"] = np.zeros((n_, 3))  # quantised th1, th2 (motor rad), r (rad) of the last sample
        self.s["vel"] = np.zeros((n_, 3))  # filtered speed estimates of the same
        self.s["cur"] = np.zeros((n_, 2))  # measured currents
        self.s["e_el"] = np.zeros(n_)  # cumulative signed electrical energy (J)
        self.s["e_charged"] = np.zeros(n_)  # cumulative energy counted by the energy term (J)

    # ------------------------------------------------------------------ model and parameters
    def _build_model(self) -> None:
        if self.randomization is None and all(p is self.base_rows[0] for p in self.row_params):
            self.params = self.row_params[0]
        else:
            self.params = VsaUT2Params.stack(self.row_params)
        self.model = VsaUT2Model(self.params, integrator=self.integrator)
        self._cols_for: VsaUT2Params | None = None

    def _cols(self) -> dict[str, np.ndarray]:
        """Per-row parameter columns the step uses, computed once per parameter set (not every step)."""
        p = self.params
        if self._cols_for is not p:
            m1, m2 = p.pivot_motor, p.frame_motor
            self._cols_cache = {
                "U_max": np.stack([self._col(m1.U_max), self._col(m2.U_max)], axis=1),
                "I_max": np.stack([self._col(m1.I_max), self._col(m2.I_max)], axis=1),
                "th1_max": np.array(self._col(p.theta1_max)),
                "q2_max": np.array(self._col(p.q2_max)),
                "phi_max": np.array(self._col(p.lever.phi_max)),
                "n1": np.array(self._col(p.pivot_gearbox.n)),
                "ratio": np.array(self._col(p.frame_ratio)),
                "K_b": np.array(self._col(belt_stiffness_at_frame(p.belt))),
            }
            self._cols_cache["i2t_lim"] = i2t_limit(self._cols_cache["I_max"], self.i_nominal, self.i2t_trip_s)
            self._cols_for = p
        return self._cols_cache

    def _sample_params(self, rows: np.ndarray) -> None:
        if self.randomization is None:
            return
        for i in rows:
            self.row_params[int(i)] = self.randomization.sample(self.base_rows[int(i)], self.rngs[int(i)])
        self._build_model()

    def _row_model(self, i: int) -> VsaUT2Model:
        return VsaUT2Model(self.row_params[i])

    def _col(self, value: Any) -> np.ndarray:
        """A parameter (float or ``(n,)``) as an ``(n,)`` array."""
        return np.broadcast_to(np.asarray(value, dtype=np.float64), (self.n,))

    # ------------------------------------------------------------------ common observations
    def _common_channels(self) -> list[ObsChannel]:
        p = self.base_rows[0]
        w1 = 1.5 * p.pivot_motor.U_max / p.pivot_motor.k_e
        w2 = 1.5 * p.frame_motor.U_max / p.frame_motor.k_e
        i1 = 1.25 * p.pivot_motor.I_max
        i2 = 1.25 * p.frame_motor.I_max
        return [
            ObsChannel("q1_hat", "m", 0.0, float(2.0 * p.pivot.D_p),
                       "pivot position from the pivot motor encoder (eq. 5 on the quantised angle)"),
            ObsChannel("q2_hat", "rad", -1.0, 1.0, "frame angle from the frame motor encoder (angle / 226.9)"),
            ObsChannel("r_hat", "rad", -np.pi, np.pi, "output angle, AS5043 absolute encoder (10 bit)"),
            ObsChannel("w1_hat", "rad/s", -w1, w1, "pivot motor speed estimate (filtered encoder difference)"),
            ObsChannel("w2_hat", "rad/s", -w2, w2, "frame motor speed estimate"),
            ObsChannel("r_dot_hat", "rad/s", -50.0, 50.0, "output speed estimate (filtered encoder difference)"),
            ObsChannel("i1", "A", -i1, i1, "pivot motor current (drive measurement)"),
            ObsChannel("i2", "A", -i2, i2, "frame motor current (drive measurement)"),
            ObsChannel("log_K_hat", "ln(N m/rad)", float(np.log(K_FLOOR)), float(np.log(1000.0)),
                       "stiffness estimate: eq. 6 at (q1_hat, r_hat - q2_hat) in series with the belt"),
            ObsChannel("i2t_1", "-", 0.0, 1.0,
                       "pivot drive I^2 t utilisation: heating state / trip threshold (1 = trip)"),
            ObsChannel("i2t_2", "-", 0.0, 1.0, "frame drive I^2 t utilisation (1 = trip)"),
        ]

    def _measure(self, rows: np.ndarray) -> np.ndarray:
        """Quantised sensor angles ``(len(rows), 3)``: pivot motor, frame motor, output."""
        x = self.s["x"][rows]
        th1 = self.motor_encoder.measure(x[:, STATE["th1"]])
        th2 = self.motor_encoder.measure(x[:, STATE["th2"]])
        r = self.output_encoder.measure(x[:, STATE["r"]])
        return np.stack([th1, th2, r], axis=1)

    def _reset_sensors(self, rows: np.ndarray) -> None:
        self.s["meas"][rows] = self._measure(rows)
        self.s["vel"][rows] = 0.0
        x = self.s["x"][rows]
        self.s["cur"][rows] = add_noise(x[:, [STATE["i1"], STATE["i2"]]], self.noise["current"], self.rngs, rows)

    def _update_sensors(self) -> None:
        """I^2 t states, encoder reads and speed estimates of every row (one compiled call), then the currents."""
        rows = self._all_rows
        x = self.s["x"]
        _sense_update(x, self.s["meas"], self.s["vel"], self.s["i2t"], self._enc, self.control_dt, self.v_gain,
                      self.i_nominal)
        self.s["cur"] = add_noise(x[:, [STATE["i1"], STATE["i2"]]], self.noise["current"], self.rngs, rows)

    def _common_obs(self, rows: np.ndarray) -> np.ndarray:
        """The ``N_COMMON_OBS`` common channels of ``rows`` (compiled: eq. 5 and eq. 6 on the quantised angles)."""
        c = self._cols()
        return _common_obs_rows(self.s["meas"], self.s["vel"], self.s["cur"], self.s["i2t"], c["i2t_lim"],
                                self.model._p_rows, c["K_b"], c["ratio"], np.asarray(rows, dtype=np.intp))

    def _stiffness(self) -> np.ndarray:
        """True output stiffness of every row, ``VsaUT2Model.stiffness`` (eq. 6 in series with the belt), compiled."""
        return _true_stiffness(self.s["x"], self.model._p_rows, self._cols()["K_b"])

    # ------------------------------------------------------------------ physics step
    def _physics(self, a: np.ndarray, tau_ext: np.ndarray, enabled: np.ndarray | None = None) -> np.ndarray:
        """Apply the commands for one control step; returns the per-motor electrical energy ``(n, 2)`` (J).

        ``enabled`` (bool ``(n,)``) switches drives off (0 V) where false.
        """
        p = self.params
        m1, m2 = p.pivot_motor, p.frame_motor
        x = self.s["x"]
        if self.control_mode == "voltage":
            u = a * self._cols()["U_max"]
            if enabled is not None:
                u = np.where(enabled[:, None], u, 0.0)
            x, e_sum = self.model._step_valid(x, u, tau_ext, self.control_dt)  # inputs valid by construction
        else:
            i_ref = a * self._cols()["I_max"]
            e_sum = np.zeros((self.n, len(POWER)))
            dt = self.control_dt / self.n_inner
            for _ in range(self.n_inner):
                u = np.stack([
                    current_control_voltage(m1, i_ref[:, 0], x[:, STATE["i1"]], x[:, STATE["w1"]],
                                            self.current_bandwidth_hz),
                    current_control_voltage(m2, i_ref[:, 1], x[:, STATE["i2"]], x[:, STATE["w2"]],
                                            self.current_bandwidth_hz),
                ], axis=1)
                if enabled is not None:
                    u = np.where(enabled[:, None], u, 0.0)
                x, e = self.model._step_valid(x, u, tau_ext, dt, n_sub=1)
                e_sum = e_sum + e
        self.s["x"] = x
        e_m = e_sum[:, [POWER["el_pivot"], POWER["el_frame"]]]
        self._update_sensors()  # also advances the I^2 t states (sensing.i2t_update)
        return e_m

    # ------------------------------------------------------------------ failures and margins
    def _margins(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        c = self._cols()
        mg = _margin_rows(self.s["x"], self.s["i2t"], c["th1_max"], c["q2_max"], c["phi_max"], c["i2t_lim"],
                          np.asarray(rows, dtype=np.intp))
        return {"margin_frame_stop": mg[:, 0], "margin_deflection_stop": mg[:, 1], "margin_i2t": mg[:, 2],
                "margin_pivot_stroke": mg[:, 3]}

    def _failures(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        mg = self._margins(self._all_rows)
        fail = (mg["margin_frame_stop"] <= 0) | (mg["margin_deflection_stop"] <= 0) | (mg["margin_i2t"] <= 0)
        return fail, mg

    def _energy_info(self, e_m: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        charged = self.energy_cost_basis(e_m)
        self.s["e_el"] += e_m.sum(axis=1)
        self.s["e_charged"] += charged
        return charged, {
            "energy_el": e_m.sum(axis=1), "energy_el_pivot": e_m[:, 0], "energy_el_frame": e_m[:, 1],
            "energy_charged": charged, "energy_el_total": self.s["e_el"].copy(),
            "energy_charged_total": self.s["e_charged"].copy(),
        }

    def _reset_common(self, rows: np.ndarray) -> None:
        self.s["i2t"][rows] = 0.0
        self.s["e_el"][rows] = 0.0
        self.s["e_charged"][rows] = 0.0

    # ------------------------------------------------------------------ drawing
    def draw_mechanism(self, ax: Any, i: int) -> None:
        p = self.row_params[i]
        x = self.s["x"][i]
        q2, r = x[STATE["q2"]], x[STATE["r"]]
        q1 = float(pivot_position(p.pivot, x[STATE["th1"]] / p.pivot_gearbox.n))
        K = float(self.model.stiffness(self.s["x"])[i])
        ax.set_xlim(-1.4, 1.4)
        ax.set_ylim(-1.4, 1.4)
        for lim in (-p.q2_max, p.q2_max):
            ax.plot([0, 1.25 * np.cos(lim)], [0, 1.25 * np.sin(lim)], color="0.75", lw=0.8, ls="--")
        ax.add_patch(_circle((0, 0), 0.12, "0.6"))
        ax.plot([0, np.cos(q2)], [0, np.sin(q2)], color="0.35", lw=6, solid_capstyle="round", label="frame q2")
        ax.plot([0, 1.2 * np.cos(r)], [0, 1.2 * np.sin(r)], color="tab:blue", lw=3, label="output r")
        # lever with the pivot: the pivot slides along the frame arm (q1 / 2 D_p of the stroke)
        f = 0.2 + 0.7 * q1 / (2.0 * p.pivot.D_p)
        ax.plot([f * np.cos(q2)], [f * np.sin(q2)], "o", color="tab:red", ms=8, label="pivot q1")
        tip_f = np.array([np.cos(q2), np.sin(q2)])
        tip_o = np.array([np.cos(r), np.sin(r)])
        zz = np.linspace(0, 1, 40)
        perp = np.array([-(tip_o - tip_f)[1], (tip_o - tip_f)[0]])
        perp = perp / (np.linalg.norm(perp) + 1e-9)
        pts = tip_f[:, None] + np.outer(tip_o - tip_f, zz) + 0.04 * np.outer(perp, np.sin(zz * 12 * np.pi))
        ax.plot(pts[0], pts[1], color="tab:green", lw=1)
        ax.text(-1.35, -1.3, f"K = {K:.3g} N m/rad\nq1 = {1e3 * q1:.1f} mm", fontsize=7)
        ax.legend(fontsize=6, loc="upper left")


def _circle(xy: tuple[float, float], radius: float, color: str) -> Any:
    from matplotlib.patches import Circle

    return Circle(xy, radius, color=color)


# ---------------------------------------------------------------------------- compiled per-step sensing
# Element by element, with the operations of the numpy expressions they replace (sensors.IncrementalEncoder /
# AbsoluteEncoder.measure, sensing.update_velocity and i2t_update, eqs. 5 and 6): the values are unchanged
# (tests/envs checks them against the sensor objects); one call replaces about 40 small numpy calls per step.


@numba.njit(cache=True)
def _sense_update(x: np.ndarray, meas: np.ndarray, vel: np.ndarray, i2t: np.ndarray, enc: np.ndarray, dt: float,
                  gain: float, i_nom: float) -> None:
    """In place, every row: I^2 t states ``(n, 2)``, quantised angles ``meas`` and speed estimates ``vel`` ``(n, 3)``.

    ``enc = [motor encoder step, output encoder step, output gain mismatch]`` (step 0: exact angle).
    """
    for i in range(x.shape[0]):
        for j, col in ((0, _I1), (1, _I2)):
            i2t[i, j] = i2t_update(i2t[i, j], x[i, col] ** 2, i_nom, dt)
        m = np.empty(3)
        for j, col in ((0, _TH1), (1, _TH2)):
            m[j] = x[i, col] if enc[0] == 0.0 else np.floor(x[i, col] / enc[0]) * enc[0]
        r = x[i, _R]
        m[2] = r if enc[1] == 0.0 else np.round((r + enc[2] * np.sin(2.0 * r)) / enc[1]) * enc[1]
        for j in range(3):
            vel[i, j] = update_velocity(meas[i, j], m[j], vel[i, j], dt, gain)
            meas[i, j] = m[j]


@numba.njit(cache=True)
def _common_obs_rows(meas: np.ndarray, vel: np.ndarray, cur: np.ndarray, i2t: np.ndarray, i2t_lim: np.ndarray,
                     P: np.ndarray, K_b: np.ndarray, ratio: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The common observation channels of ``rows``, ``(len(rows), N_COMMON_OBS)`` (see ``_common_channels``)."""
    out = np.empty((rows.shape[0], N_COMMON_OBS))
    for j in range(rows.shape[0]):
        i = rows[j]
        p = _P_ROW(P, i)
        q1 = pivot_position(p.pivot, meas[i, 0] / p.pivot_gearbox.n)
        q2 = meas[i, 1] / ratio[i]
        K_s = spring_stiffness(p.lever, q1, meas[i, 2] - q2)
        K = max(series_stiffness(K_s, K_b[i]), K_FLOOR) if K_s > 0 else K_FLOOR
        out[j, 0], out[j, 1], out[j, 2] = q1, q2, meas[i, 2]
        out[j, 3], out[j, 4], out[j, 5] = vel[i, 0], vel[i, 1], vel[i, 2]
        out[j, 6], out[j, 7], out[j, 8] = cur[i, 0], cur[i, 1], np.log(K)
        out[j, 9] = min(i2t[i, 0] / i2t_lim[i, 0], 1.0)
        out[j, 10] = min(i2t[i, 1] / i2t_lim[i, 1], 1.0)
    return out


@numba.njit(cache=True)
def _true_stiffness(x: np.ndarray, P: np.ndarray, K_b: np.ndarray) -> np.ndarray:
    """``VsaUT2Model.stiffness(x)``: eq. (6) at the true pivot and deflection in series with the belt, ``(n,)``."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        p = _P_ROW(P, i)
        K_s = spring_stiffness(p.lever, pivot_position(p.pivot, x[i, _TH1] / p.pivot_gearbox.n), x[i, _R] - x[i, _Q2])
        out[i] = series_stiffness(K_s, K_b[i])
    return out


@numba.njit(cache=True)
def _margin_rows(x: np.ndarray, i2t: np.ndarray, th1_max: np.ndarray, q2_max: np.ndarray, phi_max: np.ndarray,
                 lim: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Constraint margins of ``rows``, ``(len(rows), 4)``: frame stop, deflection stop, I^2 t, pivot stroke."""
    out = np.empty((rows.shape[0], 4))
    for j in range(rows.shape[0]):
        i = rows[j]
        q2, th1 = x[i, _Q2], x[i, _TH1]
        out[j, 0] = q2_max[i] - abs(q2)
        out[j, 1] = phi_max[i] - abs(x[i, _R] - q2)
        out[j, 2] = min(1.0 - i2t[i, 0] / lim[i, 0], 1.0 - i2t[i, 1] / lim[i, 1])
        out[j, 3] = min(th1, th1_max[i] - th1) / th1_max[i]
    return out
