"""Hidden effects in seeded synthetic drive records: the right cause, its parameter, nothing else.

Each record hides one effect of random magnitude (``vsa_gym.devices.drive.synthetic.DRIVE_RANGES``),
with encoder quantisation (10 um, floor) and white noise (20 um).  Tolerance on the
recovered main parameter: 10 % relative.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.identify.recovery import assert_planted_effect_recovered
from vsa_gym.devices.drive.effects import LIBRARY as DRIVE_LIBRARY
from vsa_gym.devices.drive.model import DriveParams, simulate
from vsa_gym.devices.drive.synthetic import ENCODER_STEP, NOISE_STD, make_drive_record
from vsa_gym.identify.library import main_parameters
from vsa_gym.identify.pipeline import Identifier
from vsa_gym.physics.friction import CoulombViscousParams, coulomb_viscous_moment

REL_TOL = 0.10
NOISE_RMSE = float(np.hypot(NOISE_STD, ENCODER_STEP / np.sqrt(12)))  # the synthetic sensor's noise and quantiser
MAIN = main_parameters(DRIVE_LIBRARY)  # the drive library's main parameter of each effect


def _check(effect: str, seed: int) -> None:
    rec, truth = make_drive_record(seed, effect)
    res = Identifier().fit(rec).result_
    assert_planted_effect_recovered(res, truth, effect, MAIN[effect], REL_TOL, 0.5, noise_rmse=NOISE_RMSE)
    assert "95 % CI" in res.statements()[0]


@pytest.mark.parametrize("effect", ["coulomb_friction", "stribeck_friction", "gearbox_efficiency", "hysteresis",
                                    "viscous_friction", "force_offset"])
def test_physical_effect_is_named_and_recovered(effect):
    _check(effect, seed=11)


# look-alike pairs: each member planted, the other must not be named
@pytest.mark.parametrize("effect", ["coulomb_friction", "sensor_offset"])
def test_lookalike_coulomb_vs_offset(effect):
    _check(effect, seed=3)


@pytest.mark.parametrize("effect", ["coulomb_friction", "backlash"])
def test_lookalike_coulomb_vs_backlash(effect):
    _check(effect, seed=4)


@pytest.mark.parametrize("effect", ["sensor_gain", "inertia_error"])
def test_lookalike_gain_vs_inertia(effect):
    _check(effect, seed=5)


@pytest.mark.parametrize("effect", ["transmission_compliance", "sensor_delay"])
def test_lookalike_compliance_vs_delay(effect):
    _check(effect, seed=6)


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_negative_control_reports_none(seed):
    rec, _ = make_drive_record(100 + seed, None)
    res = Identifier().fit(rec).result_
    assert res.effects == []
    assert res.statements()[0].startswith("No significant effect")
    assert any(c.fitted and not c.accepted for c in res.candidates)


def test_random_effect_generator_is_seeded():
    a, ta = make_drive_record(7)
    b, tb = make_drive_record(7)
    assert ta == tb
    np.testing.assert_array_equal(a.output("position"), b.output("position"))
    assert make_drive_record(8)[1] != ta


def test_drive_friction_matches_the_physics_component():
    """The drive's Coulomb + viscous law is the one of vsa_gym.physics.friction (steady motion)."""
    F_c, b, eps = 2.0, 5.0, 1e-3
    for v in (-0.3, 0.2):
        # balance k_u u = F_c tanh(v/eps) + b v at constant speed: start there, check it stays
        f = float(coulomb_viscous_moment(CoulombViscousParams(F_c=F_c, b=b, omega_eps=eps), np.array(v)))
        P = DriveParams(m=1.0, b=b, k_u=1.0, F_c=F_c, v_eps=eps).vector(1)
        x0 = np.array([0.0, v, 0.0, v, 0.0, 0.0, 0.0])
        y = simulate(P, np.full(200, f), 1e-3, x0=x0)
        assert y[-1, 0, 1] == pytest.approx(v, rel=1e-9)


def test_backlash_contact_adds_only_the_gap():
    """Inside the gap exactly no force, spring or damper (up to the corners, E_CORNER g wide); beyond it the
    fixed, well damped contact (not a free parameter) acts on d - g; the corners are C1."""
    from vsa_gym.devices.drive.model import E_CORNER, ZETA_CONTACT, _tforce, contact_stiffness

    gap = 4e-3
    P = DriveParams(m=2.0, backlash=gap).vector(1)[0]
    k, g = float(contact_stiffness(P)[0]), 0.5 * gap
    m_r = 0.25 * 2.0
    for d in np.linspace(-(1 - E_CORNER) * g, (1 - E_CORNER) * g, 41):
        assert _tforce(P, d, 0.0) == 0.0 and _tforce(P, d, 1.0) == 0.0  # free play, even while closing
    assert _tforce(P, -(g + 1e-3), 0.0) == pytest.approx(-k * 1e-3)  # contact, either side
    assert _tforce(P, g + 1e-3, 0.0) == pytest.approx(k * 1e-3)
    c = _tforce(P, 2 * g, 1.0) - _tforce(P, 2 * g, 0.0)
    assert c == pytest.approx(2 * ZETA_CONTACT * np.sqrt(k * m_r))
    # C1 through the corner: the spring force's slope goes from 0 to k without a jump
    ds = np.linspace((1 - 2 * E_CORNER) * g, (1 + 2 * E_CORNER) * g, 2001)
    f = np.array([_tforce(P, d, 0.0) for d in ds])
    slope = np.diff(f) / np.diff(ds)
    assert np.max(np.abs(np.diff(slope))) < 0.01 * k and slope[0] == 0.0 and slope[-1] == pytest.approx(k)
    # with a compliance the transmission uses k_c, c_c (the gap is unchanged)
    Pc = DriveParams(m=2.0, backlash=gap, k_c=5e3, c_c=3.0).vector(1)[0]
    assert _tforce(Pc, g + 1e-3, 0.0) == pytest.approx(5.0, rel=1e-12)


def test_a_free_load_coasts_through_the_gap_untouched():
    """A frictionless load crossing the gap of a held motor keeps its speed exactly until the far tooth (the
    independent truth simulator's sharp dead zone; a rounded one pushed a floating load across, case 5015 of
    `benchmarks.identify_truth --seed 5`)."""
    gap, v = 4e-3, 0.01
    P = DriveParams(m=1.0, b=0.0, k_u=1.0, frac_m=0.5, backlash=gap).vector(1)
    # motor at rest in the middle; the load starts 0.9 g behind it, moving towards the far tooth
    x0 = np.array([-0.45 * gap, v, 0.0, 0.0, 0.0, 0.0, 0.0])
    y = simulate(P, np.zeros(80), 1e-3, x0=x0)  # 0.08 s: the load travels 0.8 mm of the 1.8 mm to contact
    assert np.all(y[:, 0, 1] == v)
    assert np.all(y[:, 0, 2] == 0.0)

