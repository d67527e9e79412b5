"""agents for vsa-gym (see README)."""
