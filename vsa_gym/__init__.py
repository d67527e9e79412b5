"""vsa-gym: simulations, Gymnasium environments, baselines and identification for the vsaUT-II and the eLPAS."""

__version__ = "0.1.0"
