"""Cone kinematics: virtual work, the cone property, the paper's anchor value, range checks."""

import numpy as np
import pytest

from vsa_gym.devices.elpas import cone
from vsa_gym.devices.elpas.params import ConeGeometry

C = ConeGeometry()
G = np.radians(np.linspace(-90.0, 90.0, 37))
A = np.radians(np.array([-15.0, -7.0, -3.4, 0.0, 4.2, 9.0, 15.0]))
GG, AA = np.meshgrid(G, A)


def test_force_at_origin_matches_paper() -> None:
    assert cone.actuator_force(C, 0.0, 0.0) == pytest.approx(2555.0, abs=1.0)


def test_forces_are_minus_energy_derivatives() -> None:
    # keep the finite-difference stencil inside the angle range
    g = np.clip(GG, -np.pi / 2 + 1e-5, np.pi / 2 - 1e-5)
    a = np.clip(AA, -C.alpha_max + 1e-5, C.alpha_max - 1e-5)
    eps = 1e-6
    s = cone.spring_state(C, g, a)
    dU_dg = (cone.spring_energy(C, g + eps, a) - cone.spring_energy(C, g - eps, a)) / (2 * eps)
    # F_act = -dU/dx_ext with the suspension extension x_ext = -l sin(alpha)
    x_p, x_m = -C.l * np.sin(a + eps), -C.l * np.sin(a - eps)
    dU_dx = (cone.spring_energy(C, g, a + eps) - cone.spring_energy(C, g, a - eps)) / (x_p - x_m)
    np.testing.assert_allclose(s.T_gamma, -dU_dg, rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(s.F_act, -dU_dx, rtol=1e-6)


def test_effective_stiffness_is_force_derivative() -> None:
    a = np.clip(AA, -C.alpha_max + 1e-5, C.alpha_max - 1e-5)
    eps = 1e-6
    dF = cone.actuator_force(C, GG, a + eps) - cone.actuator_force(C, GG, a - eps)
    ds = C.l * (np.sin(a + eps) - np.sin(a - eps))
    np.testing.assert_allclose(cone.effective_stiffness(C, GG, a), dF / ds, rtol=1e-5)
    assert np.all(cone.effective_stiffness(C, G, 0.0) > 0.0)


def test_no_disturbance_moment_on_the_cone() -> None:
    np.testing.assert_allclose(cone.disturbance_moment(C, G, 0.0), 0.0, atol=1e-9)
    assert np.all(np.abs(cone.disturbance_moment(C, 0.0, A[A != 0.0])) > 1.0)
    # parameters.md anchor: |T_gamma(0, 15 deg)| = 104 N m at the arm
    assert abs(cone.disturbance_moment(C, 0.0, np.radians(15.0))) == pytest.approx(104.0, abs=1.0)


def test_spring_stays_compressed_over_the_range() -> None:
    assert np.all(cone.spring_force(C, GG, AA) > 0.0)


def test_batched_geometry_broadcasts() -> None:
    cb = ConeGeometry(h=[0.25, 0.26])
    f = cone.actuator_force(cb, np.zeros(2), np.zeros(2))
    assert f[0] == pytest.approx(cone.actuator_force(C, 0.0, 0.0))
    assert f[1] != pytest.approx(f[0])


@pytest.mark.parametrize(("gamma", "alpha", "name"), [(0.0, np.radians(15.5), "alpha"),
                                                      (np.radians(91.0), 0.0, "gamma"),
                                                      (0.0, np.nan, "alpha")])
def test_angles_out_of_range_are_rejected(gamma: float, alpha: float, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cone.actuator_force(C, gamma, alpha)
