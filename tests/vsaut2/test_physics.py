"""Properties of the vsaUT-II core: energy balance, stiffness, pivot kinematics, batching, validation."""

import dataclasses

import numpy as np
import pytest

from vsa_gym.devices.vsaut2.belt import belt_stiffness_at_frame
from vsa_gym.devices.vsaut2.lever import lever_forces, spring_stiffness
from vsa_gym.devices.vsaut2.model import POWER, STATE, VsaUT2Model
from vsa_gym.devices.vsaut2.params import RE40Motor, VsaUT2Params, gp42c_gearbox, re40_motor
from vsa_gym.devices.vsaut2.pivot import gear_ratio, pivot_jacobian, pivot_position
from vsa_gym.devices.vsaut2.statics import static_output_stiffness
from vsa_gym.physics.dc_motor import DCMotorParams
from vsa_gym.physics.friction import LuGreParams
from vsa_gym.physics.gearbox import GearboxParams, input_torque
from vsa_gym.physics.sensors import AbsoluteEncoder, IncrementalEncoder

from .conftest import input_program


@pytest.mark.parametrize("kind", range(5))
def test_energy_balance(model, kind):
    """Electrical energy in + external work = dissipated + change of stored energy (to integrator accuracy)."""
    T = 400
    u, tau = input_program(kind, T, seed=7)
    x0 = model.initial_state(1, q1=0.015, q2=0.05, r=0.1)
    xs, es = model.simulate(x0, u[:, None, :], tau[:, None])
    e_in = es[-1, 0, POWER["el_pivot"]] + es[-1, 0, POWER["el_frame"]] + es[-1, 0, POWER["ext"]]
    diss = es[-1, 0, [POWER["copper"], POWER["viscous"], POWER["gearbox"], POWER["stops"]]].sum()
    stored = model.stored_energy(xs[-1])[0] - model.stored_energy(xs[0])[0]
    scale = np.abs(es[-1, 0]).sum()
    assert scale > 0.1, "the programme must move energy"
    # RK4 at 0.1 ms leaves up to ~1.5e-4 of the flows under repeated full-voltage reversals (the 0.1 ms
    # electrical transients); a missing or wrong energy term would leave percent-level errors
    assert abs(e_in - diss - stored) <= 5e-4 * scale, (e_in, diss, stored)
    # every dissipation channel is non-negative
    assert np.all(es[-1, 0, [POWER["copper"], POWER["viscous"], POWER["gearbox"], POWER["stops"]]] >= -1e-12)


@pytest.mark.parametrize("kind", range(5))
def test_energy_balance_with_spring_hysteresis(model, kind):
    """Spring hysteresis (Dahl, an 11th state column): the balance closes as the nominal one does, with the Dahl
    element's stored part in ``stored_energy`` and its dissipation in the ``viscous`` channel."""
    from vsa_gym.devices.vsaut2.params import VsaUT2Effects

    hm = VsaUT2Model(VsaUT2Params(effects=VsaUT2Effects(M_h=0.05, phi_h=0.005)))
    assert hm.n_states == 11 and hm.n_effect_states == 1
    u, tau = input_program(kind, 400, seed=7)
    x0 = hm.initial_state(1, q1=0.015, q2=0.05, r=0.1)
    xs, es = hm.simulate(x0, u[:, None, :], tau[:, None])
    diss = es[-1, 0, [POWER["copper"], POWER["viscous"], POWER["gearbox"], POWER["stops"]]].sum()
    stored = hm.stored_energy(xs[-1])[0] - hm.stored_energy(xs[0])[0]
    scale = np.abs(es[-1, 0]).sum()
    assert abs(es[-1, 0, :3].sum() - diss - stored) <= 5e-4 * scale
    assert np.max(np.abs(xs[:, 0, 10])) <= 0.05 * (1 + 1e-9)  # |h| <= M_h from h = 0
    assert np.all(es[-1, 0, 3:] >= -1e-12)


