"""Checks of the independent truth simulator (physics, numerics, records)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.truthsim.integrate import initial_state, simulate
from tests.truthsim.plant import (
    CUR,
    K_F,
    M_M,
    V_L,
    V_M,
    W_DAHL,
    W_DAMP,
    W_FR,
    W_IN,
    W_MESH,
    W_R,
    X_L,
    X_M,
    Y_N,
    param_vector,
    stored_energy,
)
from tests.truthsim.records import run
from tests.truthsim.scenarios import EFFECTS, draw_case, simulate_case, write_case
from vsa_gym.identify.record import check_record

DT = 1e-3
T_TEST = 3000  # samples


def _sine_input(n: int, amp: float) -> np.ndarray:
    t = np.arange(n) * DT
    return amp * (np.sin(2 * np.pi * 0.7 * t) + 0.5 * np.sin(2 * np.pi * 3.3 * t + 1.0))


def _two_mass(**kw: float) -> dict[str, float]:
    m_l, m_m = kw.get("m_l", 20.0), kw.get("m_m", 10.0)
    m_r = m_l * m_m / (m_l + m_m)
    return {"m_r": m_r, "k80": (2 * np.pi * 80) ** 2 * m_r, "k8": (2 * np.pi * 8) ** 2 * m_r}


BASE = {"m_l": 20.0, "m_m": 10.0, "b": 5.0, "K": 60.0, "R": 1.0, "L": 1e-3}
TM = _two_mass()
CONFIGS = {
    "rigid friction+dahl+lossy, voltage": {**BASE, "F_c": 20.0, "F_s": 10.0, "v_s": 0.02, "delta": 1.5, "F_h": 8.0,
                                           "sigma_h": 2e4, "eta_f": 0.8, "eta_b": 0.7, "F_0": 15.0},
    "compliant lossy, current": {**BASE, "amp": 1.0, "G_a": 2.0, "tau_c": 3e-4, "F_c": 10.0, "k_s": TM["k8"],
                                 "c_s": 2 * 0.05 * np.sqrt(TM["k8"] * TM["m_r"]), "eta_f": 0.75, "eta_b": 0.6},
    "backlash+coulomb, voltage": {**BASE, "F_c": 15.0, "k_s": TM["k80"],
                                  "c_s": 2 * 0.1 * np.sqrt(TM["k80"] * TM["m_r"]), "g": 4e-4, "k_b": 5 * TM["k80"],
                                  "c_b": 2 * 0.3 * np.sqrt(5 * TM["k80"] * TM["m_r"])},
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_energy_balance(name: str) -> None:
    """Work in = change of kinetic + magnetic + elastic + potential energy + all dissipation."""
    P = param_vector(**CONFIGS[name])
    u = _sine_input(T_TEST, 6.0 if P[17] == 0 else 3.0)
    sim = simulate(P, DT, T_TEST, u=u, v_max=0.5)
    x = sim.x
    E = stored_energy(P, x)
    D = x[:, W_R] + x[:, W_FR] + x[:, W_MESH] + x[:, W_DAMP] + x[:, W_DAHL]
    residual = x[:, W_IN] - (E - E[0]) - D
    scale = float(np.max(np.abs(x[:, W_IN])))
    assert scale > 1.0 and np.ptp(x[:, X_L]) > 0.01  # it did move and work was done
    assert np.max(np.abs(residual)) < 1e-5 * scale
    assert np.all(np.diff(x[:, W_MESH]) >= -1e-9 * scale)  # the mesh never generates energy
    assert np.all(np.diff(x[:, W_FR]) >= -1e-9 * scale)  # nor does the load friction
    assert sim.overflows == 0


@pytest.mark.parametrize("ratio, moves", [(0.95, False), (1.05, True)])
def test_true_stiction(ratio: float, moves: bool) -> None:
    """A constant drive force below the static level F_c + F_s leaves the load at exactly zero speed."""
    F_st = 30.0 + 12.0
    P = param_vector(m_l=5.0, m_m=0.0, b=2.0, F_c=30.0, F_s=12.0, v_s=0.01, amp=1.0, K=50.0, G_a=1.0, tau_c=5e-4)
    u = np.full(2000, ratio * F_st / 50.0)
    sim = simulate(P, DT, 2000, u=u, x0=initial_state(P, 0.1))
    if moves:
        assert sim.x[-1, X_L] > 0.1 + 1e-3 and np.all(sim.x[:, V_L] >= 0.0)
    else:
        assert np.all(sim.x[:, V_L] == 0.0) and np.all(sim.x[:, X_L] == 0.1)
        assert np.all(sim.modes[100:, 0] == 0)


def test_backlash_contact_never_pulls_and_gap_is_free() -> None:
    """Contact force >= 0 on the engaged side, zero in the gap; the rotor crosses the gap on its own."""
    P = param_vector(**CONFIGS["backlash+coulomb, voltage"])
    sim = simulate(P, DT, T_TEST, u=_sine_input(T_TEST, 6.0), v_max=0.5)
    contact, f = sim.modes[:, 2], sim.f_t
    assert np.all(contact * f >= -1e-9)
    assert np.all(f[contact == 0] == 0.0)
    assert {-1, 0, 1} <= set(np.unique(contact).tolist())
    # a held load (stiction far above the drive); the rotor starts on the - flank and crosses the 2 mm gap
    Q = param_vector(**{**CONFIGS["backlash+coulomb, voltage"], "g": 1e-3, "F_c": 1e4, "amp": 1.0, "G_a": 1.0,
                        "tau_c": 1e-4, "b": 0.0})
    s = simulate(Q, DT, 150, u=np.full(150, 0.2), x0=initial_state(Q, 0.0, gap_position=-1e-3), n_sub=50)
    assert np.all(s.x[:, X_L] == 0.0) and np.all(s.x[:, V_L] == 0.0)
    q = s.x[:, X_M] - s.x[:, Y_N]
    crossing = np.abs(q) < 1e-3
    k1 = int(np.argmax(s.modes[:, 2] == 1))  # first sample in contact on the + flank (it then rebounds)
    assert k1 > 30 and crossing[1:k1].all() and q[k1] > 1e-3 and s.f_t[k1] > 0.0
    assert np.all(s.modes[:, 2] >= 0)  # it never sticks to the - flank it started on
    assert np.all(s.f_t[crossing] == 0.0)
    # free rotor in the gap: m_m dv_m/dt = K i (no transmission force)
    k = np.flatnonzero(crossing[5:-5]) + 5
    k = k[crossing[k - 1] & crossing[k + 1]]
    acc = (s.x[k + 1, V_M] - s.x[k - 1, V_M]) / (2 * DT)
    force = Q[K_F] * 0.5 * (s.x[k + 1, CUR] + s.x[k - 1, CUR])
    assert np.allclose(acc * Q[M_M], force, rtol=1e-2)


def test_efficiency_direction() -> None:
    """Vertical rigid axis with a lossy mesh: lifting uses eta_f, lowering (back-driven) 1/eta_b, between holds."""
    m_l, m_m, eta_f, eta_b = 10.0, 4.0, 0.8, 0.6
    F_g = m_l * 9.81
    base = {"m_l": m_l, "m_m": m_m, "eta_f": eta_f, "eta_b": eta_b, "F_0": F_g, "amp": 1.0, "K": 1.0, "G_a": 1.0,
            "tau_c": 1e-5}
    P = param_vector(**base)
    for F_m, expect in ((1.5 * F_g, (eta_f * 1.5 * F_g - F_g) / (m_l + eta_f * m_m)),
                        (0.3 * F_g, (0.3 * F_g / eta_b - F_g) / (m_l + m_m / eta_b))):
        x0 = initial_state(P, 0.0)
        x0[CUR] = F_m
        s = simulate(P, DT, 200, u=np.full(200, F_m), x0=x0, n_sub=4)
        acc = np.diff(s.x[:, V_L]) / DT
        assert np.allclose(acc[5:], expect, rtol=1e-6), (F_m, acc[5], expect)
    for F_m in (0.7 * F_g, 1.2 * F_g):  # eta_b F_g < F_m < F_g / eta_f: the mesh holds the load
        x0 = initial_state(P, 0.0)
        x0[CUR] = F_m
        s = simulate(P, DT, 200, u=np.full(200, F_m), x0=x0, n_sub=4)
        assert np.all(s.x[:, V_L] == 0.0)


def _open_loop(case, duration: float):  # noqa: ANN001, ANN202 -- a Case forced to an open-loop sine drive
    case.loop, case.replay, case.controller, case.ref, case.duration = "open", "open_loop", None, None, duration
    case.u = _sine_input(case.n, 0.5 * case.design["F_peak"] / case.nominal["k_u"])
    return case


def test_step_halving_convergence() -> None:
    """The same case at 2x and 4x the sub-steps: differences shrink and stay far below the encoder step."""
    case = _open_loop(draw_case(3, ("backlash", "coulomb_friction")), 3.0)
    s1 = run(case)
    s2 = run(case, n_sub=2 * s1.n_sub)
    s4 = run(case, n_sub=4 * s1.n_sub)
    cols = [X_L, X_M]
    e1 = float(np.max(np.abs(s1.x[:, cols] - s4.x[:, cols])))
    e2 = float(np.max(np.abs(s2.x[:, cols] - s4.x[:, cols])))
    res = case.sensor["resolution"]
    assert np.ptp(s4.x[:, X_L]) > 50 * res and s1.events > 10
    assert e1 < 0.01 * res and e2 < 0.01 * res
    assert e2 <= e1 or e1 < 1e-9 * np.ptp(s4.x[:, X_L])


def test_determinism(tmp_path) -> None:
    """The same seed gives the identical record; another seed another one."""
    a = simulate_case(draw_case(11, ("hysteresis",)))
    b = simulate_case(draw_case(11, ("hysteresis",)))
    c = simulate_case(draw_case(12, ("hysteresis",)))
    assert a[0].equals(b[0]) and a[1] == b[1] and a[2]["planted"] == b[2]["planted"]
    assert not (a[0].shape == c[0].shape and a[0].equals(c[0]))
    p1 = write_case(draw_case(11, ("hysteresis",)), tmp_path / "one")
    p2 = write_case(draw_case(11, ("hysteresis",)), tmp_path / "two")
    assert p1.read_bytes() == p2.read_bytes()
    assert p1.with_suffix(".json").read_bytes() == p2.with_suffix(".json").read_bytes()


@pytest.mark.parametrize("effects", [("backlash",), ("transmission_compliance", "sensor_delay"), ()])
def test_a_given_rate_and_duration_keep_the_rest_of_the_draw(effects, tmp_path) -> None:
    """``draw_case(rate=, duration=)`` (the timing set of benchmarks/identify_truth.py) changes the sampling
    and nothing drawn before it; the record is valid, and a rate or length <= 0 is refused."""
    for seed in (11049, 11000, 7015):
        drawn = draw_case(seed, effects)
        fixed = draw_case(seed, effects, rate=1000.0, duration=20.0)
        assert (fixed.rate, fixed.duration, fixed.n) == (1000.0, 20.0, 20000)
        assert (fixed.axis, fixed.amplifier, fixed.loop, fixed.replay, fixed.excitation, fixed.x0) == \
            (drawn.axis, drawn.amplifier, drawn.loop, drawn.replay, drawn.excitation, drawn.x0)
    assert check_record(write_case(fixed, tmp_path)) == []
    for bad in ({"rate": 0.0}, {"duration": -1.0}):
        with pytest.raises(ValueError, match="must be > 0"):
            draw_case(1, effects, **bad)


COMBOS = [(), *[(e,) for e in EFFECTS], ("coulomb_friction", "force_offset"), ("backlash", "coulomb_friction"),
          ("gearbox_efficiency", "viscous_friction"), ("transmission_compliance", "gearbox_efficiency")]


@pytest.mark.parametrize("seed", [1, 2])
def test_drawn_cases_pass_check_record(seed: int, tmp_path) -> None:
    """Every drawn case is a valid record (checked on disk, as ``vsa-gym data check`` does)."""
    for i, effects in enumerate(COMBOS):
        case = draw_case(1000 * seed + i, effects)
        path = write_case(case, tmp_path)
        assert check_record(path) == [], (effects, case.summary())
        tru = path.parent / (path.stem + ".truth.json")
        assert tru.exists()
        meta = path.with_suffix(".json").read_text()
        assert all(e not in meta for e in effects)  # the truth stays out of the sidecar
        if effects == ("coulomb_friction", "force_offset"):
            assert case.vertical and case.loop == "closed"


def test_speed_20s_at_1khz() -> None:
    """A 20 s record at 1 kHz simulates well within 15 s on one core (after compilation)."""
    case = draw_case(5, ("backlash", "coulomb_friction"))
    case.rate = 1000.0
    case = _open_loop(case, 20.0)
    run(case)
    t0 = time.perf_counter()
    run(case)
    assert time.perf_counter() - t0 < 15.0
