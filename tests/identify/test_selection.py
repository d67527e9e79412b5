"""The selection rules' building blocks: the noise floor, the excess share, look-alikes and their report."""

from __future__ import annotations

import numpy as np
import pytest

from vsa_gym.identify.selection import (
    LOOKALIKE_GROUPS,
    SEPARATING,
    Ambiguity,
    excess_share,
    lookalikes,
    noise_floor,
    separating_experiment,
)


@pytest.mark.parametrize("sigma", [1e-6, 1e-4, 1e-2])
def test_noise_floor_recovers_white_noise_under_a_smooth_signal(sigma):
    rng = np.random.default_rng(0)
    t = np.arange(20000) * 1e-3
    y = 0.05 * np.sin(2 * np.pi * 1.3 * t) + 0.02 * np.sin(2 * np.pi * 4.1 * t) + sigma * rng.standard_normal(t.size)
    assert noise_floor(y) == pytest.approx(sigma, rel=0.1)


def test_noise_floor_is_at_least_the_quantiser_step():
    t = np.arange(5000) * 1e-3
    q = 1e-5
    y = np.floor(0.01 * np.sin(2 * np.pi * t) / q) * q
    assert noise_floor(y, q) >= q / np.sqrt(12)


def test_excess_share_counts_only_the_misfit_above_the_floor():
    assert excess_share(0.1, 0.2, 0.1) == pytest.approx(1.0)  # down to the floor: all of the excess
    assert excess_share(0.2, 0.2, 0.1) == pytest.approx(0.0)
    assert excess_share(np.sqrt(0.5 * 0.04 + 0.5 * 0.01), 0.2, 0.1) == pytest.approx(0.5)
    assert excess_share(0.05, 0.1, 0.1) == 0.0  # already at the floor: nothing left to explain


def test_every_lookalike_pair_names_its_separating_experiment():
    for group in LOOKALIKE_GROUPS:
        for a in group:
            for b in group:
                if a != b:
                    assert frozenset({a, b}) in SEPARATING, (a, b)
                    assert b in lookalikes(a)
    assert "reversal" in separating_experiment("backlash", "transmission_compliance")


def test_ambiguity_statement_asserts_neither_and_says_how_to_separate():
    amb = Ambiguity(["backlash", "transmission_compliance"], 1, {"backlash": 0.101, "transmission_compliance": 0.1015},
                    {"backlash": {"backlash.width": 1e-3}, "transmission_compliance": {}},
                    separating_experiment("backlash", "transmission_compliance"))
    text = amb.statement({"backlash": "backlash", "transmission_compliance": "transmission compliance"})
    assert text.startswith("Ambiguous between backlash and transmission compliance")
    assert "neither is asserted" in text and "slow reversal" in text
    assert amb.to_dict()["between"] == ["backlash", "transmission_compliance"]
