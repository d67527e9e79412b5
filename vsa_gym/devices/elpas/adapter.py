"""Replay of eLPAS hydropulse-rig records (force tests) through the eLPAS core and the paper's controller.

A rig record has the inputs ``force_reference`` (N) and the imposed wishbone angle
``alpha`` (rad), and the outputs ``force`` (actuator force sensor, N) and/or
``gamma`` (arm angle from the motor encoder, rad).  Row ``k`` holds the values at
``t_k``; the controller acts once per sample (``dt`` of the record = the
cascade's rate).

The sine and step force tests of the paper are closed-loop: the replay runs the
*same* controller the environments and baselines run --
:class:`baselines.elpas_cascade.ElpasCascade` (force low-pass, lookup
``gamma_ref(F_ref)``, lead-lag + clamped integrator; designed with the *nominal*
parameters, as the real controller was) on the observation it would see (the
motor-encoder ``gamma_hat``, the 12-bit ``alpha_hat``, ``force_ref``; unquantised unless
``quantised_feedback``), and the environments' 10 kHz PI current loop
(:func:`vsa_gym.devices.elpas.current_loop.current_loop_rows`, gains
:class:`~vsa_gym.devices.elpas.current_loop.ElpasCurrentLoop`)
between control steps, with ``alpha`` interpolated linearly.  Each 0.1 ms step is
the compiled core of :func:`vsa_gym.devices.elpas.model.step_rig`
(:func:`vsa_gym.devices.elpas.integrator.advance_row`: the
same ETDRK4 and the same refinement of speed reversals), batched over the candidate
parameter rows; one control step of all rows is one compiled call.

The current loop uses the controller's (nominal) ``K_T`` and ``R``: it is the
amplifier's firmware, not the plant.  With nominal motor parameters this is exactly
the environment's loop.

Effects (all parameters of the compiled core, so the replay runs them; the stateful arm hysteresis is the core's
effect-state column, present in the replay when some candidate row has ``M_h > 0``):

* ``coulomb_friction.F_c`` (N m at the motor): added to ``friction.F_c`` *and*
  ``friction.F_s`` (the whole Stribeck curve shifts: "friction underestimated");
* ``stribeck_friction.F_s``: added to ``friction.F_s`` only (the break-away hump);
* ``viscous_friction.s2``: added to ``friction.s2``;
* ``spring_stiffness_drift.drift``: ``cone.C_a *= 1 + drift``;
* ``inertia_error.rel``: ``drive.J_r *= 1 + rel``;
* ``gearbox_efficiency.loss``: the motor moment reaching the reductor, ``K_T (1 - loss) i``
  (a symmetric efficiency);
* ``hysteresis.M_h`` (N m), ``hysteresis.phi_h`` (rad): the arm hysteresis (Dahl) about gamma, ``effects.M_h`` /
  ``effects.phi_h`` of :class:`~vsa_gym.devices.elpas.params.ElpasEffects`;
* ``alpha_offset.offset`` (rad): the wishbone is at ``alpha_rec + offset`` -- the
  paper's alignment error (nonzero disturbance moment at alpha = 0); the controller
  still sees the recorded alpha;
* ``sensor_gain`` / ``sensor_offset`` / ``sensor_delay`` of the first output (the force sensor).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from vsa_gym.devices.elpas import model as em
from vsa_gym.devices.elpas.cone import spring_unchecked
from vsa_gym.devices.elpas.current_loop import ElpasCurrentLoop, current_loop_rows, loop_steps
from vsa_gym.devices.elpas.effects import LIBRARY as ELPAS_LIBRARY
from vsa_gym.devices.elpas.packing import params_tuple, tuple_matrix
from vsa_gym.devices.elpas.params import ElpasAlphaEncoder, ElpasMotorEncoder, ElpasParams
from vsa_gym.identify.adapters import Adapter, Theta, theta_column
from vsa_gym.identify.effects import EffectSpec
from vsa_gym.identify.library import physics_specs
from vsa_gym.identify.record import Record

#: ``model.params`` of the sidecar: overrides of the nominal parameters, ``"group.field": value``
PARAM_GROUPS = ("motor", "friction", "drive", "cone")


def _tuple(p: ElpasParams, n: int) -> Any:
    """Fresh (uncached, writable) named tuples of ``(n,)`` arrays (the parameter-type effects change them)."""
    t = params_tuple(p, n)
    return type(t)(*(type(g)(*(np.array(a, copy=True) for a in g)) for g in t))


class ElpasAdapter(Adapter):
    """eLPAS rig records, closed-loop replay through :class:`~baselines.elpas_cascade.ElpasCascade`.

    Sidecar ``controller``: ``{"type": "elpas_cascade", <ElpasCascadeConfig fields>}`` (``dt`` is the
    record's); ``model``: ``{"params": {"friction.F_c": ..., ...}}`` overrides the nominal set.
    ``initial_state``: ``{"gamma": rad}`` (default: the first ``gamma`` sample, else the lookup
    of the first force reference); the rig starts at rest.
    """

    def __init__(self, record: Record, replay: str | None = None) -> None:
        super().__init__(record)
        if replay not in (None, "closed_loop"):
            raise ValueError("eLPAS rig records are replayed in closed loop through the paper's cascade")
        from baselines.elpas_cascade import ElpasCascade, ElpasCascadeConfig  # the controller of the baselines

        self.replay = "closed_loop"
        #: feed the controller the quantised encoders, as the environments do.  Off for fitting: the
        #: 5e-5 rad steps make the replay jump with the parameters and the finite-difference
        #: Jacobians of the fit useless (the force they cause is a few 0.01 N).
        self.quantised_feedback = False
        self.nominal = self._nominal(record.model.get("params", {}))
        ctrl = dict(record.controller or {"type": "elpas_cascade"})
        if ctrl.pop("type", None) != "elpas_cascade":
            raise ValueError("eLPAS rig records need controller type 'elpas_cascade' (the paper's cascade)")
        fields = {f.name for f in dataclasses.fields(ElpasCascadeConfig)}
        unknown = set(ctrl) - fields
        if unknown:
            raise ValueError(f"controller: unknown ElpasCascadeConfig fields {sorted(unknown)}")
        self.cfg = ElpasCascadeConfig(**{**ctrl, "dt": self.dt})
        self._cascade_cls = ElpasCascade
        if "force_reference" not in record.inputs:
            raise ValueError("eLPAS rig replay needs the input 'force_reference' (closed-loop force tests)")
        for s in self.outputs:
            if s.quantity not in ("force", "gamma"):
                raise ValueError(f"eLPAS rig replay compares force and gamma, not {s.quantity!r}")
        self.f_ref = record.input("force_reference")
        self.alpha = record.input("alpha")
        self.loop = ElpasCurrentLoop()
        self.n_inner, self.h, self.n_sub = loop_steps(self.dt)
        self.motor_encoder = ElpasMotorEncoder()
        self.alpha_encoder = ElpasAlphaEncoder()
        init = record.meta.get("initial_state", {})
        g0 = init.get("gamma")
        if g0 is None and "gamma" in record.outputs:
            g0 = float(record.output("gamma")[0])
        if g0 is None:
            g0 = float(self._cascade().lookup(self.f_ref[:1])[0])
        self.gamma0 = float(g0)
        self.base = []
        self.effects = self._effects()

    @staticmethod
    def _nominal(overrides: Mapping[str, float]) -> ElpasParams:
        p = ElpasParams()
        groups: dict[str, dict[str, float]] = {}
        for key, v in overrides.items():
            g, _, f = key.partition(".")
            if g not in PARAM_GROUPS or not f or f not in {x.name for x in dataclasses.fields(getattr(p, g))}:
                raise ValueError(f"model.params: {key!r} is not an eLPAS parameter ('group.field', groups "
                                 f"{PARAM_GROUPS})")
            groups.setdefault(g, {})[f] = float(v)
        return p.replace(**{g: dataclasses.replace(getattr(p, g), **kv) for g, kv in groups.items()})

    def _cascade(self) -> Any:
        return self._cascade_cls(self.cfg, self.nominal, ("gamma_hat", "alpha_hat", "force_ref"))

    def for_record(self, record: Record) -> ElpasAdapter:
        other = ElpasAdapter(record)
        other.effects = self.effects
        return other

    def _effects(self) -> dict[str, EffectSpec]:
        """The eLPAS library's effects (:mod:`vsa_gym.devices.elpas.effects`), then the force sensor's measurement
        effects when the force is the first output."""
        eff = physics_specs(ELPAS_LIBRARY, self)
        if "force" in self.record.outputs and self.outputs[0].quantity == "force":
            eff.update(self._sensor_effects())
        return eff

    # ------------------------------------------------------------------ replay
    def param_tuple(self, theta: Theta, n: int) -> Any:
        t = _tuple(self.nominal, n)
        dF_c = theta_column(theta, "coulomb_friction.F_c", n)
        t.friction.F_c[:] += dF_c
        t.friction.F_s[:] += dF_c + theta_column(theta, "stribeck_friction.F_s", n)
        t.friction.s2[:] += theta_column(theta, "viscous_friction.s2", n)
        t.cone.C_a[:] *= 1.0 + theta_column(theta, "spring_stiffness_drift.drift", n)
        t.drive.J_r[:] *= 1.0 + theta_column(theta, "inertia_error.rel", n)
        t.motor.k_t[:] *= 1.0 - theta_column(theta, "gearbox_efficiency.loss", n)
        t.effects.M_h[:] += theta_column(theta, "hysteresis.M_h", n)
        if "hysteresis.phi_h" in theta:  # absent: the nominal presliding angle
            t.effects.phi_h[:] = theta_column(theta, "hysteresis.phi_h", n)
        return t

    def simulate_states(self, theta: Theta, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(gamma, F_act)`` trajectories ``(T, n)`` (true, before the sensors)."""
        p = self.param_tuple(theta, n)
        P = tuple_matrix(p)
        a_off = theta_column(theta, "alpha_offset.offset", n)
        T = len(self.t)
        nom = self.nominal
        N = float(nom.drive.N)
        alpha = self.alpha[:, None] + a_off[None, :]
        x = em.initial_state_rig(nom, n, gamma=self.gamma0, alpha=0.0)
        if np.any(p.effects.M_h > 0.0) and x.shape[1] == em.N_RIG:  # the arm hysteresis' state column, h = 0
            x = np.concatenate([x, np.zeros((n, 1))], axis=1)
        x[:, em.ALPHA] = alpha[0]
        pi_int = np.zeros(n)
        cascade = self._cascade()
        cascade.reset()
        obs = np.empty((n, 3))
        gam = np.empty((T, n))
        k_t, R, lp = float(nom.motor.k_t), float(nom.motor.R), self.loop
        i_max = float(nom.motor.I_max)
        alpha_hat = self.alpha_encoder.measure(self.alpha) if self.quantised_feedback else self.alpha
        for k in range(T):
            gam[k] = x[:, em.GAMMA]
            if k == T - 1:
                break
            obs[:, 0] = self.motor_encoder.measure(N * x[:, em.GAMMA]) / N if self.quantised_feedback else \
                x[:, em.GAMMA]
            obs[:, 1] = alpha_hat[k]
            obs[:, 2] = self.f_ref[k]
            i_ref = np.asarray(cascade(obs), dtype=np.float64)[:, 0] * i_max
            current_loop_rows(x, i_ref, pi_int, alpha[k], alpha[k + 1], P, self.h, self.n_inner, self.n_sub, False,
                              k_t, R, lp.P_m, lp.I_m, lp.I_m_max)  # x, pi_int in place
            if not np.all(np.isfinite(x)):  # a diverging candidate row: freeze it (huge residual, no crash)
                x = np.where(np.isfinite(x), x, 0.0)
        F = spring_unchecked(p.cone, gam, alpha).F_act
        return gam, F

    def simulate_physical(self, theta: Theta, n: int) -> np.ndarray:
        # gamma is compared unquantised (the sidecar's floor quantiser is the measurement model's bias):
        # a quantised output would make the finite-difference Jacobians of the fit useless
        gam, F = self.simulate_states(theta, n)
        cols = [F if s.quantity == "force" else gam for s in self.outputs]
        return np.stack(cols, axis=2)

    def describe_model(self, theta: Mapping[str, float]) -> dict[str, Any]:
        """The identified parameters (``group.field`` of :class:`ElpasParams` that the effects changed)."""
        t = self.param_tuple({k: np.array([v]) for k, v in theta.items()}, 1)
        out = {f"{g}.{f}": float(getattr(getattr(t, g), f)[0]) for g, f in (
            ("friction", "F_c"), ("friction", "F_s"), ("friction", "s2"), ("cone", "C_a"), ("drive", "J_r"),
            ("motor", "k_t"), ("effects", "M_h"), ("effects", "phi_h"))}
        out["alpha_offset"] = float(theta.get("alpha_offset.offset", 0.0))
        return out

    def identified_params(self, theta: Mapping[str, float]) -> ElpasParams:
        """The identified model as an :class:`ElpasParams` (``gym.make(ID, params=...)`` takes it).

        ``theta``: fitted values by ``"effect.param"`` key (e.g. ``result.final.theta()``).  The
        parameter-type effects change ``friction.F_c``/``F_s``/``s2``, ``cone.C_a``, ``drive.J_r``,
        ``motor.k_t`` and the arm hysteresis ``effects.M_h``/``phi_h`` exactly as in the replay
        (:meth:`param_tuple`).  Left out, because they are not parameters of the plant: ``alpha_offset`` (an
        alignment of the rig) and the force sensor's gain/offset/delay.  Note: with ``gearbox_efficiency`` the
        environments' current loop computes its torque error with the returned (reduced) ``k_t``, the replay
        with the nominal one.
        """
        t = self.param_tuple({k: np.array([float(v)]) for k, v in theta.items()}, 1)
        p = self.nominal

        def val(group: str, field: str) -> float:
            return float(getattr(getattr(t, group), field)[0])

        return p.replace(
            friction=dataclasses.replace(p.friction, F_c=val("friction", "F_c"), F_s=val("friction", "F_s"),
                                         s2=val("friction", "s2")),
            cone=dataclasses.replace(p.cone, C_a=val("cone", "C_a")),
            drive=dataclasses.replace(p.drive, J_r=val("drive", "J_r")),
            motor=dataclasses.replace(p.motor, k_t=val("motor", "k_t")),
            effects=dataclasses.replace(p.effects, M_h=val("effects", "M_h"), phi_h=val("effects", "phi_h")))


__all__ = ["ElpasAdapter"]
