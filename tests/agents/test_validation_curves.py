"""benchmarks.validation_curves: the best validation return is the one best_model.zip holds, ended episodes counted,
missing runs named."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from benchmarks.validation_curves import curve, main, return_scale


def _write(run: Path, results: list[list[float]], lengths: list[list[int]]) -> None:
    run.mkdir(parents=True)
    np.savez(run / "evaluations.npz", timesteps=np.arange(1, len(results) + 1) * 1000, results=np.array(results),
             ep_lengths=np.array(lengths))


def test_curve_picks_the_first_best_and_counts_ended(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "ppo" / "env_1"
    _write(run, [[-5.0, -7.0], [-2.0, -4.0], [-3.0, -3.0], [-9.0, -1.0]], [[50, 50], [50, 20], [50, 50], [50, 50]])
    c = curve(run)
    assert c["best_step"] == 2000 and c["best_return"] == -3.0  # [-2, -4] and [-3, -3] tie: the first is kept
    assert c["evaluations_with_ended"] == 1
    assert main([str(run), "--last", "2"]) == 0
    out = capsys.readouterr().out
    assert "4 evaluations, best -3.0 at 2000; 1 with an ended episode | last 2: 3k: -3.0, 4k: -5.0" in out


def test_missing_run_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(tmp_path / "nope")]) == 2
    assert "nope/evaluations.npz not found" in capsys.readouterr().err


def _args(run: Path, env: str, eval_kwargs: dict | None, env_kwargs: dict | None = None) -> None:
    import yaml

    name = env.replace("/", "-")
    (run / name).mkdir()
    (run / name / "args.yml").write_text(yaml.safe_dump({"env": env, "eval_kwargs": eval_kwargs}))
    (run / name / "config.yml").write_text(yaml.safe_dump({"env_kwargs": env_kwargs or {}}))


def test_rescoring_moves_the_charge_of_ended_episodes_only(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """At failure rate 1 the checkpoint that lasts longer on a road every policy fails on wins; rescored at 0.3 the
    one that rides the other roads better does.  Full-length episodes keep their returns."""
    run = tmp_path / "ppo" / "qc_1"
    T = 5000  # the quarter car's time limit
    # checkpoint 1: ends the bad road at 1000 (charged 1.0 x 4000); checkpoint 2: lasts to 4000, rides worse
    _write(run, [[-300.0 - 4000.0, -1000.0], [-1300.0 - 1000.0, -1500.0]], [[1000, T], [4000, T]])
    _args(run, "vsa_gym/ELPAS-QuarterCar-v0", {"failure_rate": 1.0})
    from benchmarks.validation_curves import rescore

    c = curve(run)
    assert c["best_step"] == 2000
    rs = rescore(run, c, 0.3)
    np.testing.assert_allclose(rs["mean_return"], [(-300 - 0.3 * 4000 - 1000) / 2, (-1300 - 0.3 * 1000 - 1500) / 2])
    assert rs["best_step"] == 1000 and rs["own_rate"] == 1.0
    assert main([str(run), "--failure-rate", "0.3"]) == 0
    assert "failure_rate 1 -> 0.3: best -1250.0 at 1000" in capsys.readouterr().out


def test_rescoring_needs_a_stated_rate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "ppo" / "throw_1"
    _write(run, [[1.0], [2.0]], [[300], [400]])  # a throw's short episode is its release, not a failure
    _args(run, "vsa_gym/VsaUT2-Throw-v0", None)
    assert main([str(run), "--failure-rate", "0.3"]) == 2
    assert "states no failure_rate" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([str(run), "--failure-rate", "-1"])


def test_return_scale_reads_the_final_normalizer(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The scale is the square root of VecNormalize's return variance, read from the run's own statistics; a run
    without them is named."""
    run = tmp_path / "ppo" / "ps_1"
    _write(run, [[-5.0], [-3.0]], [[50], [50]])
    assert main([str(run), "--return-scale"]) == 2
    assert "holds no */vecnormalize.pkl" in capsys.readouterr().err

    vn = VecNormalize(DummyVecEnv([lambda: gym.make("Pendulum-v1")]))
    vn.ret_rms = RunningMeanStd(shape=())
    vn.ret_rms.update(np.array([0.0, -300.0, 0.0, -300.0]))  # variance 150^2
    (run / "env").mkdir()
    vn.save(str(run / "env" / "vecnormalize.pkl"))
    assert return_scale(run) == pytest.approx(150.0, rel=1e-3)
    assert main([str(run), "--return-scale"]) == 0
    assert "| return scale 150.0" in capsys.readouterr().out
