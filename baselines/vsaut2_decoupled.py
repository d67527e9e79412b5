"""Decoupled position / stiffness controller of the vsaUT-II (voltage mode) as a policy object.

Position (frame motor): the output sits at ``r = q2 + phi``, so the frame is commanded to
``q2_ref = r_ref - phi_c`` where ``phi_c`` is the measured deflection ``r_hat - q2_hat`` through a
first-order low-pass (``deflection_filter_hz``): the static deflection under load is compensated
without closing a fast loop through the spring.  A PID on the frame angle (derivative on the
measured speed ``w2_hat``) drives the frame motor voltage.

Stiffness (pivot motor): the stiffness reference ``K_ref`` is inverted in three steps:
the belt in series (``K_s = K_ref K_b / (K_b - K_ref)``), eq. (6) at the current deflection
(``K_s / cos(2 phi_c)`` at phi = 0, then :func:`vsa_gym.devices.vsaut2.lever.pivot_for_stiffness`) and
eq. (5) (:func:`vsa_gym.devices.vsaut2.pivot.sun_angle_for`) to the pivot motor angle; a PID on the
pivot motor angle (derivative on ``w1_hat``) drives the pivot motor voltage.

Model feed-forward (both motors): ``u_ff = R i_ff + k_e w_ref`` with ``w_ref`` the motor speed of
the (differentiated, filtered) reference and ``i_ff`` the current that balances the modelled load:
on the frame the lever torque ``k l^2 rho^2 sin(2 phi_c)`` and the viscous friction ``c_ad``, on the
pivot the lever's pivot force ``F_q1`` through the mechanism's Jacobian (eqs. 4-6), both divided by
the gearbox ratio and its maximum efficiency.

I^2 t foldback (both motors), as a servo drive limits its current when its I^2 t protection fills
up: from the observed utilisation ``i2t_j`` (heating state over the trip threshold) the current limit
falls linearly from ``I_max`` at ``i2t_foldback[0]`` to ``i_foldback`` (below the nominal current, so the
heating state drains) at ``i2t_foldback[1]``; while it is below ``I_max`` the voltage is clamped to
``k_e w_hat +- R I_lim`` (the quasi-static current limit; the current settles within ``L/R``, 0.3 ms).

Anti-windup: the integrators are clamped and do not integrate while the voltage saturates (supply or
foldback limit) in the direction of the error.  The controller uses only the observation (15 channels of
``VsaUT2-PositionStiffness-v0``) and runs at the environment's ``control_dt`` (2 ms).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame
from vsa_gym.devices.vsaut2.lever import pivot_for_stiffness
from vsa_gym.devices.vsaut2.params import VsaUT2Params
from vsa_gym.devices.vsaut2.pivot import pivot_jacobian, sun_angle_for
from vsa_gym.physics.dc_motor import current_limited_voltage, foldback_current

VSAUT2_PS_OBS = ("q1_hat", "q2_hat", "r_hat", "w1_hat", "w2_hat", "r_dot_hat", "i1", "i2", "log_K_hat", "i2t_1",
                 "i2t_2", "r_ref", "log_K_ref", "r_err", "log_K_err")


@dataclasses.dataclass(frozen=True)
class VsaUT2DecoupledConfig:
    """Gains of the decoupled controller (tuned on the nominal model, see benchmarks.baselines).

    The frame gains were retuned when the I^2 t state became observable: the earlier ``kp_frame`` 400,
    ``kd_frame`` 0.02, ``output_damping`` 0.5, ``shaping_fraction`` 0.5 drove the frame loop into a 10-20 Hz
    limit cycle (frame voltage saturated most of the time, about 11 A rms) that tripped the frame drive's
    I^2 t protection in 10 of 12 full episodes (seeds 100-111).  A grid over ``output_damping`` {0, 0.1,
    0.25, 0.5}, ``kp_frame`` {100, 150, 250, 400}, ``kd_frame`` {0.02, 0.06, 0.1, 0.15} and
    ``shaping_fraction`` {0.5, 0.8, 1, 1.3} on seeds 100-111 and a final choice between four candidates
    on seeds 0-23 (which include the baseline table's seeds 0-2) chose these by the environment's return;
    the agents' held-out seeds 2_000_000 + k were not used.
    """

    # frame PID: volts per rad of frame angle error, per rad s, per (rad/s of motor speed)
    kp_frame: float = 250.0
    ki_frame: float = 800.0
    kd_frame: float = 0.06  # V per rad/s of frame *motor* speed (w2_hat)
    # pivot PID: volts per rad of pivot motor angle error
    kp_pivot: float = 0.6
    ki_pivot: float = 0.5
    kd_pivot: float = 0.002  # V per rad/s of pivot motor speed (w1_hat)
    int_max: float = 6.0  # V, integrator clamps
    deflection_filter_hz: float = 0.5  # low-pass of the deflection compensation (static load only)
    deflection_comp_max: float = 0.3  # rad, clamp of the compensation
    reference_filter_hz: float = 10.0  # low-pass on the stiffness reference before differentiation
    shaping_fraction: float = 1.0  # position reference shaped at this fraction of the output mode sqrt(K/I_o)
    output_damping: float = 0.25  # damping ratio injected through the frame (q2_ref -= 2 zeta sqrt(I_o/K) r_dot)
    feedforward: bool = True
    # I^2 t foldback: utilisation where the current limit starts to fall and where it reaches i_foldback
    i2t_foldback: tuple[float, float] = (0.5, 0.9)
    i_foldback: float = 3.0  # A, below the drives' nominal 4 A: the I^2 t state drains at the folded limit
    dt: float = 2e-3

    def __post_init__(self) -> None:
        lo, hi = self.i2t_foldback
        if not 0.0 <= lo < hi <= 1.0:
            raise ValueError(f"i2t_foldback must be (start, end) with 0 <= start < end <= 1, got {self.i2t_foldback}")
        if not self.i_foldback > 0.0:
            raise ValueError(f"i_foldback must be > 0 A, got {self.i_foldback}")


class VsaUT2Decoupled:
    """``reset()``, then ``policy(obs) -> [pivot, frame]`` voltage commands in ``[-1, 1]`` (module docstring)."""

    def __init__(self, config: VsaUT2DecoupledConfig | None = None, params: VsaUT2Params | None = None,
                 obs_names: Sequence[str] = VSAUT2_PS_OBS) -> None:
        self.config = VsaUT2DecoupledConfig() if config is None else config
        self.p = VsaUT2Params() if params is None else params
        self.idx = {name: k for k, name in enumerate(obs_names)}
        missing = [name for name in VSAUT2_PS_OBS if name not in self.idx]
        if missing:
            raise ValueError(f"obs_names lack the channel(s) {missing} the controller reads; got {list(obs_names)}")
        p = self.p
        self.K_b = float(belt_stiffness_at_frame(p.belt))
        self.q1_lo, self.q1_hi = 1.5 * float(p.lever.q1_min), float(p.q1_max)
        self.n1, self.ratio = float(p.pivot_gearbox.n), float(p.frame_ratio)
        self.m1, self.m2 = p.pivot_motor, p.frame_motor
        self.u1_max, self.u2_max = float(p.pivot_motor.U_max), float(p.frame_motor.U_max)
        self.reset()

    def reset(self) -> None:
        self.n: int | None = None
        self.last: dict[str, np.ndarray] = {}

    def _init(self, o: np.ndarray) -> None:
        n = o.shape[0]
        self.n = n
        self.phi_c = o[:, self.idx["r_hat"]] - o[:, self.idx["q2_hat"]]
        self.int1, self.int2 = np.zeros(n), np.zeros(n)
        self.q2_ref_f = None
        self.th1_ref_f = None

    def _lp(self, f_hz: float) -> float:
        return 1.0 - np.exp(-2.0 * np.pi * f_hz * self.config.dt)

    def pivot_angle_for(self, K: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Inverse of eqs. (5)-(6) with the belt in series: pivot motor angle (rad) giving output stiffness K."""
        K = np.minimum(K, 0.95 * self.K_b)
        K_s = K * self.K_b / (self.K_b - K)
        K_s = K_s / np.maximum(np.cos(2.0 * phi), 0.3)
        q1 = np.clip(pivot_for_stiffness(self.p.lever, K_s), self.q1_lo, self.q1_hi)
        return self.n1 * sun_angle_for(self.p.pivot, q1)

    def foldback_current(self, i_max: float, utilisation: np.ndarray) -> np.ndarray:
        """Current limit (A) at an I^2 t ``utilisation``: the amplifiers' foldback law
        (:func:`vsa_gym.physics.dc_motor.foldback_current`, which the environments' drives apply too) with this
        controller's ``i2t_foldback`` and ``i_foldback``."""
        lo, hi = self.config.i2t_foldback
        return foldback_current(i_max, self.config.i_foldback, np.asarray(utilisation, dtype=np.float64), lo, hi)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        cfg, p = self.config, self.p
        o = np.atleast_2d(np.asarray(obs, dtype=np.float64))
        single = np.ndim(obs) == 1
        if self.n != o.shape[0]:
            self._init(o)
        g = self.idx
        q1, q2, r = o[:, g["q1_hat"]], o[:, g["q2_hat"]], o[:, g["r_hat"]]
        w1, w2 = o[:, g["w1_hat"]], o[:, g["w2_hat"]]
        r_ref, K_ref = o[:, g["r_ref"]], np.exp(o[:, g["log_K_ref"]])
        dt = cfg.dt
        phi = r - q2
        self.phi_c = self.phi_c + self._lp(cfg.deflection_filter_hz) * (phi - self.phi_c)
        K_hat = np.exp(o[:, g["log_K_hat"]])

        # position: critically damped 2nd-order shaping below the output mode, then deflection
        # compensation and damping injection through the frame
        w_n = np.sqrt(np.maximum(K_hat, 0.5) / p.I_o)
        w_s = cfg.shaping_fraction * w_n
        if self.q2_ref_f is None:
            self.r_s, self.r_sd = r_ref.copy(), np.zeros_like(r_ref)
            self.th1_ref_f = self.pivot_angle_for(K_ref, self.phi_c)
            self.q2_ref_f = q2.copy()
        acc = w_s**2 * (r_ref - self.r_s) - 2.0 * w_s * self.r_sd
        self.r_sd = self.r_sd + acc * dt
        self.r_s = self.r_s + self.r_sd * dt
        comp = np.clip(self.phi_c, -cfg.deflection_comp_max, cfg.deflection_comp_max)
        # moving the frame against the output's speed makes the spring torque oppose that speed
        damp = -2.0 * cfg.output_damping * np.sqrt(p.I_o / np.maximum(K_hat, 0.5)) * o[:, g["r_dot_hat"]]
        q2_ref = np.clip(self.r_s - comp + damp, -0.95 * p.q2_max, 0.95 * p.q2_max)
        w2_ref = self.ratio * self.r_sd
        self.q2_ref_f = q2_ref

        # stiffness: inverse of eqs. (5)-(6), low-passed so that its derivative (feed-forward speed) is bounded
        th1_ref = self.pivot_angle_for(K_ref, self.phi_c)
        th1_prev = self.th1_ref_f.copy()
        self.th1_ref_f = self.th1_ref_f + self._lp(cfg.reference_filter_hz) * (th1_ref - self.th1_ref_f)
        w1_ref = (self.th1_ref_f - th1_prev) / dt

        # measured pivot motor angle from q1_hat (eq. 5 inverted)
        th1 = self.n1 * sun_angle_for(p.pivot, np.clip(q1, 0.0, 2.0 * p.pivot.D_p))

        # feed-forward
        u1_ff = np.zeros_like(q1)
        u2_ff = np.zeros_like(q1)
        if cfg.feedforward:
            lv = p.lever
            qc = np.maximum(q1, lv.q1_min)
            rho = (lv.l - qc) / qc
            tau_frame = lv.k * lv.l**2 * rho**2 * np.sin(2.0 * self.phi_c) + p.c_ad * w2_ref / self.ratio
            i2 = tau_frame / (self.ratio * self.m2.k_t * p.frame_gearbox.eta_max)
            u2_ff = self.m2.R * i2 + self.m2.k_e * w2_ref
            F_q1 = 2.0 * lv.k * lv.l**3 * (lv.l - qc) * np.sin(self.phi_c) ** 2 / qc**3
            tau_sun = -F_q1 * pivot_jacobian(p.pivot, th1 / self.n1)
            i1 = tau_sun / (self.n1 * self.m1.k_t * p.pivot_gearbox.eta_max)
            u1_ff = self.m1.R * i1 + self.m1.k_e * w1_ref

        e2 = self.q2_ref_f - q2
        e1 = self.th1_ref_f - th1
        u2 = cfg.kp_frame * e2 + self.int2 - cfg.kd_frame * (w2 - w2_ref) + u2_ff
        u1 = cfg.kp_pivot * e1 + self.int1 - cfg.kd_pivot * (w1 - w1_ref) + u1_ff
        u1_free, u2_free = u1, u2
        # I^2 t foldback: clamp the voltage to the folded current limit around the back-EMF
        lim1 = self.foldback_current(self.m1.I_max, o[:, g["i2t_1"]])
        lim2 = self.foldback_current(self.m2.I_max, o[:, g["i2t_2"]])
        # (only while folding back: at I_max the amplifier's own limit acts, on the true speed)
        u1 = current_limited_voltage(self.m1, u1, w1, lim1)
        u2 = current_limited_voltage(self.m2, u2, w2, lim2)
        u1, u2 = np.clip(u1, -self.u1_max, self.u1_max), np.clip(u2, -self.u2_max, self.u2_max)
        # conditional integration (anti-windup): freeze where a limit holds the voltage in the error's direction
        sat2 = (u2 != u2_free) & (np.sign(u2_free) == np.sign(e2))
        sat1 = (u1 != u1_free) & (np.sign(u1_free) == np.sign(e1))
        self.int2 = np.clip(self.int2 + np.where(sat2, 0.0, cfg.ki_frame * e2 * dt), -cfg.int_max, cfg.int_max)
        self.int1 = np.clip(self.int1 + np.where(sat1, 0.0, cfg.ki_pivot * e1 * dt), -cfg.int_max, cfg.int_max)
        act = np.stack([np.clip(u1 / self.u1_max, -1, 1), np.clip(u2 / self.u2_max, -1, 1)], axis=1)
        self.last = {"q2_ref": self.q2_ref_f.copy(), "th1_ref": self.th1_ref_f.copy(), "int_pivot": self.int1.copy(),
                     "int_frame": self.int2.copy(), "u_pivot": u1, "u_frame": u2}
        return (act[0] if single else act).astype(np.float32)


def vsaut2_decoupled_factory(config: VsaUT2DecoupledConfig | None = None):  # noqa: ANN201
    """``policy_factory(env)`` for :func:`baselines.metrics.evaluate_policy`."""

    def make(env) -> VsaUT2Decoupled:  # noqa: ANN001
        task = env.unwrapped.task
        cfg = dataclasses.replace(config or VsaUT2DecoupledConfig(), dt=float(task.control_dt))
        return VsaUT2Decoupled(cfg, task.base_rows[0], [c.name for c in task.obs_channels])

    return make
