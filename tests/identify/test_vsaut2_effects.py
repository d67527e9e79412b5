"""vsaUT-II: hidden effects in seeded synthetic records of the paper's experiments.

Each record hides one effect of random realistic magnitude
(:data:`vsa_gym.devices.vsaut2.synthetic.RANGES`), measured through the AS5043
(10 bit, gain mismatch) or the frame motor encoder with noise below one count.  The
identifier must name that effect and nothing else, recover its main parameter within
``REL_TOL``, and improve the held-out (test part) error; negative controls must report none.
All three experiments are covered: free oscillation, constant-current frame actuation and
the torque-deflection sweep.  Recovery rates over many seeds:
``python -m benchmarks.identify_recovery_devices --device vsaut2``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.identify.recovery import assert_planted_effect_recovered
from vsa_gym.devices.vsaut2.adapter import Vsaut2Adapter
from vsa_gym.devices.vsaut2.experiments import fig10_free_oscillation
from vsa_gym.devices.vsaut2.model import POWER, ExtensionOutput, VsaUT2Model
from vsa_gym.devices.vsaut2.params import VsaUT2Effects, VsaUT2Params
from vsa_gym.devices.vsaut2.synthetic import make_vsaut2_record
from vsa_gym.identify.adapters import make_adapter
from vsa_gym.identify.recovery import identify_case, main_key

REL_TOL = 0.10


def _check(experiment: str, effect: str, seed: int):
    res, truth = identify_case("vsaut2", experiment, effect, seed)
    assert_planted_effect_recovered(res, truth, effect, main_key("vsaut2", effect), REL_TOL, 0.7)
    return res


def _check_none(experiment: str, seed: int) -> None:
    res, _ = identify_case("vsaut2", experiment, None, seed)
    assert res.effects == [], res.statements()
    assert res.statements()[0].startswith("No significant effect")
    assert any(c.fitted and not c.accepted for c in res.candidates)


@pytest.mark.parametrize("effect", ["coulomb_friction", "inertia_error", "spring_stiffness_drift"])
def test_free_oscillation_effect_is_named_and_recovered(effect):
    _check("free_oscillation", effect, seed=1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_free_oscillation_negative_control_reports_none(seed):
    _check_none("free_oscillation", 200 + seed)


@pytest.mark.parametrize("effect", ["gearbox_efficiency", "coulomb_friction"])
def test_constant_current_effect_is_named_and_recovered(effect):
    """Fig. 9's experiment: the frame driven at constant current, q2 from the motor encoder; the effect acts at
    the frame (gearbox efficiency of the GP42C, Coulomb friction of the frame bearing)."""
    res = _check("constant_current", effect, seed=1)
    assert res.effects[0]["location"] in ("in the GP42C frame gearbox", "at the frame joint")


def test_constant_current_negative_control_reports_none():
    _check_none("constant_current", 200)


def test_torque_sweep_reaches_the_lever_nonlinear_range_below_the_stops():
    """The sweep's design: the deflection goes where ``sin(2 phi) / (2 phi)`` is well below 1 (the lever is
    nonlinear), but the spring end stays short of its travel stop ``x_max``."""
    from vsa_gym.devices.vsaut2.lever import lever_ratio

    rec, _ = make_vsaut2_record(2000, "torque_sweep", None)
    p = VsaUT2Params()
    phi = np.max(np.abs(rec.output("r")))
    assert phi > 0.4 and np.sin(2 * phi) / (2 * phi) < 0.85
    q1 = rec.meta["initial_state"]["q1"]
    assert p.lever.l * lever_ratio(p.lever, q1) * np.sin(phi) < p.lever.x_max


def test_torque_sweep_spring_drift_is_not_taken_for_a_sensor_gain():
    """The look-alike pair of the sweep: a drift of the spring rate and a gain error of the AS5043 both scale the
    deflection where the lever is linear.  The sweep takes the lever into its nonlinear range (``K/2 sin 2 phi``),
    where a drift scales the torque axis and a gain the deflection axis: the drift must be named, and the gain,
    if fitted as a competitor, must validate clearly worse."""
    res = _check("torque_sweep", "spring_stiffness_drift", seed=1)
    val = {c.name: c.val_score for c in res.candidates if c.fitted and c.round == 1}
    if "sensor_gain" in val:
        assert val["sensor_gain"] > 2.0 * val["spring_stiffness_drift"], val


def test_zero_effects_are_the_nominal_model_bit_for_bit():
    p0 = VsaUT2Params()
    p1 = VsaUT2Params(effects=VsaUT2Effects(w_eps=0.05, b_eps=1e-5, w_s_o=0.3, phi_h=0.05))  # magnitudes still zero
    assert VsaUT2Model(p1).n_states == 10  # no hysteresis column with M_h = 0
    x0 = VsaUT2Model(p0).initial_state(2, q1=0.01, r=0.2)
    u = np.zeros((200, 2, 2))
    u[:, :, 1] = 3.0
    xa, ea = VsaUT2Model(p0).simulate(x0, u)
    xb, eb = VsaUT2Model(p1).simulate(x0, u)
    assert np.array_equal(xa, xb) and np.array_equal(ea, eb)


def test_effects_compiled_matches_numpy_and_conserve_energy():
    p = VsaUT2Params(effects=VsaUT2Effects(F_c_o=0.02, F_s_o=0.01, F_c_ad=0.05, b_belt=1e-4))
    mc, mn = VsaUT2Model(p), VsaUT2Model(p, compiled=False)
    x0 = mc.initial_state(1, q1=0.01, r=0.2)
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-10, 10, (10, 1, 2)), 30, axis=0)
    tau = 2.0 * np.sin(np.arange(300) * 0.01)[:, None]
    xs, es = mc.simulate(x0, u, tau)
    xn, _ = mn.simulate(x0, u, tau)
    assert np.max(np.abs(xs - xn)) < 1e-10
    E = mc.stored_energy(xs[:, 0])
    e = es[:, 0]
    bal = e[:, POWER["el_pivot"]] + e[:, POWER["el_frame"]] + e[:, POWER["ext"]] - e[:, 3:].sum(-1) - (E - E[0])
    assert np.max(np.abs(bal)) < 1e-3 * np.max(np.abs(e))
    # the friction dissipated something, and the backlash changed the belt's response
    x_nom, e_nom = VsaUT2Model(VsaUT2Params()).simulate(x0, u, tau)
    assert e[-1, POWER["viscous"]] > e_nom[-1, 0, POWER["viscous"]]
    assert np.max(np.abs(xs - x_nom)) > 1e-3


@dataclasses.dataclass(frozen=True)
class _NumpyDahl:
    """The spring hysteresis written as a numpy :class:`~vsa_gym.devices.vsaut2.layout.Extension` (the route the
    model offered before it was a state column of the compiled core): the reference of the compiled one."""

    M_h: float
    phi_h: float
    name: str = "numpy_dahl"
    n_states: int = 1

    def initial_state(self, n):
        return np.zeros((n, 1))

    def evaluate(self, params, kin, z):
        h, w = z[:, 0], kin.phi_dot
        return ExtensionOutput({"lever_torque": -h}, ((self.M_h * w - np.abs(w) * h) / self.phi_h)[:, None],
                               np.abs(w) * h * h / self.M_h)

    def stored_energy(self, params, kin, z):
        return 0.5 * z[:, 0] ** 2 * self.phi_h / self.M_h


def test_spring_hysteresis_compiled_matches_numpy_path_and_the_extension_route():
    """The compiled core's hysteresis column, the same equations on the numpy path, and the nominal model with a numpy
    Dahl extension give the same trajectory (to 1e-10 rad / rad/s / N m; 2.3e-13 measured when written); the extension
    books its dissipation in the ``stops`` channel, the core in ``viscous``."""
    p = VsaUT2Params(effects=VsaUT2Effects(M_h=0.03, phi_h=0.02))
    mc, mn = VsaUT2Model(p), VsaUT2Model(p, compiled=False)
    me = VsaUT2Model(VsaUT2Params(), (_NumpyDahl(0.03, 0.02),))
    x0 = mc.initial_state(1, q1=0.01, r=0.2)
    assert x0.shape == (1, 11) and me.initial_state(1).shape == (1, 11)
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-10, 10, (10, 1, 2)), 30, axis=0)
    tau = 0.5 * np.sin(np.arange(300) * 0.01)[:, None]
    xs, es = mc.simulate(x0, u, tau)
    xn, en = mn.simulate(x0, u, tau)
    xe, ee = me.simulate(x0, u, tau)
    assert np.max(np.abs(xs - xn)) < 1e-10 and np.max(np.abs(es - en)) < 1e-10
    assert np.max(np.abs(xs - xe)) < 1e-10
    v, st = POWER["viscous"], POWER["stops"]
    assert np.max(np.abs(np.delete(es - ee, [v, st], axis=-1))) < 1e-10
    assert np.max(np.abs((es[..., v] + es[..., st]) - (ee[..., v] + ee[..., st]))) < 1e-10
    assert np.max(np.abs(xs[:, 0, 10])) > 0.5 * 0.03  # the loop was run through
    x_nom, _ = VsaUT2Model(VsaUT2Params()).simulate(x0[:, :10], u, tau)
    assert np.max(np.abs(xs[..., :10] - x_nom)) > 1e-2


def test_hysteresis_is_offered_where_a_torque_sweeps_the_deflection():
    """A catalogue effect of the compiled core on the torque sweep; not on the free oscillation or the frame-driven
    record (where it stays the nominal candidate list)."""
    names = {exp: set(make_adapter(make_vsaut2_record(3, exp, None)[0]).effects)
             for exp in ("free_oscillation", "constant_current", "torque_sweep")}
    assert "hysteresis" in names["torque_sweep"]
    assert "hysteresis" not in names["free_oscillation"] | names["constant_current"]


def test_torque_sweep_hysteresis_is_named_and_recovered():
    """Planted spring hysteresis (Dahl) in the torque sweep: named alone, ``M_h`` within ``REL_TOL``; the
    identified parameters rebuild an env whose core carries the hysteresis column."""
    import gymnasium as gym

    import vsa_gym  # noqa: F401  (registers the envs)

    res = _check("torque_sweep", "hysteresis", seed=1)
    rec, truth = make_vsaut2_record(1, "torque_sweep", "hysteresis")
    p = make_adapter(rec).identified_params(res.final.theta())
    assert p.effects.M_h == pytest.approx(truth["params"]["hysteresis.M_h"], rel=REL_TOL)
    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", params=p)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.unwrapped.task.s["x"].shape == (1, 11)


def test_coulomb_output_friction_decays_faster_than_linear():
    """Fig. 10's discrepancy: with Coulomb friction the peaks fall linearly, not geometrically."""
    nom = fig10_free_oscillation(VsaUT2Model(VsaUT2Params()))
    cf = fig10_free_oscillation(VsaUT2Model(VsaUT2Params(effects=VsaUT2Effects(F_c_o=2e-3))))
    assert cf.decay_rate_per_s > 1.2 * nom.decay_rate_per_s
    ratios = cf.peak_values[1:5] / cf.peak_values[:4]
    assert ratios[-1] < ratios[0]  # the ratio of successive peaks falls: not a pure exponential


def test_identified_params_rebuild_the_env():
    import gymnasium as gym

    import vsa_gym  # noqa: F401  (registers the envs)

    rec, truth = make_vsaut2_record(5, "free_oscillation", "coulomb_friction")
    ad = make_adapter(rec)
    assert isinstance(ad, Vsaut2Adapter)
    p = ad.identified_params(truth["params"])
    assert p.effects.F_c_o == pytest.approx(truth["params"]["coulomb_friction.F_c"])
    env = gym.make("vsa_gym/VsaUT2-PositionStiffness-v0", params=p)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.unwrapped.task.model.params.effects.F_c_o == p.effects.F_c_o
