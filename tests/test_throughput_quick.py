"""``python -m benchmarks.throughput --quick`` completes and every core stays within its accuracy bound.

No wall-clock threshold is asserted (the machines are shared); speed is reported, not tested.
"""

from __future__ import annotations

import json

from benchmarks import throughput


def test_quick_benchmark_completes_with_accuracy_bounds(tmp_path):
    out = tmp_path / "throughput.json"
    rc = throughput.main(["--quick", "--sizes", "1", "8", "--json", str(out)])
    res = json.loads(out.read_text())
    for key in ("peer_steps_per_s", "single_env_steps_per_s", "vector_env_steps_per_s", "identify_20s_record_wall_s"):
        assert key in res
    assert set(res["single_env_steps_per_s"]) == set(res["accuracy"])
    assert all(v > 0 for v in res["single_env_steps_per_s"].values())
    assert all(v > 0 for v in res["vector_env_steps_per_s"].values())
    for env_id, acc in res["accuracy"].items():
        assert acc["worst_relative_state_error"] <= acc["bound"] == 1e-3, env_id
    assert res["etd"], "the opt-in exponential integrator of the vsaUT-II ids is benchmarked too"
    for env_id, e in res["etd"].items():
        assert e["accuracy"]["worst_relative_state_error"] <= e["accuracy"]["bound"] == 1e-3, env_id
    assert res["accuracy_ok"] and rc == 0