def test_spring_hysteresis_acts_at_the_lever_port_and_books_its_dissipation_as_friction(model):
    """One evaluation of the right-hand side: the Dahl torque ``-h`` on the output (``+h`` on the frame), its law
    ``dh/dt = (M_h phi_dot - |phi_dot| h) / phi_h``, and ``|phi_dot| h^2 / M_h`` added to the viscous channel only."""
    from vsa_gym.devices.vsaut2.params import VsaUT2Effects

    M_h, phi_h, h = 0.05, 0.01, 0.02
    p = model.params.replace(effects=VsaUT2Effects(M_h=M_h, phi_h=phi_h))
    x = model.initial_state(1, q1=0.015, r=0.2)
    x[0, STATE["r_dot"]], x[0, STATE["q2_dot"]] = 1.5, -0.5
    xh = np.concatenate([x, [[h]]], axis=1)
    for compiled in (True, False):
        dx0, p0 = VsaUT2Model(model.params, compiled=compiled).rhs(x, np.zeros((1, 2)), np.zeros(1))
        dx1, p1 = VsaUT2Model(p, compiled=compiled).rhs(xh, np.zeros((1, 2)), np.zeros(1))
        assert dx1[0, STATE["r_dot"]] == pytest.approx(dx0[0, STATE["r_dot"]] - h / model.params.I_o, rel=1e-12)
        assert dx1[0, STATE["q2_dot"]] == pytest.approx(dx0[0, STATE["q2_dot"]] + h / model.params.I_ad, rel=1e-12)
        assert dx1[0, 10] == pytest.approx((M_h * 2.0 - 2.0 * h) / phi_h, rel=1e-12)
        dp = p1[0] - p0[0]
        assert dp[POWER["viscous"]] == pytest.approx(2.0 * h * h / M_h, rel=1e-12)
        assert np.all(np.delete(dp, POWER["viscous"]) == 0.0)


def test_energy_imbalance_is_integration_error(model):
    """Refining the substeps shrinks the imbalance at RK4's order: the model itself conserves energy."""
    u, tau = input_program(2, 200, seed=7)
    x0 = model.initial_state(1, q1=0.015, q2=0.05, r=0.1)

    def imbalance(n_sub):
        xs, es = model.simulate(x0, u[:, None, :], tau[:, None], n_sub=n_sub)
        return es[-1, 0, :3].sum() - es[-1, 0, 3:].sum() - (model.stored_energy(xs[-1]) - model.stored_energy(xs[0]))[0]

    coarse, fine = abs(imbalance(10)), abs(imbalance(40))
    assert coarse > 0 and fine < coarse / 50, (coarse, fine)


def test_gearbox_losses_oppose_power_flow():
    gb = gp42c_gearbox()
    tau_L = np.array([5.0, -5.0, 5.0, -5.0, 0.0, 12.0])
    w = np.array([100.0, -100.0, -100.0, 100.0, 50.0, 0.0])
    tau_in, p_loss = input_torque(gb, tau_L, w)
    assert np.all(p_loss >= 0)
    # forward (motor drives): the motor supplies more than the ideal torque; back-driven: it receives less
    assert tau_in[0] > tau_L[0] / gb.n and tau_in[1] < tau_L[1] / gb.n
    assert abs(tau_in[2]) < abs(tau_L[2]) / gb.n and abs(tau_in[3]) < abs(tau_L[3]) / gb.n
    # far from the blends the efficiency law holds exactly
    eta = gb.eta_max * (1 - np.exp(-gb.alpha * 5.0 / gb.tau_max))
    assert tau_in[0] == pytest.approx(5.0 / (gb.n * eta), rel=1e-4)
    assert tau_in[2] == pytest.approx(5.0 * eta / gb.n, rel=1e-4)


def test_pivot_moves_on_a_straight_line():
    p = VsaUT2Params().pivot
    g = gear_ratio(p)
    assert g == pytest.approx(1 / (1 + (60 / 30) * (31 / 14)), rel=1e-12)
    assert g == pytest.approx(0.1842, abs=1e-4)
    th_s = np.linspace(0, np.pi / g, 50)
    th_pc = g * th_s
    # planet centre on the carrier at D_r/2 - D_p/2 = D_p/2; planet spins at -th_pc (rolling, D_r = 2 D_p);
    # the pivot is D_r/4 = D_p/2 from the planet centre
    cx, cy = 0.5 * p.D_p * np.cos(th_pc), 0.5 * p.D_p * np.sin(th_pc)
    px, py = cx + 0.5 * p.D_p * np.cos(-th_pc), cy + 0.5 * p.D_p * np.sin(-th_pc)
    assert np.max(np.abs(py)) < 1e-15  # a straight line
    assert np.allclose(pivot_position(p, th_s), p.D_p - px, atol=1e-15)
    h = 1e-6
    fd = (pivot_position(p, th_s + h) - pivot_position(p, th_s - h)) / (2 * h)
    assert np.allclose(pivot_jacobian(p, th_s), fd, atol=1e-9)


