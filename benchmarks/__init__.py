"""benchmarks for vsa-gym (see README)."""
