"""benchmarks.validation_curves: the best validation return is the one best_model.zip holds, ended episodes counted,
missing runs named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.validation_curves import curve, main


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
