"""Shared assertion of the planted-effect tests: the right cause, its parameter, its CI, the held-out gain."""

from collections.abc import Sequence
from typing import Any

import pytest


def assert_planted_effect_recovered(res: Any, truth: dict[str, Any], effect: str, key: str, rel_tol: float,
                                    rmse_ratio: float, outputs: Sequence[str] | None = None,
                                    noise_rmse: float = 0.0) -> None:
    """``effect`` alone is named, ``key`` is within ``rel_tol`` of the truth with a CI that excludes 0, and
    the held-out RMSE of each of ``outputs`` (default: every output) falls below ``rmse_ratio`` times the
    nominal model's, or to the sensor's own noise ``noise_rmse`` (within 5 %, about two standard errors of an
    RMSE over a few hundred samples) where the effect is less than ``1 / rmse_ratio`` times the noise."""
    names = [e["name"] for e in res.effects]
    assert names == [effect], f"planted {effect} {truth['params']}, named {names}: {res.statements()}"
    got = res.effects[0]["parameters"][key]
    want = truth["params"][f"{effect}.{key}"]
    assert got == pytest.approx(want, rel=rel_tol)
    lo, hi = res.effects[0]["ci"][key]
    assert lo < hi and not lo <= 0.0 <= hi
    for out, before in res.metrics_before.items():
        if outputs is not None and out not in outputs:
            continue
        bound = max(rmse_ratio * before["rmse"], 1.05 * noise_rmse)
        assert res.metrics_after[out]["rmse"] < bound, (out, before, res.metrics_after[out], noise_rmse)
