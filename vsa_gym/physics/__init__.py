"""Component library: each physical component written once, batched over a leading axis."""
