"""Close the loop (issue #7, item 5), quick version of ``python -m benchmarks.identify_close_loop``.

One seeded vsaUT-II record with a drifted lever spring is identified; the identified parameter set
must rebuild ``VsaUT2-PositionStiffness-v0`` through ``gym.make(..., params=)``, that simulator must
be closer to the truth plant than the nominal one in closed loop, and the decoupled baseline
rebuilt on the identified model must do no worse on the truth plant than the one tuned on the
nominal model, and remove most of its steady stiffness error.  (The full run adds a gain search on
the identified env and its control on the nominal env; too slow for a test.)
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from benchmarks.identify_close_loop import ENV_ID, CloseLoopSettings, markdown, run
from vsa_gym.devices.vsaut2.params import VsaUT2Params


@pytest.fixture(scope="module")
def case() -> tuple[dict, dict[str, VsaUT2Params]]:
    return run(CloseLoopSettings.quick(seed=1), log=lambda s: None)


@pytest.fixture(scope="module")
def quick(case) -> dict:
    return case[0]


def test_identified_params_rebuild_the_environment(case, quick):
    ident = quick["identification"]
    assert [e["name"] for e in ident["effects"]] == ["spring_stiffness_drift"], ident["statements"]
    k = quick["params"]
    # the environment was built with the identified spring rate, not the nominal one
    assert quick["env_rebuilt_lever_k"] == pytest.approx(k["identified"]["lever.k"], rel=1e-12)
    assert abs(k["identified"]["lever.k"] - k["truth"]["lever.k"]) < 0.1 * abs(k["nominal"]["lever.k"] -
                                                                                  k["truth"]["lever.k"])
    identified = case[1]["identified"]
    assert isinstance(identified, VsaUT2Params)
    env = gym.make(ENV_ID, params=identified)
    assert env.unwrapped.task.base_rows[0] is identified
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        obs, rew, term, trunc, _ = env.step(env.action_space.sample())
        assert np.all(np.isfinite(obs)) and np.isfinite(rew)
    env.close()


def test_identified_simulator_is_closer_to_the_truth_plant(quick):
    gap = quick["plant_gap"]
    for key in ("r_rad", "lnK"):
        assert gap["identified"][key] < 0.25 * gap["nominal"][key], gap


def test_rebuilt_controller_is_no_worse_on_the_truth_plant(quick):
    tr = quick["results"]["truth"]
    nom, new = tr["nominal_tuned"], tr["identified_rebuilt"]
    # (not the return: an episode that survives longer accumulates more tracking cost)
    assert new["log_stiffness_rms"] <= nom["log_stiffness_rms"]
    assert new["position_rms_rad"] <= 1.05 * nom["position_rms_rad"]
    assert new["energy_J"] <= 1.05 * nom["energy_J"]
    assert new["violations"] <= nom["violations"]
    # the steady stiffness error a spring-rate error leaves (a ln K bias of about ln(1 + drift)) mostly goes
    drift = quick["case"]["planted"]["spring_stiffness_drift.drift"]
    assert nom["lnK_median_abs"] > 0.5 * np.log1p(abs(drift))
    assert new["lnK_median_abs"] < 0.5 * nom["lnK_median_abs"]
    # and it is as good as the controller designed on the truth itself (the oracle)
    assert new["lnK_median_abs"] < tr["oracle"]["lnK_median_abs"] + 0.01


def test_report_tables(quick):
    md = markdown(quick, "python -m benchmarks.identify_close_loop --quick")
    assert "| identified |" in md and "tuned on nominal" in md
    assert md.count("\n| ") >= 8


def test_search_objective_prices_episodes_that_end_early():
    """The plain return prefers an episode that fails early (it stops accumulating tracking cost); the
    search objective must not."""
    from baselines.retune import objective

    steady = {"return": -500.0, "steps": 1000.0, "violations": 0, "episodes": 4}
    failing = {"return": -400.0, "steps": 600.0, "violations": 2, "episodes": 4}
    assert failing["return"] > steady["return"]
    assert objective(failing) > objective(steady)


def test_gain_multipliers_scale_only_their_group():
    from baselines.retune import GAIN_GROUPS, LOG_BOUND, scaled_config
    from baselines.vsaut2_decoupled import VsaUT2DecoupledConfig

    base = VsaUT2DecoupledConfig()
    assert scaled_config(base, [0.0, 0.0]) == base
    c = scaled_config(base, [np.log(2.0), 10.0])
    for name in GAIN_GROUPS[0]:
        assert getattr(c, name) == pytest.approx(2.0 * getattr(base, name))
    for name in GAIN_GROUPS[1]:
        assert getattr(c, name) == pytest.approx(np.exp(LOG_BOUND) * getattr(base, name))  # clipped
    assert c.int_max == base.int_max and c.deflection_filter_hz == base.deflection_filter_hz
    with pytest.raises(ValueError):
        scaled_config(base, [0.0])