def test_lever_forces_are_gradients_of_the_spring_energy():
    lev = VsaUT2Params().lever
    q1 = np.array([0.01, 0.02, 0.04])
    phi = np.array([0.05, -0.2, 0.3])
    z = np.zeros(3)
    f = lever_forces(lev, q1, phi, z, z)
    h = 1e-7
    dU_dphi = (lever_forces(lev, q1, phi + h, z, z).energy - lever_forces(lev, q1, phi - h, z, z).energy) / (2 * h)
    dU_dq1 = (lever_forces(lev, q1 + h, phi, z, z).energy - lever_forces(lev, q1 - h, phi, z, z).energy) / (2 * h)
    assert np.allclose(f.tau_phi, -dU_dphi, rtol=1e-6)
    assert np.allclose(f.F_q1, -dU_dq1, rtol=1e-6)
    # closed form of the pivot force inside the travel limit
    inside = np.abs(f.x) < lev.x_max
    closed = 2 * lev.k * lev.l**3 * (lev.l - q1) * np.sin(phi) ** 2 / q1**3
    assert np.allclose(f.F_q1[inside], closed[inside], rtol=1e-9)


@pytest.mark.parametrize("q1", [0.0, 0.0068, 0.012, 0.02, 0.04])
def test_stiffness_from_simulated_torque(model, q1):
    """Finite differences of the simulated static torque match eq. (6), and eq. (6) in series with the belt."""
    p = model.params
    # springs alone: differentiate the lever torque the model applies to the output
    x = model.initial_state(1, q1=q1)
    h = 1e-6
    xp, xm = x.copy(), x.copy()
    xp[0, STATE["r"]] += h
    xm[0, STATE["r"]] -= h
    K_springs = -(model.output_torque(xp)[0] - model.output_torque(xm)[0]) / (2 * h)
    K6 = spring_stiffness(p.lever, max(q1, p.lever.q1_min))
    assert K_springs == pytest.approx(K6, rel=1e-6)
    # whole actuator with the frame motor locked: belt in series
    K_b = belt_stiffness_at_frame(p.belt)
    assert static_output_stiffness(model, q1) == pytest.approx(K6 * K_b / (K6 + K_b), rel=1e-5)


def test_batched_parameters_equal_single_calls():
    base = VsaUT2Params()
    sets = [base, base.replace(I_o=0.02), base.replace(lever=base.lever.replace(k=2500.0)),
            base.replace(frame_motor=base.frame_motor.replace(R=0.4))]
    u, tau = input_program(1, 50)
    x0 = VsaUT2Model().initial_state(1, q1=0.02, q2=0.1, r=0.15)
    batched = VsaUT2Model(VsaUT2Params.stack(sets))
    xb, eb = batched.simulate(np.repeat(x0, 4, 0), np.repeat(u[:, None], 4, 1), np.repeat(tau[:, None], 4, 1))
    for i, s in enumerate(sets):
        xs, es = VsaUT2Model(s).simulate(x0, u[:, None], tau[:, None])
        assert np.array_equal(xb[:, i], xs[:, 0])
        assert np.allclose(eb[:, i], es[:, 0], rtol=0, atol=1e-15)


