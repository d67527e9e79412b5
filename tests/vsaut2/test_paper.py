"""The model against the paper's figures and Table IV, each within a stated tolerance."""

import numpy as np
import pytest

from vsa_gym.devices.vsaut2 import experiments as ex
from vsa_gym.devices.vsaut2.calibration import TARGET_TIME_S, stiffness_variation_time
from vsa_gym.devices.vsaut2.datasheet import compute, format_table


def test_fig10_period_and_decay(model):
    osc = ex.fig10_free_oscillation(model)
    assert osc.period_s == pytest.approx(0.77, rel=0.05)  # paper 0.77 s; model 0.79 (cos(2 phi) softening)
    # the paper's c = 2 delta I_o treats delta = 0.56 as a decay rate (1/s); the model uses that c
    assert osc.decay_rate_per_s == pytest.approx(0.56, rel=0.05)


def test_lever_length_reproduces_the_calibration_row(model):
    assert stiffness_variation_time(model.params)[0] == pytest.approx(TARGET_TIME_S, abs=0.01)


def test_gearbox_efficiency_reaches_eta_max_at_rated_torque(model):
    for gb in (model.params.pivot_gearbox, model.params.frame_gearbox):
        tau_in, eta = ex.fig8_efficiency(gb)
        assert np.all(np.diff(eta[eta > 0]) >= -1e-12)  # monotone
        at_rated = np.interp(gb.tau_max, tau_in * gb.n, eta)
        assert at_rated == pytest.approx(gb.eta_max * (1 - np.exp(-gb.alpha)), rel=2e-2)


# rows checked as predictions (tolerance beside each); by-construction rows are checked tightly
TOLERANCES = {
    "Continuous Output Power": 0.05,
    "Nominal Torque": 0.01,
    "Nominal Speed": 0.05,
    "Nom. Stiffness Variation Time: no load": 0.02,
    "Nom. Stiffness Variation Time: nom. torque": 0.15,
    "Peak (Maximum) Torque": 0.03,
    "Maximum Stiffness": 0.03,
    "Minimum Stiffness": 0.01,
    "Maximum Elastic Energy": 0.01,
    "Maximum Deflection: min. stiffness": 0.01,
    "Active Rotation Angle": 0.01,
    "Angular Resolution": 0.01,
    "Nominal Voltage": 1e-9,
    "Nominal Current": 0.15,
    "Maximum Current": 1e-9,
}
# rows the model does not reproduce, with the reason given in the protocol column
NOT_REPRODUCED = {"Maximum Speed", "Maximum Torque Hysteresis", "Maximum Deflection: max. stiffness", "Weight",
                  "Control Voltage Supply", "Control Nominal Current", "I/O Protocol"}


def test_table_iv_rows():
    rows = compute()
    names = {r["quantity"] for r in rows}
    assert len(rows) == 22 and names == set(TOLERANCES) | NOT_REPRODUCED
    for r in rows:
        assert r["protocol"]
        if r["quantity"] in TOLERANCES:
            assert abs(r["rel_diff"]) <= TOLERANCES[r["quantity"]], format_table([r])
    assert "| 8 | Maximum Stiffness |" in format_table(rows)
