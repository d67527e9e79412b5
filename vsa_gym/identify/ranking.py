"""Ranking of candidate effects by the share of the replay residual their signatures explain.

Step 2 of the pipeline (:mod:`vsa_gym.identify.pipeline`): before any effect is fitted, every candidate's
signature (the secant sensitivity of the replay to its main parameter, at a few sizes) is taken from one batched
replay, and the candidates are ranked by how much of the current model's residual that signature explains beyond
the parameters already free.  Only the best few (and their look-alikes) are then fitted.
"""

from __future__ import annotations

import numpy as np

from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.effects import EffectSpec
from vsa_gym.identify.fitting import lstsq_sse, part_end
from vsa_gym.identify.result import FittedModel

#: multiples of a candidate's typical size at which its ranking signature is taken (:func:`rank_sizes`)
RANK_SIZES: tuple[float, ...] = (1.0, 4.0, 16.0)


def rank_candidates(ad: Adapter, cur: FittedModel, names: list[str], mask: np.ndarray) -> list[tuple[str, float]]:
    """``(name, share)`` best first: the share of the residual's SSE on ``mask`` each candidate's signature
    explains beyond the free parameters of ``cur`` (its best over the sizes of :func:`rank_sizes`)."""
    theta0 = cur.theta()
    rows: list[dict[str, float]] = [dict(theta0)]
    for k, s in zip(cur.keys, cur.specs, strict=True):  # sensitivities of the already-free parameters
        rows.append({**theta0, k: theta0[k] + 0.01 * (abs(s.typical - s.absent) or 1.0)})
    owner: list[str] = []  # the candidate of each signature row
    for name in names:
        spec = ad.effects[name]
        restart = ad.restarts(name, theta0)  # its signature is also taken from where it is also fitted
        for moved in ({}, restart) if restart else ({},):
            for size in rank_sizes(spec):
                rows.append({**theta0, **moved, **{k: p.typical for k, p in zip(spec.keys, spec.params,
                                                                                  strict=True)}, **size})
                owner.append(name)
    keys = sorted({k for r in rows for k in r})
    n = len(rows)
    theta = {}
    for k in keys:
        default = next((p.absent for nm in ad.effects for kk, p in zip(ad.effects[nm].keys, ad.effects[nm].params,
                                                                        strict=True) if kk == k), None)
        if default is None:
            default = theta0.get(k, 0.0)
        theta[k] = np.array([r.get(k, default) for r in rows])
    y = ad.simulate(theta, n, until=part_end(mask))
    sd = np.array([float(np.std(ad.measured[mask, j])) or 1.0 for j in range(y.shape[2])])
    Y = (y[mask] / sd).transpose(1, 0, 2).reshape(n, -1)
    r = ((ad.measured[mask] / sd).reshape(-1) - Y[0])
    nb = len(cur.keys)
    B = np.nan_to_num((Y[1:1 + nb] - Y[0]).T, nan=0.0, posinf=0.0, neginf=0.0)
    base_sse = lstsq_sse(B, r)
    best: dict[str, float] = {}
    for i, name in enumerate(owner):
        sig = Y[1 + nb + i] - Y[0]
        if not np.all(np.isfinite(sig)):  # a size whose replay diverged says nothing about the effect
            best.setdefault(name, -np.inf)
            continue
        S = np.column_stack([B, sig])
        best[name] = max(best.get(name, -np.inf), float((base_sse - lstsq_sse(S, r)) / (base_sse or 1.0)))
    return sorted(best.items(), key=lambda s: -s[1])


def rank_sizes(spec: EffectSpec) -> list[dict[str, float]]:
    """Main-parameter sizes at which a candidate's signature is taken: its typical size, and 4x and 16x it
    where the bounds allow.  The signature of a gap, a stick-slip or a presliding loop changes its shape with
    the size, so one secant at the typical size can miss an effect several times larger (a closed-loop
    backlash of 6x the typical width ranked tenth of twelve on its typical-size secant)."""
    k, p = spec.main_param
    step = p.typical - p.absent
    sizes = [{k: p.typical}]
    for f in RANK_SIZES[1:]:
        v = p.absent + f * step
        if p.lower <= v <= p.upper - 0.02 * (p.upper - p.lower):
            sizes.append({k: v})
    return sizes


__all__ = ["RANK_SIZES", "rank_candidates", "rank_sizes"]
