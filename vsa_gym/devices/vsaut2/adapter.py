"""Identification adapter of the vsaUT-II: replay a record through the envs' compiled core.

The replay is the nominal :class:`~vsa_gym.devices.vsaut2.model.VsaUT2Model` (the same
``rhs_point`` the environments integrate), batched over candidate parameter rows:
the parameters are flattened once (:func:`~vsa_gym.physics.kernels.flatten_rows`),
each candidate edits its own row, and one numba rollout steps all rows through
the compiled RK4 (:func:`vsa_gym.devices.vsaut2.model.rk4_rows`).  The effects are
parameters of that core (``params.effects``, :class:`~vsa_gym.devices.vsaut2.params.VsaUT2Effects`)
or plain parameter errors, so :meth:`Vsaut2Adapter.identified_params` returns a
:class:`~vsa_gym.devices.vsaut2.params.VsaUT2Params` that ``gym.make(ID, params=...)`` accepts.

Experiments (selected by the record's inputs; all sampled on a uniform grid, inputs held):

* free oscillation -- ``voltage_pivot`` / ``voltage_frame`` (0 V: frame motor short-circuited);
* constant-current frame actuation -- ``current_frame``: the current-mode amplifier of
  :func:`~vsa_gym.physics.dc_motor.current_control_voltage` (1 kHz loop) evaluated at every
  0.1 ms substep, as in :func:`~vsa_gym.devices.vsaut2.experiments.fig9_q2_response`;
* torque-deflection sweep -- ``external_torque`` with the frame motor held by a stiff PD
  voltage loop on its encoder (``model.frame_hold = {"kp": V/rad, "kd": V s/rad}``).

Sidecar ``model`` section: ``{"params": {nested VsaUT2Params fields}, "free": {"c_o": [lo, hi],
"lever.k": [lo, hi]}, "r_sensor": "AS5043"}``; ``initial_state``: ``{"q1": m, "q2": rad, "r": rad}``.
Outputs: ``r``, ``q2`` (``"at": "motor"``: the frame motor encoder divided by the frame
ratio, which includes the belt stretch and backlash), ``phi``, ``i2``.  With
``r_sensor = "AS5043"`` the simulated ``r`` carries the encoder's gain-mismatch error
(its quantisation is left to the data: it has no gradient).

Hysteresis (Dahl, ``effects.M_h`` / ``effects.phi_h``) is a state column of the same compiled core
(``EFFECT_STATE["h_phi"]``): the rollout carries it when some candidate row has ``M_h > 0``.  It is offered on
records whose deflection is swept by an external torque (the torque-deflection sweep).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numba
import numpy as np

from vsa_gym.devices.vsaut2.effects import LIBRARY as VSAUT2_LIBRARY
from vsa_gym.devices.vsaut2.model import EFFECT_STATE, N_STATES, STATE, SUBSTEPS_PER_MS, VsaUT2Model, rk4_rows
from vsa_gym.devices.vsaut2.params import AS5043Encoder, VsaUT2Params
from vsa_gym.identify.adapters import Adapter, Theta, theta_column
from vsa_gym.identify.effects import EffectSpec, ParamSpec
from vsa_gym.identify.library import physics_specs
from vsa_gym.identify.record import Record
from vsa_gym.physics.kernels import flatten_rows

OUTPUT_STATE = {"r": STATE["r"], "q2": STATE["q2"], "i2": STATE["i2"]}
MODES = ("voltage", "current", "hold")


def leaf_names(p: VsaUT2Params) -> list[str]:
    """Dotted names of the leaves of ``p.as_tuple()``, in :func:`flatten_rows` column order."""
    out: list[str] = []

    def walk(t: Any, prefix: str) -> None:
        for name, v in zip(t._fields, t, strict=True):
            if isinstance(v, tuple) and hasattr(v, "_fields"):
                walk(v, f"{prefix}{name}.")
            else:
                out.append(prefix + name)

    walk(p.as_tuple(), "")
    return out


def _replace_dotted(p: VsaUT2Params, changes: Mapping[str, float]) -> VsaUT2Params:
    nested: dict[str, dict[str, float]] = {}
    top: dict[str, Any] = {}
    for k, v in changes.items():
        if "." in k:
            a, b = k.split(".", 1)
            nested.setdefault(a, {})[b] = float(v)
        else:
            top[k] = float(v)
    for a, sub in nested.items():
        top[a] = getattr(p, a).replace(**sub)
    return p.replace(**top)


@numba.njit(cache=True)
def _rollout(x0: np.ndarray, u: np.ndarray, tau: np.ndarray, mode: int, P: np.ndarray, D: np.ndarray,
             dt: float, n_sub: int, R2: float, ke2: float, L2: float, wc: float, kp: float, kd: float,
             th2_0: np.ndarray) -> np.ndarray:
    """States ``(T, n, n_x)`` at the sample times; inputs held over each sample interval.

    ``x0`` ``(n, n_x)``: the 10 core states, or 11 with the hysteresis state.  ``u`` ``(T, 2)``: pivot voltage
    and the frame command (voltage, current reference, or unused in hold mode); ``tau`` ``(T, n)``.  Modes 1
    (current) and 2 (hold) update the frame voltage at every substep.
    """
    T = u.shape[0]
    n = x0.shape[0]
    xs = np.empty((T, n, x0.shape[1]))
    x = x0.copy()
    xs[0] = x
    uk = np.empty((n, 2))
    h = dt / n_sub
    for k in range(T - 1):
        if mode == 0:
            for i in range(n):
                uk[i, 0] = u[k, 0]
                uk[i, 1] = u[k, 1]
            x, _ = rk4_rows(x, uk, tau[k], P, D, dt, n_sub)
        else:
            for _ in range(n_sub):
                for i in range(n):
                    uk[i, 0] = u[k, 0]
                    if mode == 1:
                        uk[i, 1] = R2 * u[k, 1] + ke2 * x[i, 5] + L2 * wc * (u[k, 1] - x[i, 3])
                    else:
                        uk[i, 1] = -kp * (x[i, 4] - th2_0[i]) - kd * x[i, 5]
                x, _ = rk4_rows(x, uk, tau[k], P, D, h, 1)
        xs[k + 1] = x
    return xs


class Vsaut2Adapter(Adapter):
    """The vsaUT-II core replaying a record (module docstring)."""

    def __init__(self, record: Record, replay: str | None = None) -> None:
        super().__init__(record)
        model = record.model
        self.params = VsaUT2Params.from_dict(model.get("params", {}))
        self.names = leaf_names(self.params)
        self.col = {k: i for i, k in enumerate(self.names)}
        self.base = []
        for name, (lo, hi) in model.get("free", {}).items():
            if name not in self.col:
                raise ValueError(f"model.free: {name!r} is not a vsaUT-II parameter (dotted leaf name)")
            v = float(flatten_rows(self.params.as_tuple())[0, self.col[name]])
            self.base.append(ParamSpec(name, "", float(lo), float(hi), v, max(abs(v), 1e-9)))
        ins = record.inputs
        T = len(record)
        self.u = np.zeros((T, 2))
        if "voltage_pivot" in ins:
            self.u[:, 0] = record.input("voltage_pivot")
        if "current_frame" in ins:
            self.mode = 1
            self.u[:, 1] = record.input("current_frame")
        elif "frame_hold" in model:
            self.mode = 2
        else:
            self.mode = 0
            if "voltage_frame" in ins:
                self.u[:, 1] = record.input("voltage_frame")
        hold = model.get("frame_hold", {})
        self.kp, self.kd = float(hold.get("kp", 0.0)), float(hold.get("kd", 0.0))
        self.tau = record.input("external_torque") if "external_torque" in ins else np.zeros(T)
        init = record.meta.get("initial_state", {})
        self.q1_0 = float(init.get("q1", 0.0))
        self.q2_0 = float(init.get("q2", 0.0))
        r0 = init.get("r")
        if r0 is None and "r" in record.outputs:
            r0 = float(record.output("r")[0])
        self.r_0 = self.q2_0 if r0 is None else float(r0)
        self.obs = []
        for s in self.outputs:
            at = record.meta["outputs"][s.column].get("at", "load")
            if s.quantity == "tau_out":
                raise ValueError("vsaut2 adapter: tau_out outputs are not replayed; use r, q2, phi or i2")
            self.obs.append("q2_motor" if (s.quantity == "q2" and at == "motor") else s.quantity)
        self.r_sensor = AS5043Encoder() if str(model.get("r_sensor", "")).upper() == "AS5043" else None
        self.frame_actuated = self.mode in (1,) or bool(np.any(self.u[:, 1] != 0.0))
        self.joint = "frame" if self.frame_actuated else "output"
        #: an external torque sweeps the deflection (the torque-deflection sweep): where hysteresis is offered
        self.torque_driven = not self.frame_actuated and bool(np.any(self.tau != 0.0))
        self.n_sub = max(1, int(round(self.dt / 1e-3 * SUBSTEPS_PER_MS)))
        self._scales()
        self.effects = self._effects()

    def for_record(self, record: Record) -> Vsaut2Adapter:
        other = Vsaut2Adapter(record)
        other.effects, other.base = self.effects, self.base
        other.T_ref, other.v_ref, other.x_ref = self.T_ref, self.v_ref, self.x_ref
        return other

    # ------------------------------------------------------------------ parameters
    def changes(self, theta: Theta, n: int) -> dict[str, np.ndarray]:
        """Per-row values ``(n,)`` of the parameters the candidate changes, by dotted leaf name."""
        base = flatten_rows(self.params.as_tuple())[0]

        def cur(name: str) -> np.ndarray:
            return out.get(name, np.full(n, base[self.col[name]]))

        out: dict[str, np.ndarray] = {}
        for b in self.base:
            out[b.name] = theta_column(theta, f"base.{b.name}", n, b.absent).copy()
        J = self.joint
        c_key, I_key = ("c_o", "I_o") if J == "output" else ("c_ad", "I_ad")
        fc_key = "effects.F_c_o" if J == "output" else "effects.F_c_ad"
        if "coulomb_friction.F_c" in theta:
            out[fc_key] = cur(fc_key) + theta_column(theta, "coulomb_friction.F_c", n)
        if "stribeck_friction.F_s" in theta:
            out["effects.F_s_o"] = cur("effects.F_s_o") + theta_column(theta, "stribeck_friction.F_s", n)
            if "stribeck_friction.w_s" in theta:
                out["effects.w_s_o"] = theta_column(theta, "stribeck_friction.w_s", n).copy()
        if "viscous_friction.b" in theta:
            out[c_key] = cur(c_key) + theta_column(theta, "viscous_friction.b", n)
        if "inertia_error.rel" in theta:
            out[I_key] = cur(I_key) * (1.0 + theta_column(theta, "inertia_error.rel", n))
        if "spring_stiffness_drift.drift" in theta:
            out["lever.k"] = cur("lever.k") * (1.0 + theta_column(theta, "spring_stiffness_drift.drift", n))
        if "backlash.width" in theta:
            out["effects.b_belt"] = cur("effects.b_belt") + theta_column(theta, "backlash.width", n)
        if "transmission_compliance.compliance" in theta:
            compliance = theta_column(theta, "transmission_compliance.compliance", n)
            out["belt.C_belt"] = 1.0 / (1.0 / cur("belt.C_belt") + compliance)
        if "gearbox_efficiency.loss" in theta:
            out["frame_gearbox.eta_max"] = cur("frame_gearbox.eta_max") * (1.0 - theta_column(theta,
                                                                                      "gearbox_efficiency.loss", n))
        if "hysteresis.M_h" in theta:
            out["effects.M_h"] = cur("effects.M_h") + theta_column(theta, "hysteresis.M_h", n)
            if "hysteresis.phi_h" in theta:
                out["effects.phi_h"] = theta_column(theta, "hysteresis.phi_h", n).copy()
        return out

    def identified_params(self, theta: Mapping[str, float]) -> VsaUT2Params:
        """The identified model as a :class:`VsaUT2Params` (``gym.make(ID, params=...)`` takes it).

        ``force_offset`` and the sensor effects are not parameters of the plant and are left out.
        """
        ch = self.changes({k: np.array([v]) for k, v in theta.items()}, 1)
        return _replace_dotted(self.params, {k: float(v[0]) for k, v in ch.items()})

    def describe_model(self, theta: Mapping[str, float]) -> dict[str, Any]:
        return self.identified_params(theta).to_dict()

    # ------------------------------------------------------------------ simulation
    def simulate_states(self, theta: Theta, n: int) -> np.ndarray:
        P = np.repeat(flatten_rows(self.params.as_tuple()), n, axis=0)
        for name, v in self.changes(theta, n).items():
            P[:, self.col[name]] = v
        model = VsaUT2Model(self.params)
        x0 = model.initial_state(n, q1=self.q1_0, q2=self.q2_0, r=self.r_0)
        # the hysteresis state column (starting at 0) when some row has it on
        x0 = np.concatenate([x0[:, :N_STATES], np.zeros((n, len(EFFECT_STATE)))], axis=1) \
            if np.any(P[:, [self.col["effects.M_h"], self.col["effects.mu_h"]]] > 0.0) else x0[:, :N_STATES]
        D = model.d_rows
        tau = self.tau[:, None] + theta_column(theta, "force_offset.F_0", n)[None, :]
        m = self.params.frame_motor
        return _rollout(np.ascontiguousarray(x0), np.ascontiguousarray(self.u),
                        np.ascontiguousarray(tau), self.mode, np.ascontiguousarray(P), D, float(self.dt),
                        int(self.n_sub), float(m.R), float(m.k_e), float(m.L), 2.0 * np.pi * 1000.0, self.kp,
                        self.kd, np.ascontiguousarray(x0[:, STATE["th2"]]))

    def simulate_physical(self, theta: Theta, n: int) -> np.ndarray:
        xs = self.simulate_states(theta, n)
        ratio = float(self.params.frame_ratio)
        out = np.empty((xs.shape[0], n, len(self.obs)))
        for j, q in enumerate(self.obs):
            if q == "q2_motor":
                out[:, :, j] = xs[:, :, STATE["th2"]] / ratio
            elif q == "phi":
                out[:, :, j] = xs[:, :, STATE["r"]] - xs[:, :, STATE["q2"]]
            else:
                out[:, :, j] = xs[:, :, OUTPUT_STATE[q]]
            if q == "r" and self.r_sensor is not None:
                out[:, :, j] += float(self.r_sensor.gain_mismatch) * np.sin(2.0 * out[:, :, j])
        return out

    # ------------------------------------------------------------------ catalogue
    def _scales(self) -> None:
        xs = self.simulate_states({}, 1)[:, 0, :]
        p = self.params
        if self.joint == "output":
            w, q = xs[:, STATE["r_dot"]], xs[:, STATE["r"]]
            inertia = float(p.I_o)
        else:
            w, q = xs[:, STATE["q2_dot"]], xs[:, STATE["q2"]]
            J2 = float(p.frame_motor.J + p.frame_gearbox.J_in)
            inertia = float(p.I_ad + p.I_o + J2 * float(p.frame_ratio) ** 2)
        acc = np.gradient(w, self.dt)
        self.T_ref = inertia * float(np.max(np.abs(acc))) or 1.0
        if np.any(self.tau != 0.0):
            self.T_ref = max(self.T_ref, float(np.max(np.abs(self.tau))))
        self.v_ref = float(np.max(np.abs(w))) or 1.0
        self.x_ref = float(np.std(q)) or 1.0

    def _effects(self) -> dict[str, EffectSpec]:
        """The vsaUT-II library's effects that apply to this record (:mod:`vsa_gym.devices.vsaut2.effects`), then
        the output sensors' measurement effects."""
        eff = physics_specs(VSAUT2_LIBRARY, self)
        eff.update(self._sensor_effects())
        return eff

    @property
    def free(self) -> set[str]:
        """The nominal parameters fitted as base parameters (``model.free``, dotted leaf names)."""
        return {b.name for b in self.base}


__all__ = ["Vsaut2Adapter", "leaf_names"]
