"""The generic drive's identification adapter: replays a drive record (open or closed loop, the sensors as
declared) through the drive model (:mod:`vsa_gym.devices.drive.model`) with a batch of candidate parameters; its
candidate effects are the drive's library (:mod:`vsa_gym.devices.drive.effects`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from vsa_gym.devices.drive import model as drive
from vsa_gym.devices.drive.effects import LIBRARY as DRIVE_LIBRARY
from vsa_gym.devices.drive.effects import ZETA_COMPLIANCE
from vsa_gym.identify.adapters import SENSOR_KEYS, Adapter, Theta, theta_column, theta_rows
from vsa_gym.identify.effects import EffectSpec, ParamSpec
from vsa_gym.identify.library import physics_specs
from vsa_gym.identify.record import TRANSMISSIONS, Record

# ----------------------------------------------------------------------------- generic drive
#: nuisance parameter of a drive whose start force is not declared: the share of the settled drive force at t0
START_SHARE = "start_share"
#: nuisance parameter of a voltage input with a lag whose sidecar does not give b_emf: the back-EMF share of b
EMF_SHARE = "emf_share"
#: a nominal replay whose position spread exceeds the measured one by this factor ran away: the record's scales are
#: then the measured position's (:meth:`DriveAdapter._scales`)
RUNAWAY_SPREAD = 3.0
#: window (s) of the central differences that give a measured position's peak speed
SPEED_WINDOW = 0.01
#: effects that split the drive into a motor side and a load side (the model's two-mass case)
SPLITTING = ("backlash", "transmission_compliance")
#: effects after which the back-EMF share of ``b`` says where ``b`` acts: on the motor side or the load side of a
#: shaft or gap (:data:`SPLITTING`), or in front of a lossy mesh, which passes a motor-side damping scaled by its
#: efficiency (``eta`` forward, ``1 / eta_b`` back-driven) and a load-side one as it is
SIDE_SENSITIVE = (*SPLITTING, "gearbox_efficiency")
_DRIVE_OBS = {"position": 0, "velocity": 1, "speed_abs": 1, "force": 3, "controller_output": 4}


class DriveAdapter(Adapter):
    """The generic drive (:mod:`vsa_gym.devices.drive.model`) from the sidecar's ``model`` section.

    ``model``: ``{"params": {DriveParams fields}, "free": {name: [lower, upper]}, "motion":
    "translational" | "rotational"}``.  Free parameters are refitted in every model
    (nominal and extended), so an effect is credited only with what they cannot explain.

    Two optional sidecar keys serve short records of several experiments (CED):

    - ``segments``: rows where an independent experiment starts (first must be 0).  Each
      segment is replayed from the initial state, and its sensor filter restarts there.
    - ``initial_state.fit_window = n``: the state of each segment (load and motor speed,
      transmission deflection, lagged drive force) is not known but fitted, per candidate
      model, to the segment's first ``n`` measured samples (the state-initialisation window
      of a benchmark; those samples must be excluded from scoring with ``skip_samples``).
    """

    def __init__(self, record: Record, replay: str | None = None) -> None:
        super().__init__(record)
        model = record.model
        self.params = drive.DriveParams(**model.get("params", {}))
        self._nominal_row = self.params.vector(1)  # every candidate's parameter matrix starts from it
        self.rot = model.get("motion", "translational") == "rotational"
        transmission = model.get("transmission", "geared")
        if transmission not in TRANSMISSIONS:
            raise ValueError(f"model.transmission must be 'geared' (a transmission between motor and load: gear, "
                             f"screw, belt; the default) or 'direct' (the motor drives the load itself, e.g. a "
                             f"linear motor), got {transmission!r}")
        #: a transmission between motor and load: its effects (backlash, compliance, mesh loss) are candidates
        self.geared = transmission == "geared"
        given = model.get("params", {})
        clash = [k for k in ("k_c", "backlash", "eta", "eta_b") if k in given and given[k] not in (0, 0.0, 1, 1.0)]
        if not self.geared and clash:
            raise ValueError(f"model.transmission is 'direct' but model.params gives transmission parameters "
                             f"{', '.join(f'{k} = {given[k]!r}' for k in clash)}")
        if self.params.b_emf > self.params.b:
            raise ValueError(f"model.params: b_emf = {self.params.b_emf:g} (back-EMF part of b) exceeds b = "
                             f"{self.params.b:g}; b is the whole viscous damping, back-EMF included")
        free = model.get("free", {})
        self.base = []
        for name, (lo, hi) in free.items():
            if name not in drive.PIDX:
                raise ValueError(f"model.free: {name!r} is not a drive parameter ({drive.PNAMES})")
            if name == "tau_e" and float(lo) <= 0.0:
                raise ValueError("model.free: tau_e needs a lower bound > 0 (a vanishing lag makes the replay "
                                 "stiff); fix tau_e = 0 in model.params for a drive without lag")
            v = float(getattr(self.params, name))
            self.base.append(ParamSpec(name, "", float(lo), float(hi), v, max(abs(v), 1e-9)))
        init = record.meta.get("initial_state", {})
        force0 = init.get("force")
        if force0 is not None and force0 != "settled" and not isinstance(force0, int | float):
            raise ValueError(f"initial_state.force must be a number (the drive force at the start) or 'settled' "
                             f"(in equilibrium with the first input), got {force0!r}")
        self.start_force = None if force0 in (None, "settled") else float(force0)
        lagged = float(self.params.tau_e) > 0.0 or "tau_e" in free
        if lagged and force0 is None and not init.get("fit_window"):
            # the lagged drive force at the start is not known: the amplifier may have been on and settled
            # (share 1, the equilibrium with the first input) or switched on with the record (0); an
            # open-loop replay that starts from the wrong one drifts by a constant position offset ever
            # after, so the share is fitted with every model, like a free nominal parameter ("settled" or a
            # number in the sidecar says which)
            self.base.append(ParamSpec(START_SHARE, "-", 0.0, 1.0, 0.5, 1.0))
        if "voltage" in record.inputs and lagged and "b_emf" not in model.get("params", {}) and "b_emf" not in free:
            # a voltage input with a lag: a voltage drive, whose back-EMF damping (part of b) acts through the
            # winding's L / R, or a current amplifier commanded in volts, whose loop rejects the back-EMF; a
            # sidecar that does not split b leaves it open, so the back-EMF share of b is fitted
            self.base.append(ParamSpec(EMF_SHARE, "-", 0.0, 1.0, 0.5, 1.0))
        ctrl = record.controller
        self.replay = replay or record.meta.get("replay", "closed_loop" if ctrl else "open_loop")
        if self.replay not in ("open_loop", "closed_loop"):
            raise ValueError(f"replay must be open_loop or closed_loop, got {self.replay!r}")
        ins = record.inputs
        T = len(record)
        drive_q = next((q for q in ("voltage", "current", "force") if q in ins), None)
        self.u = record.input(drive_q) if drive_q else np.zeros(T)
        self.fext = record.input("external_force") if "external_force" in ins else np.zeros(T)
        self.ctrl = None
        self.ref = self.ff = np.zeros(T)
        if self.replay == "closed_loop":
            if not ctrl or ctrl.get("type") != "pd_cascade":
                raise ValueError("closed-loop replay of a drive needs controller type 'pd_cascade' "
                                 "(u = clip(kp kv (ref - q) - kv dq, +-saturation) + feedforward)")
            self.ctrl = (float(ctrl["kp"]), float(ctrl["kv"]), float(ctrl.get("saturation", np.inf)))
            self.ref = record.data[ctrl["reference"]].to_numpy(dtype=np.float64)
            ffc = ctrl.get("feedforward")
            self.ff = record.data[ffc].to_numpy(dtype=np.float64) if ffc else np.zeros(T)
        self.obs = [_DRIVE_OBS[s.quantity] if not (s.quantity == "position"
                                                    and record.meta["outputs"][s.column].get("at") == "motor") else 2
                    for s in self.outputs]
        # the position sensor a closed loop reads: the first position output, where it sits (the state column
        # it records) and its quantiser's bias; a record without one leaves the loop on the motor position
        self.loop_output = next((j for j, s in enumerate(self.outputs) if s.quantity == "position"), None)
        self.loop_at_motor = self.loop_output is None or self.obs[self.loop_output] == 2
        self.loop_bias = self.measurement[self.loop_output].bias if self.loop_output is not None else 0.0
        pos0 = init.get("position")
        # where the sidecar does not give the start position it is read from the first output, through the
        # candidate's sensor model (offset, gain and the quantiser's bias taken out, :meth:`_start_states`):
        # a sensor offset must not pass for a wrong start position
        self.pos_measured = (pos0 is None and bool(self.outputs) and self.outputs[0].quantity == "position")
        if pos0 is None and "position" in record.outputs:
            pos0 = float(record.output("position")[0])
        self.x0 = np.zeros(drive.N_STATE)
        self.x0[0] = self.x0[2] = pos0 or 0.0
        self.x0[1] = self.x0[3] = float(init.get("velocity", 0.0))
        self.x0[4] = float(self.params.k_u) * float(self.u[0])
        starts = [int(a) for a in record.meta.get("segments", [0])]
        if not starts or starts[0] != 0 or np.any(np.diff(starts) <= 0) or starts[-1] >= T:
            raise ValueError(f"segments must be increasing row indices starting at 0 and below {T}, got {starts}")
        self.segments = list(zip(starts, [*starts[1:], T], strict=True))
        self.init_window = int(init.get("fit_window", 0))
        if self.init_window and self.ctrl is not None:
            raise ValueError("initial_state.fit_window is implemented for open-loop replay only")
        if self.init_window and self.init_window >= min(b - a for a, b in self.segments):
            raise ValueError(f"initial_state.fit_window = {self.init_window} leaves no sample of a segment to score")
        self._scales()
        self.effects = self._effects()

    def for_record(self, record: Record) -> DriveAdapter:
        other = DriveAdapter(record, replay=self.replay)
        other.effects, other.base = self.effects, self.base
        other.F_ref, other.v_ref, other.x_ref = self.F_ref, self.v_ref, self.x_ref
        other.refine = self.refine
        if self.shooting:
            other.set_shooting(self.shooting * self.dt)
        return other

    def _scales(self) -> None:
        P1 = self.param_matrix({}, 1)
        P = P1[0]
        try:
            xs = drive.simulate(P1, self.u, self.dt, x0=self.x0, fext=self.fext, ref=self.ref,
                                ff=self.ff, controller=self.ctrl, sensor_at_motor=self.loop_at_motor,
                                sensor_bias=self.loop_bias)[:, 0, :]
        except FloatingPointError as e:
            raise ValueError(f"{self.record.path}: the sidecar's nominal model cannot be replayed on this record "
                             f"({e})") from e
        self.F_ref = float(np.max(np.abs(P[drive.PIDX["k_u"]] * xs[:, 4]))) or 1.0
        self.v_ref = float(np.max(np.abs(xs[:, 1]))) or 1.0
        self.x_ref = float(np.std(xs[:, 0])) or 1.0
        measured = self._measured_scales()
        if measured is not None and self.x_ref > RUNAWAY_SPREAD * measured[0]:
            # the nominal replay ran away (an open-loop replay of a vertical axis without its weight, of a closed
            # loop's integrating plant): bounds and typical sizes scaled on it describe the runaway, not the record
            # (truth case 29008: a Stribeck curve of v_s = 4.9 m/s, 8x the record's peak speed and flat over it, passed
            # for its Coulomb friction), so the position spread and the peak speed are the measured position's
            self.x_ref, self.v_ref = measured

    def _measured_scales(self) -> tuple[float, float] | None:
        """Spread (std) and peak speed of the first measured position output, the speed from central
        differences over :data:`SPEED_WINDOW` (a quantiser's counts average out) within each segment; None
        without a position output."""
        if self.loop_output is None:
            return None
        x = self.measured[:, self.loop_output]
        w = max(1, int(round(0.5 * SPEED_WINDOW / self.dt)))
        peaks = [float(np.max(np.abs(x[a + 2 * w:b] - x[a:b - 2 * w]))) / (2 * w * self.dt)
                 for a, b in self.segments if b - a > 2 * w]
        spread = float(np.std(x))
        if not peaks or not spread or not max(peaks):
            return None
        return spread, max(peaks)

    def restarts(self, effect: str, theta: Mapping[str, float]) -> dict[str, float]:
        """An effect after which the back-EMF share says on which side ``b`` acts (:data:`SIDE_SENSITIVE`) is also
        fitted with all of ``b`` as back-EMF (share 1) where the share is free and the model before holds less than
        half.  In a rigid, lossless drive the share only sets whether ``b`` acts through the winding's lag, and the
        nominal fit may leave it at 0; with two masses it says whether ``b`` damps the motor or the load, and a
        motor that crosses its gap undamped fits a voltage drive's gap worse than no gap (truth case 29002: the true
        gap validated at 0.0064 with share 0 against 0.0061 for Coulomb friction alone, at 0.00025 with share 0.99;
        the command is in docs/identification.md, "Nuisance parameters that only matter once an effect is in").
        Behind a lossy mesh a back-EMF damping is scaled by the mesh and a load friction is not: truth case 107020
        (a voltage-driven gear motor whose ``b`` is 99.6 % back-EMF) replays at validation 0.00015 at the truth's
        loss with share 0.9956 and at 0.225 with share 0.5; fitted from the nominal share 0 it stopped at share 0.59,
        a loss of 0.197 and a back-driven loss of 0.70 (truth 0.27)."""
        key = f"base.{EMF_SHARE}"
        if effect in SIDE_SENSITIVE and key in theta and theta[key] < 0.5:
            return {key: 1.0}
        return {}

    def _effects(self) -> dict[str, EffectSpec]:
        """The drive library's effects that apply to this record (:mod:`vsa_gym.devices.drive.effects`), then the
        output sensors' measurement effects."""
        eff = physics_specs(DRIVE_LIBRARY, self)
        eff.update(self._sensor_effects())
        return eff

    @property
    def free(self) -> set[str]:
        """The nominal parameters fitted as base parameters (``model.free``)."""
        return {b.name for b in self.base}

    @property
    def units(self) -> tuple[str, str]:
        """``(position, force)`` units: m and N, rad and N m, or the record model's own (CED: arbitrary units)."""
        lin, rot = ("rad", "N m") if self.rot else ("m", "N")
        units = self.record.model.get("units", {})
        return str(units.get("position", lin)), str(units.get("force", rot))

    def param_matrix(self, theta: Theta, n: int) -> np.ndarray:
        P = np.repeat(self._nominal_row, n, axis=0)
        I = drive.PIDX
        for b in self.base:
            if b.name in I:
                P[:, I[b.name]] = theta_column(theta, f"base.{b.name}", n, b.absent)
        if any(b.name == EMF_SHARE for b in self.base):
            P[:, I["b_emf"]] = P[:, I["b"]] * theta_column(theta, f"base.{EMF_SHARE}", n, 0.0)
        P[:, I["F_c"]] += theta_column(theta, "coulomb_friction.F_c", n)
        if "coulomb_friction.v_t" in theta:
            P[:, I["v_eps"]] = theta_column(theta, "coulomb_friction.v_t", n)
        P[:, I["F_s"]] += theta_column(theta, "stribeck_friction.F_s", n)
        if "stribeck_friction.v_s" in theta:
            P[:, I["v_s"]] = theta_column(theta, "stribeck_friction.v_s", n)
        if "stribeck_friction.delta" in theta:
            P[:, I["delta_s"]] = theta_column(theta, "stribeck_friction.delta", n)
        for key in ("coulomb_friction.sticks", "stribeck_friction.sticks"):  # friction that truly sticks
            if key in theta:
                P[:, I["sticks"]] = np.where(theta_column(theta, key, n) > 0.0, 1.0, P[:, I["sticks"]])
        P[:, I["b"]] += theta_column(theta, "viscous_friction.b", n)
        P[:, I["backlash"]] += theta_column(theta, "backlash.width", n)
        P[:, I["m"]] *= 1.0 + theta_column(theta, "inertia_error.rel", n)
        P[:, I["F_0"]] += theta_column(theta, "force_offset.F_0", n)
        eta_nom = P[:, I["eta"]].copy()
        P[:, I["eta"]] *= 1.0 - theta_column(theta, "gearbox_efficiency.loss", n)
        if "gearbox_efficiency.loss_back" in theta:
            eta_b = np.where(P[:, I["eta_b"]] > 0, P[:, I["eta_b"]], eta_nom)
            P[:, I["eta_b"]] = eta_b * (1.0 - theta_column(theta, "gearbox_efficiency.loss_back", n))
        comp = theta_column(theta, "transmission_compliance.compliance", n)
        # below 1/100 of the typical compliance the mode is far above the sampling rate: rigid (keeps RK4 cheap)
        c_typ = self.effects["transmission_compliance"].params[0].typical if hasattr(self, "effects") and \
            "transmission_compliance" in self.effects else 0.0
        on = comp > 0.01 * c_typ
        P[on, I["k_c"]] = 1.0 / comp[on]
        P[:, I["k_c"]] *= 1.0 + theta_column(theta, "spring_stiffness_drift.drift", n)
        kc = P[:, I["k_c"]]
        red = P[:, I["m"]] * P[:, I["frac_m"]] * (1 - P[:, I["frac_m"]])
        zeta = theta_column(theta, "transmission_compliance.zeta", n, ZETA_COMPLIANCE)
        P[on, I["c_c"]] = np.maximum(P[on, I["c_c"]], 2 * zeta[on] * np.sqrt(kc[on] * red[on]))
        if "backlash.f_contact" in theta or "backlash.zeta_contact" in theta:  # the contact of a rigid drive
            f_b = theta_column(theta, "backlash.f_contact", n, drive.F_CONTACT)
            z_b = theta_column(theta, "backlash.zeta_contact", n, drive.ZETA_CONTACT)
            # rows at the model's own contact keep it (bit for bit); the others get theirs explicitly
            own = (P[:, I["k_c"]] == 0.0) & ((f_b != drive.F_CONTACT) | (z_b != drive.ZETA_CONTACT))
            m_r = P[own, I["frac_m"]] * (1.0 - P[own, I["frac_m"]]) * P[own, I["m"]]
            P[own, I["k_contact"]] = (2.0 * np.pi * f_b[own]) ** 2 * m_r
            P[own, I["c_c"]] = 2.0 * z_b[own] * np.sqrt(P[own, I["k_contact"]] * m_r)
        fh = theta_column(theta, "hysteresis.F_h", n)
        P[:, I["F_h"]] += fh
        x_h = theta_column(theta, "hysteresis.x_h", n, 0.01 * getattr(self, "x_ref", 1.0))
        P[fh > 0, I["sigma_h"]] = fh[fh > 0] / np.maximum(x_h[fh > 0], 1e-12)
        return P

    def _loop_sensor(self, theta: Theta | None, n: int) -> np.ndarray | None:
        """Each row's ``[gain, offset, delay]`` of the position sensor the closed loop reads (None: open loop).

        The controller of a closed-loop record acts on what its sensor reads, so the sensor effects of
        the position output act inside the loop, not only on the recorded output."""
        if self.ctrl is None or self.loop_output is None or theta is None:
            return None
        return np.stack([theta_column(theta, k, n) for k in SENSOR_KEYS], axis=1)

    def substeps(self, P: np.ndarray) -> int:
        """RK4 substeps per sample that the fastest mode among rows ``P`` asks for
        (:func:`vsa_gym.devices.drive.model.substeps`), times :attr:`refine` (at most ``MAX_SUBSTEPS``)."""
        return min(drive.substeps(P, self.dt) * self.refine, drive.MAX_SUBSTEPS)

    def can_refine(self) -> bool:
        return True

    def _rollout(self, P: np.ndarray, a: int, b: int, x0: np.ndarray, theta: Theta | None = None,
                 n_sub: int | None = None, starts: np.ndarray | None = None) -> np.ndarray:
        """Physical observables ``(b - a, n, n_outputs)`` of rows ``P`` over rows ``a:b`` from states ``x0``
        (``theta``: the candidate's sensor terms, which a closed loop reads; ``n_sub``: the substeps, by
        default those of ``P``'s fastest mode; ``starts``: shooting windows from ``a``, with ``x0`` the start states
        of each, :func:`vsa_gym.devices.drive.model.simulate`)."""
        y = drive.simulate(P, self.u[a:b], self.dt, x0=x0, fext=self.fext[a:b], ref=self.ref[a:b], ff=self.ff[a:b],
                           controller=self.ctrl, n_sub=self.substeps(P) if n_sub is None else n_sub,
                           sensor_at_motor=self.loop_at_motor, sensor_bias=self.loop_bias,
                           sensor=self._loop_sensor(theta, P.shape[0]), diverged="nan",  # the fit skips such rows
                           starts=starts)
        return y[:, :, self.obs]

    def _start_states(self, P: np.ndarray, a: int, position: np.ndarray | None = None,
                      speed: np.ndarray | None = None, theta: Theta | None = None) -> np.ndarray:
        """Initial state of every row at row ``a``.

        A segment start takes the sidecar's state; its lagged drive force (``tau_e > 0``) is
        ``initial_state.force`` if given (e.g. 0 for an amplifier switched on at the first sample),
        else the fitted share ``base.start_share`` (0: off, 1: settled; 1 where not fitted) of the
        equilibrium with the first input, ``k_u u_a - b_emf v``.  A shooting window starts
        from the given ``position`` and ``speed`` of load and motor side, with the force in
        equilibrium.
        """
        x0 = np.repeat(self.x0[None, :], P.shape[0], axis=0)
        if position is None and self.pos_measured and theta is not None:
            gain, offset, _ = (theta_column(theta, k, P.shape[0]) for k in SENSOR_KEYS)
            x0[:, 0] = x0[:, 2] = (self.measured[0, 0] - self.measurement[0].bias - offset) / (1.0 + gain)
        if position is not None:
            x0[:, 0] = x0[:, 2] = position
        elif theta is not None and "backlash.start" in theta:
            # the motor's place in the gap at the first sample; a start read from a motor encoder is the motor's
            shift = theta_column(theta, "backlash.start", P.shape[0]) * 0.5 * P[:, drive.PIDX["backlash"]]
            if self.pos_measured and self.obs[0] == 2:  # the start was read from a motor encoder: the load moves
                x0[:, 0] -= shift
            else:
                x0[:, 2] += shift
        if speed is not None:
            x0[:, 1] = x0[:, 3] = speed
        I = drive.PIDX
        if position is None and self.start_force is not None:
            x0[:, 4] = self.start_force
        else:
            x0[:, 4] = P[:, I["k_u"]] * self.u[a] - P[:, I["b_emf"]] * x0[:, 3]
            if position is None and theta is not None:
                x0[:, 4] *= theta_column(theta, f"base.{START_SHARE}", P.shape[0], 1.0)
        return x0

    def _fit_start_state(self, theta: Theta, P: np.ndarray, a: int, x0: np.ndarray) -> np.ndarray:
        """Each row's state at segment start ``a`` fitted to the first ``init_window`` measured samples."""
        out = x0.copy()
        n = P.shape[0]
        for i in range(n):
            th = {k: np.broadcast_to(np.asarray(v, dtype=np.float64), (n,))[i:i + 1] for k, v in theta.items()}
            out[i] = self._fit_row_state(th, P[i:i + 1], a, x0[i])
        return out

    def _fit_row_state(self, theta: Theta, Pi: np.ndarray, a: int, x0: np.ndarray) -> np.ndarray:
        """Least-squares start state of one model ``Pi`` (1, n_params) over samples ``a .. a + init_window``.

        Unknowns: load speed ``v_l``; with a two-mass transmission also the motor speed ``v_m`` and the
        deflection ``x_m - x_l``; with a lag ``tau_e > 0`` also the drive force ``F``.  A rectifying sensor
        does not see the sign, so both signs of the speed are tried and the better fit is kept.
        """
        from scipy.optimize import least_squares

        I = drive.PIDX
        w = self.init_window
        meas = self.measured[a:a + w]
        sd = np.std(self.measured, axis=0) + 1e-12
        two = bool(Pi[0, I["k_c"]] > 0 or Pi[0, I["backlash"]] > 0)
        k = Pi[0, I["k_c"]] if Pi[0, I["k_c"]] > 0 else float(drive.contact_stiffness(Pi)[0])
        lag = bool(Pi[0, I["tau_e"]] > 0)
        scale = np.array([self.v_ref, self.v_ref, self.F_ref / k, self.F_ref])
        use = np.array([True, two, two, lag])

        def state(z: np.ndarray) -> np.ndarray:
            full = np.zeros(4)
            full[use] = z
            full *= scale
            s = x0.copy()
            s[1] = full[0]
            s[3] = full[1] if two else full[0]
            s[2] = s[0] + full[2]
            if lag:
                s[4] = full[3]
            return s

        def res(z: np.ndarray) -> np.ndarray:
            y = self._measure(theta, self._rollout(Pi, a, a + w, state(z)[None, :]), a, a + w)[:, 0, :]
            return ((y - meas) / sd).ravel()

        best = None
        for sign in (1.0, -1.0):
            z0 = np.zeros(4)
            z0[:2] = sign * max(float(np.abs(meas[0, 0])), 1e-3) / self.v_ref
            z0[3] = Pi[0, I["k_u"]] * self.u[a] / self.F_ref
            sol = least_squares(res, z0[use], method="trf", max_nfev=200)
            if best is None or sol.cost < best.cost:
                best = sol
        assert best is not None
        return state(best.x)

    # -- multiple shooting (truncated simulation error) for replays that run away
    #: each window starts at the measured position, which hides a constant sensor offset
    SHOOTING_BLIND = ("sensor_offset",)

    def can_shoot(self) -> bool:
        """Truncated simulation error needs an open-loop replay whose first output is a plain position sensor."""
        mm = self.measurement[0]
        return (self.ctrl is None and self.outputs[0].quantity == "position" and not mm.rectify
                and mm.filter_hz == 0.0 and not self.init_window)

    def set_shooting(self, window: float | None) -> None:
        """Replay in windows of ``window`` seconds, each started from the measured state (None: one replay).

        The start state of a window is the measured position (through the inverse of the measurement
        model of the candidate: offset, gain, delay and the quantiser's bias taken out) and its speed, both
        from a local quadratic (Savitzky-Golay, 5 ms or 5 samples) fit of the measured position; the motor
        side starts with the load, the drive force at ``k_u u``, the hysteresis state at zero.
        """
        if window is None:
            self.shooting = 0
            return
        if not self.can_shoot():
            raise ValueError("multiple shooting needs an open-loop replay of a position output without "
                             "rectification, filter or fitted initial state")
        from scipy.signal import savgol_filter

        self.shooting = max(int(round(window / self.dt)), 10)
        half = max(2, int(round(0.0025 / self.dt)))
        y = self.measured[:, 0]
        self._x_meas = savgol_filter(y, 2 * half + 1, 2)
        self._v_meas = savgol_filter(y, 2 * half + 1, 2, deriv=1, delta=self.dt)

    def _windows(self) -> list[tuple[int, int]]:
        if not self.shooting:
            return self.segments
        return [(w, min(w + self.shooting, b)) for a, b in self.segments for w in range(a, b, self.shooting)]

    def _shoot_states(self, theta: Theta, P: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Start states ``(windows, n, N_STATE)`` of rows ``P`` at the shooting windows' first samples ``starts``."""
        n = P.shape[0]
        gain, offset, delay = (theta_column(theta, k, n) for k in SENSOR_KEYS)
        ta = self.t[starts][:, None] + delay
        pos = (np.interp(ta, self.t, self._x_meas) - self.measurement[0].bias - offset) / (1.0 + gain)
        speed = np.interp(ta, self.t, self._v_meas) / (1.0 + gain)
        return np.stack([self._start_states(P, a, pos[w], speed[w]) for w, a in enumerate(starts)])

    def simulate(self, theta: Theta, n: int, *, until: int | None = None,
                 rows: np.ndarray | None = None) -> np.ndarray:
        """Measured outputs ``(T, n, n_outputs)``; each segment (or shooting window) is replayed on its own.

        ``until`` / ``rows`` as in :meth:`Adapter.simulate`: samples from ``until`` on are not simulated
        (NaN), and only ``rows`` are rolled out, with the substeps of all ``n`` (so a row comes back bit for
        bit as in the whole batch: a fit's residual and its finite-difference Jacobian share one step)."""
        P = self.param_matrix(theta, n)
        n_sub = self.substeps(P)
        if rows is not None:
            rows = np.asarray(rows)
            P, theta, n = P[rows], theta_rows(theta, n, rows), len(rows)
        end = len(self.t) if until is None else min(int(until), len(self.t))
        out = np.full((len(self.t), n, len(self.outputs)), np.nan)
        if self.shooting:
            # the windows tile the samples (the segments do): one compiled roll-out restarts each row at each window
            windows = [(a, min(b, end)) for a, b in self._windows() if a < end]
            starts = np.array([a for a, _ in windows])
            y = self._rollout(P, 0, end, self._shoot_states(theta, P, starts), n_sub=n_sub, starts=starts)
            for a, b in windows:
                out[a:b] = self._measure(theta, y[a:b], a, b)
            return out
        for a, b in self.segments:
            if a >= end:
                continue
            x0 = self._start_states(P, a, theta=theta)
            if self.init_window:
                x0 = self._fit_start_state(theta, P, a, x0)
            b = min(b, end)
            out[a:b] = self._measure(theta, self._rollout(P, a, b, x0, theta, n_sub), a, b)
        return out

    def simulate_physical(self, theta: Theta, n: int) -> np.ndarray:
        """Physical outputs ``(T, n, n_outputs)`` before the sensors (segments from the sidecar's initial state)."""
        P = self.param_matrix(theta, n)
        return np.concatenate([self._rollout(P, a, b, self._start_states(P, a, theta=theta), theta)
                               for a, b in self.segments])

    def describe_model(self, theta: Mapping[str, float]) -> dict[str, Any]:
        """The identified drive as a :class:`DriveParams` dict (for rebuilding the simulator)."""
        P = self.param_matrix({k: np.array([v]) for k, v in theta.items()}, 1)[0]
        return {name: float(P[i]) for i, name in enumerate(drive.PNAMES)}



__all__ = ["EMF_SHARE", "START_SHARE", "DriveAdapter"]
