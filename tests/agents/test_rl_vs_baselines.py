"""The comparison's statistics, table and doc update (the training itself is covered by the sweep test)."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.rl_vs_baselines import MARK_BEGIN, MARK_END, interval, table, update_doc


def test_interval_is_the_student_t_interval() -> None:
    m, lo, hi = interval([1.0, 2.0, 3.0])
    assert m == 2.0
    assert hi - m == pytest.approx(4.302652729911275 * 1.0 / 3**0.5)  # t_{0.975, 2} s / sqrt(n)
    assert interval([5.0]) == (5.0, 5.0, 5.0)


def test_table_rows_and_doc_section(tmp_path: Path) -> None:
    env = "vsa_gym/ELPAS-ForceTracking-v0"
    metrics = {"force_rms_N": 100.0, "energy_J": 2.0, "peak_power_W": 50.0, "violations": 0, "steps": 50.0,
               "return": -10.0}
    agents = {"PPO": [{"cpu_min": 1.0 + s, "metrics": {**metrics, "force_rms_N": 100.0 + s}} for s in range(3)]}
    base = {"cascade": [dict(metrics, force_rms_N=50.0, episodes=2)]}
    t = table(env, agents, base)
    lines = t.splitlines()
    assert len(lines) == 4 and lines[2].startswith("| cascade | 2 ep. (mean) | 50.0 |")
    assert "| **PPO** | 3 seeds | 101.0 [98.5, 103.5] |" in lines[3] and lines[3].endswith("| 2.0 [-0.5, 4.5] |")
    doc = tmp_path / "agents.md"
    doc.write_text(f"intro\n{MARK_BEGIN}\nold\n{MARK_END}\noutro\n")
    update_doc(doc, "new table")
    assert doc.read_text() == f"intro\n{MARK_BEGIN}\nnew table\n{MARK_END}\noutro\n"