def test_compiled_core_equals_numpy_core(model):
    u, tau = input_program(2, 30)
    x0 = model.initial_state(2, q1=0.02, q2=0.1, r=0.15)
    slow = VsaUT2Model(model.params, compiled=False)
    a = model.simulate(x0, np.repeat(u[:, None], 2, 1), np.repeat(tau[:, None], 2, 1))
    b = slow.simulate(x0, np.repeat(u[:, None], 2, 1), np.repeat(tau[:, None], 2, 1))
    assert np.allclose(a[0], b[0], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(
    "change, field",
    [
        (dict(I_o=-1.0), "I_o"),
        (dict(c_ad=float("nan")), "c_ad"),
        (dict(I_ad=0.0), "I_ad"),
    ],
)
def test_invalid_parameters_name_the_field(change, field):
    with pytest.raises(ValueError, match=field):
        VsaUT2Params(**change)


def test_invalid_nested_parameter_names_the_field():
    with pytest.raises(ValueError, match=r"RE40Motor\.J"):
        re40_motor().replace(J=-1e-6)
    with pytest.raises(ValueError, match=r"eta_max"):
        gp42c_gearbox().replace(eta_max=1.5)


def test_invalid_inputs_raise(model):
    x = model.initial_state(2)
    with pytest.raises(ValueError, match=r"u \(motor voltages.*non-finite"):
        model.step(x, np.array([[0.0, np.nan], [0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"u \(motor voltages.*shape"):
        model.step(x, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="tau_ext"):
        model.step(x, np.zeros((2, 2)), np.array([0.0, np.inf]))
    with pytest.raises(ValueError, match="state x"):
        model.step(x[:, :5], np.zeros((2, 2)))
    with pytest.raises(ValueError, match="dt"):
        model.step(x, np.zeros((2, 2)), dt=-1e-3)


def test_extension_port_adds_a_joint_force(model):
    """An extension at the output port (viscous extra damping) changes only what it should."""

    @dataclasses.dataclass(frozen=True)
    class ExtraDamping:
        c: float
        name: str = "extra_damping"
        n_states: int = 0

        def initial_state(self, n):
            return np.zeros((n, 0))

        def evaluate(self, params, kin, z):
            from vsa_gym.devices.vsaut2.model import ExtensionOutput

            return ExtensionOutput({"output": -self.c * kin.r_dot}, np.zeros((kin.r_dot.shape[0], 0)),
                                   self.c * kin.r_dot**2)

        def stored_energy(self, params, kin, z):
            return np.zeros(kin.r_dot.shape[0])

    ext_model = VsaUT2Model(model.params, (ExtraDamping(0.05),))
    x = model.initial_state(1, q1=model.params.q1_max, r=0.2)
    dx0, _ = model.rhs(x, np.zeros((1, 2)), np.zeros(1))
    x[0, STATE["r_dot"]] = 1.0
    dx1, _ = model.rhs(x, np.zeros((1, 2)), np.zeros(1))
    dx2, p2 = ext_model.rhs(x, np.zeros((1, 2)), np.zeros(1))
    assert dx2[0, STATE["r_dot"]] == pytest.approx(dx1[0, STATE["r_dot"]] - 0.05 / model.params.I_o)
    assert np.allclose(np.delete(dx2[0], STATE["r_dot"]), np.delete(dx1[0], STATE["r_dot"]))
    assert p2[0, POWER["stops"]] == pytest.approx(0.05)
    with pytest.raises(ValueError, match="n_states"):
        VsaUT2Model(model.params, (ExtraDamping(0.05, n_states=-1),))


@pytest.mark.parametrize("component", [DCMotorParams, GearboxParams, LuGreParams, IncrementalEncoder, AbsoluteEncoder])
def test_generic_components_carry_no_device_numbers(component: type) -> None:
    """physics/ holds generic components: a motor, gearhead, friction or encoder without the device's numbers is
    an error, not silently some paper's device."""
    with pytest.raises(TypeError, match="missing"):
        component()


def test_device_variant_documents_its_source_and_shares_the_compiled_type() -> None:
    rows = {r["name"]: r for r in RE40Motor.describe()}
    assert rows["R"]["default"] == 0.317 and rows["R"]["source"] == "vsaUT-II Table II (RE-40)"
    assert rows["U_max"]["source"] == "vsaUT-II Table IV row 17"
    assert rows["R"]["unit"] == "ohm" and rows["R"]["symbol"] == "R"
    assert type(re40_motor().as_tuple()) is type(DCMotorParams(**re40_motor().to_dict()).as_tuple())
    with pytest.raises(ValueError, match="R"):
        re40_motor().replace(R=-1.0)
    with pytest.raises(ValueError, match="unknown fields"):
        DCMotorParams.variant("X", __name__, "", {"R_typo": 1.0}, source="s", tag="paper")
