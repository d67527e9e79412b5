"""The as-measured vsaUT-II (issue 19): the shipped named set is what the fit gives, it reproduces the paper's
measured figures, and the envs take it by name."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vsa_gym  # noqa: F401  (registers the ids)
from vsa_gym.devices.vsaut2.as_measured import TARGETS, fit_as_measured, measured_figures
from vsa_gym.devices.vsaut2.params import AS_MEASURED, PARAMETER_SETS, VsaUT2Params

#: Tolerances on each measured figure (the paper's precision: hysteresis in whole %, period in 10 ms, decrement in
#: 0.01, stiffness in N m/rad).
TOL = {"hysteresis_percent": 0.1, "period_s": 2e-3, "log_decrement": 5e-3, "max_stiffness": 1.0}


@pytest.fixture(scope="module")
def shipped() -> dict[str, float]:
    return measured_figures(VsaUT2Params.as_measured())


def test_the_shipped_set_reproduces_the_measured_figures(shipped: dict[str, float]) -> None:
    for name, (value, _, _) in TARGETS.items():
        assert abs(shipped[name] - value) <= TOL[name], (name, shipped[name], value)


def test_the_nominal_set_misses_them_and_decays_slower() -> None:
    nominal = measured_figures(VsaUT2Params())
    assert nominal["hysteresis_percent"] < 3.0  # only viscous losses
    assert nominal["period_s"] > 0.785
    assert nominal["log_decrement"] < 0.45  # the linear model decays slower than the measurement (Fig. 10)


def test_refitting_gives_the_shipped_numbers() -> None:
    p, report = fit_as_measured(rounds=2)
    fitted = {"effects.mu_h": p.effects.mu_h, "effects.phi_h": p.effects.phi_h, "I_o": p.I_o, "c_o": p.c_o,
              "belt.C_belt": p.belt.C_belt}
    for key, value in AS_MEASURED.items():
        assert fitted[key] == pytest.approx(value, rel=2e-3), key
    for name, (value, _, _) in TARGETS.items():
        assert abs(report["figures"][name] - value) <= TOL[name], name


def test_only_the_named_parameters_differ_from_nominal() -> None:
    nominal, measured = VsaUT2Params().to_dict(), VsaUT2Params.as_measured().to_dict()

    def flat(d: dict, prefix: str = "") -> dict:
        out: dict = {}
        for k, v in d.items():
            out.update(flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
        return out

    a, b = flat(nominal), flat(measured)
    assert {k for k in a if a[k] != b[k]} == set(AS_MEASURED)


def test_the_hysteresis_is_load_proportional() -> None:
    """The loop is a share of the torque: about the same hysteresis % at a stiffer and a softer setting (the
    nominal model's viscous frame creep and the fixed presliding deflection move it by a few %)."""
    from vsa_gym.devices.vsaut2.datasheet import hysteresis_percent
    from vsa_gym.devices.vsaut2.model import VsaUT2Model

    m = VsaUT2Model(VsaUT2Params.as_measured())
    h = [hysteresis_percent(m, q1=q1) for q1 in (0.0068, 0.012, 0.020)]
    assert min(h) > 8.0 and max(h) < 16.0, h


@pytest.mark.parametrize("env_id", ["vsa_gym/VsaUT2-PositionStiffness-v0", "vsa_gym/VsaUT2-Throw-v0"])
def test_envs_take_the_set_by_name(env_id: str) -> None:
    env = gym.make(env_id, params="as_measured")
    assert env.unwrapped.task.params == VsaUT2Params.as_measured()
    obs, _ = env.reset(seed=0)
    for _ in range(50):
        obs, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(obs))
    assert gym.make(env_id, params="nominal").unwrapped.task.params == VsaUT2Params()
    with pytest.raises(ValueError, match="valid names: " + ", ".join(PARAMETER_SETS)):
        gym.make(env_id, params="measured")


def test_the_datasheet_prints_paper_nominal_and_as_measured() -> None:
    from vsa_gym.devices.vsaut2.datasheet import compute, format_table

    rows = compute()
    table = format_table(rows)
    assert "| paper | nominal | rel. diff | as-measured | rel. diff |" in table.splitlines()[0]
    by = {r["quantity"]: r for r in rows}
    assert by["Maximum Torque Hysteresis"]["as_measured"] == pytest.approx(12.0, abs=0.1)
    assert by["Maximum Torque Hysteresis"]["model"] < 3.0
    assert by["Maximum Stiffness"]["as_measured"] == pytest.approx(948.0, abs=1.0)
    assert by["Peak (Maximum) Torque"]["as_measured"] == by["Peak (Maximum) Torque"]["model"]  # drive unchanged


def test_the_transfer_table_lists_both_sets() -> None:
    from benchmarks.vsaut2_transfer import table

    row = {"env": "vsa_gym/VsaUT2-Throw-v0", "policy": "p", "tuned_on": "nominal",
           "nominal": {"return": 5.0, "violations": 0.0}, "as_measured": {"return": 4.0, "violations": 1.0}}
    lines = table([row]).splitlines()
    assert "| nominal | as-measured | change |" in lines[0]
    assert lines[2] == "| VsaUT2-Throw-v0 | p | nominal | return | 5 | 4 | -20.0 % |"
    assert lines[3] == "| | | | violations | 0 | 1 | +1 |"
