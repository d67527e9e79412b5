"""baselines for vsa-gym (see README)."""
