"""Where the identification's fits start: a new effect's main parameter, its optional shape parameters, and the
variants of a switch (:class:`vsa_gym.identify.pipeline.Identifier` calls these for every candidate).

Stick-slip, gaps and contacts that ring make the simulation error rough in their parameters, so a single start
can stall in a local minimum far from the truth: each start is the best point of a small grid, all replayed in one
batch (the adapter's batched roll-out).
"""

from __future__ import annotations

import numpy as np

from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.effects import EffectSpec, ParamSpec
from vsa_gym.identify.fitting import SimulationErrorProblem, with_switch_on, without_effect, without_keys
from vsa_gym.identify.result import FittedModel
from vsa_gym.identify.selection import shares_force

#: points of the grid over each optional shape parameter's range (see :func:`shape_starts`)
SHAPE_GRID = 5
#: multiples of the typical size at which a new effect's main parameter is tried (:func:`main_start`), and, finer,
#: where a shape is searched with it: a loop's force and travel trade against each other, and in an open-loop
#: replay a force 2x off runs away as far as one 4x off
MAIN_SIZES: tuple[float, ...] = (0.25, 1.0, 4.0, 16.0)
MAIN_SIZES_SHAPED: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
#: multiples of the held fit's main parameter at which a shape is searched with it (:func:`shape_starts`), and the
#: finer multiples of the best grid point's main parameter then tried at its shape
SHAPE_MAIN_SIZES: tuple[float, ...] = (0.5, 1.0, 2.0)
SHAPE_REFINE: tuple[float, ...] = (0.6, 0.7, 0.8, 0.9, 1.1, 1.25, 1.4, 1.6)
#: shares of an accepted effect's force a new effect of the same kind of force starts with (:func:`split_start`)
SPLIT_SHARES: tuple[float, ...] = (0.25, 0.5, 0.75)


def _range_grid(p: ParamSpec, n: int) -> np.ndarray:
    """``n`` points over a parameter's range: log-spaced where it is positive, even otherwise."""
    return np.geomspace(p.lower, p.upper, n) if p.lower > 0 else np.linspace(p.lower, p.upper, n)


def _searched_axis(q: ParamSpec, *extra: float) -> np.ndarray:
    """The values at which a searched shape (``ParamSpec.grid``) is tried with a main parameter: its grid over the
    range, its typical value and ``extra``."""
    return np.unique(np.append(_range_grid(q, q.grid), [q.typical, *extra]))


def _batch_cost(prob: SimulationErrorProblem, pts: np.ndarray) -> np.ndarray:
    """Fit-part cost of each start (rows of ``pts``, in parameter units) from one batched replay; a start whose
    replay runs away or diverges costs ``inf``, so it is never the best."""
    with np.errstate(over="ignore"):
        sse = np.sum(prob.batch(prob.to_x(pts)) ** 2, axis=1)
    return np.where(np.isfinite(sse), sse, np.inf)


def shape_variants(ad: Adapter, current: FittedModel, fm: FittedModel, spec: EffectSpec,
                   mask: np.ndarray) -> list[tuple[FittedModel, dict[str, float]]]:
    """The free fits ``Identifier._with`` tries: ``(model whose free keys it starts from, shape start)``.  Without a
    switch ``current`` already holds on: ``current`` with each start of :func:`shape_starts`.  With one
    (``current``'s free switches named like one of ``spec``'s): ``current`` as it is with the new effect's
    switches off, and ``current`` with those switches held off too.  Then :func:`switch_flips`."""
    names = {p.name for p in spec.params if p.switch}
    shared = [k for k, p in zip(current.keys, current.specs, strict=True) if p.switch and p.name in names]
    if not shared:
        variants = [(current, shape) for shape in shape_starts(ad, fm, spec, mask)]
    else:
        off = without_keys(current, shared)
        variants = [(current, shape_starts(ad, fm, spec, mask, switches=False)[0]),
                    (off, shape_starts(ad, without_keys(fm, shared), spec, mask, switches=False)[0])]
    return variants + switch_flips(ad, current, fm, spec, mask)


def switch_flips(ad: Adapter, current: FittedModel, fm: FittedModel, spec: EffectSpec,
                 mask: np.ndarray) -> list[tuple[FittedModel, dict[str, float]]]:
    """``current`` with an accepted effect's switch turned on, for each switch it holds off that ``spec`` does
    not bring itself, with the start of :func:`shape_starts` there (``fm``: the held fit of ``current`` plus
    ``spec``).

    A switch left off (a friction that creeps) was chosen without the new effect: a friction that sticks behind
    a gap was fitted as creeping before the gap was there (its tanh blurs the reversals the gap delays), and the
    gap beside the creeping law then removed a fifth of the misfit (truth case 59050: 0.0023 against 0.0025;
    with the friction sticking, 0.0003); beside creeping friction a viscous one removed 45 % (case 43017: 0.0011
    against 0.0014; the truth, sticking, replays at 3e-05)."""
    names = {p.name for p in spec.params if p.switch}
    out = []
    for name in current.effects:
        if name not in ad.effects or name == spec.name:
            continue
        for p in ad.effects[name].params:
            if p.switch and p.name not in names and f"{name}.{p.name}" not in current.keys:
                flipped = with_switch_on(fm, ad.effects[name], p)
                out.append((with_switch_on(current, ad.effects[name], p),
                            shape_starts(ad, flipped, spec, mask, switches=False)[0]))
    return out


def restart_base(ad: Adapter, fm: FittedModel, name: str) -> tuple[FittedModel, bool]:
    """``fm`` without effect ``name``, the model that ``name`` is restarted beside from its own starts (the refined
    refit, ``Identifier._refit_refined``), and whether that restart can hold ``fm``'s switches as they are.

    A switch of ``name`` that is on in ``fm`` (a friction that sticks) is the same physical switch as that of
    another of ``fm``'s effects which has one of the same name (a Stribeck excess and a Coulomb friction are one
    friction: it sticks or it creeps): taken out with ``name``, it is turned on there, so the load still
    sticks while ``name`` is restarted.  Where no other effect has that switch it cannot be held (False)."""
    base = without_effect(fm, name)
    for p in ad.effects[name].params:
        if not (p.switch and f"{name}.{p.name}" in fm.keys):
            continue
        # the same switch on another effect of the model that does not hold it on already
        holder = next(((ad.effects[e], q) for e in base.effects if e in ad.effects for q in ad.effects[e].params
                       if q.switch and q.name == p.name and f"{e}.{q.name}" not in base.keys), None)
        if holder is None:
            return base, False
        base = with_switch_on(base, *holder)
    return base, True


def holding_switches(current: FittedModel, variants: list[tuple[FittedModel, dict[str, float]]]
                     ) -> list[tuple[FittedModel, dict[str, float]]]:
    """The ``variants`` (of :func:`shape_variants` or :func:`switch_flips`) whose model keeps every switch that
    ``current`` has on: a restart of a friction selected sticking tries no variant that lets it creep."""
    on = [k for k, p in zip(current.keys, current.specs, strict=True) if p.switch]
    return [(base, shape) for base, shape in variants if all(k in base.keys for k in on)]


def shape_starts(ad: Adapter, fm: FittedModel, spec: EffectSpec, mask: np.ndarray,
                 switches: bool = True) -> list[dict[str, float]]:
    """Start of an effect's optional shape parameters (with its main parameter): the best fit-part cost on a
    grid of shapes (``SHAPE_GRID`` points, or the parameter's own ``grid``, over each shape parameter's range,
    log-spaced where it is positive, plus its typical value) times main sizes (the held fit's value at 0.5x, 1x
    and 2x, and the typical size), all replayed in one batch, the best point's main size then refined at its
    shape (``SHAPE_REFINE``).  Empty where the held fit's own point (the shapes at their held default,
    ``absent``) is the best.  With switches (``ParamSpec.switch``): the best
    point with every switch off, then the best with one on (``switches=False``: only the first); a shape
    that a switch on leaves out of the equations (``dead_with``) stays at its default on those points."""
    keys, params = list(spec.keys), list(spec.params)
    theta = fm.theta()
    prob = SimulationErrorProblem(ad, {k: v for k, v in theta.items() if k not in keys}, keys, params, mask)
    here = np.array([theta.get(k, p.absent if p.optional else p.typical)
                     for k, p in zip(keys, params, strict=True)])
    axes = []
    for k, p in zip(keys, params, strict=True):
        if p.optional and (switches or not p.switch):
            # the typical value and, for a switch, "off" too
            axes.append(np.unique(np.append(_range_grid(p, p.grid or SHAPE_GRID), [p.typical, p.absent])))
        elif p.optional:
            axes.append(np.array([p.absent]))
        elif p.main:
            v = theta[k]
            g = [p.absent + f * (v - p.absent) for f in SHAPE_MAIN_SIZES] + [p.typical]
            axes.append(np.unique([x for x in g if p.lower < x < p.upper] or [v]))
        else:
            axes.append(np.array([theta.get(k, p.typical)]))
    pts = np.vstack([here, np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(keys), -1).T])
    sw = [i for i, p in enumerate(params) if p.switch]
    is_on = {params[i].name: pts[:, i] != params[i].absent for i in sw}
    keep = np.ones(len(pts), bool)
    for i, p in enumerate(params):
        if p.dead_with in is_on:  # a dead shape's grid values would only repeat the replay
            keep &= ~(is_on[p.dead_with] & (pts[:, i] != p.absent))
    keep[0] = True
    pts = pts[keep]
    sse = _batch_cost(prob, pts)
    on = np.any(pts[:, sw] != np.array([params[i].absent for i in sw]), axis=1) if sw else np.zeros(len(pts), bool)
    bests: list[np.ndarray | None] = []  # each group's best point (None: the held fit's own)
    best_sse: list[float] = []
    for group in ((~on, on) if sw and switches else (~on,)):
        rows = np.flatnonzero(group)
        best = int(rows[np.argmin(sse[rows])])
        held_best = group[0] and (best == 0 or not sse[best] < sse[0])  # the off group holds the held point
        bests.append(None if held_best else pts[best])
        best_sse.append(float(sse[best]))
    # a shape and the main size are coupled (a stiffer contact leaves a narrower gap), and sizes 2x apart are too
    # coarse to start a fit from where the error is rough (truth case 29002: the best grid point kept the held
    # fit's too wide gap, and the free fit accepted no step from it): the best points' main sizes are refined at
    # their shapes (SHAPE_REFINE), in one batch
    i_main = keys.index(spec.main_param[0])
    p_main = params[i_main]
    fine: list[np.ndarray] = []
    owner: list[int] = []
    for j, pt in enumerate(bests):
        for f in SHAPE_REFINE if pt is not None else ():
            v = p_main.absent + f * (pt[i_main] - p_main.absent)
            if p_main.lower < v < p_main.upper:
                fine.append(pt.copy())
                fine[-1][i_main] = v
                owner.append(j)
    if fine:
        cost = _batch_cost(prob, np.array(fine))
        for i in range(len(fine)):
            if cost[i] < best_sse[owner[i]]:
                bests[owner[i]], best_sse[owner[i]] = fine[i], float(cost[i])
    return [{} if pt is None else dict(zip(keys, map(float, pt), strict=True)) for pt in bests]


def main_start(ad: Adapter, current: FittedModel, spec: EffectSpec, mask: np.ndarray) -> dict[str, float]:
    """Start of the new effect's main parameter: the best of a grid (0.25x to 16x its typical size, both
    signs where allowed), all replayed in one batch.  Stick-slip and gaps make the simulation error rough
    in these parameters, so a single start can stall in a local minimum far from the truth.  A fitted shape
    parameter with a ``grid`` (not optional: always fitted) is searched with it, over its range (log-spaced
    where positive) and its typical value: a Dahl loop started at a typical presliding travel 5x the true one
    slid to the shortest travel, a Coulomb friction of twice the loop's force (truth case 11024)."""
    k, p = spec.main_param
    step = p.typical - p.absent
    keys, params = list(spec.keys), list(spec.params)
    searched = {kk for kk, q in zip(keys, params, strict=True) if q.grid and not q.optional}  # with the main one
    sizes = MAIN_SIZES_SHAPED if searched else MAIN_SIZES
    grid = [p.absent + f * step for f in sizes] + [p.absent - f * step for f in sizes]
    grid = [v for v in grid if p.lower + 0.02 * (p.upper - p.lower) < v < p.upper - 0.02 * (p.upper - p.lower)]
    if len(grid) < 2:
        return {}
    axes = []
    for kk, q in zip(keys, params, strict=True):
        if kk == k:
            axes.append(np.array(grid))
        elif kk in searched:
            axes.append(_searched_axis(q))
        else:
            axes.append(np.array([q.typical]))
    pts = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(keys), -1).T
    prob = SimulationErrorProblem(ad, current.theta(), keys, params, mask)
    best = pts[int(np.argmin(_batch_cost(prob, pts)))]
    return {kk: float(v) for kk, v in zip(keys, best, strict=True) if kk == k or kk in searched}


def split_start(ad: Adapter, current: FittedModel, spec: EffectSpec, mask: np.ndarray) -> dict[str, float]:
    """A start that gives the new effect a share of an accepted effect's force (empty where none shares one).

    Look-alikes that are one kind of force at one place (:func:`vsa_gym.identify.selection.shares_force`: a
    Dahl loop and Coulomb friction slide at the sum of their forces) are fitted one after the other: the first
    takes the whole sliding force (and a shape to match: a Dahl loop standing in for loop plus friction has
    the short travel of the sum), and the second, started beside it (:func:`main_start`), only adds to a force
    that is already right, so the least squares keeps it near zero.  Here the accepted effect keeps ``1 - s``
    of its force and the new one starts with ``s`` of it (``s`` in :data:`SPLIT_SHARES`), the searched shapes
    of both (``ParamSpec.grid``) over their grids as in :func:`main_start`, all replayed in one batch; the
    best point is the start (truth cases 7053 and 13053: a Dahl loop carrying loop plus Coulomb force, split,
    refits to both within 3 %)."""
    theta = current.theta()
    k_new, p_new = spec.main_param
    best: tuple[float, dict[str, float]] | None = None
    for old in (o for o in current.effects if o in ad.effects and shares_force(ad.effects[o], spec)):
        k_old, p_old = ad.effects[old].main_param
        force = theta[k_old] - p_old.absent
        # the new force keeps its own sign convention: a friction is positive whatever the accepted one's sign
        new = abs(force) if p_new.lower >= p_new.absent else force
        keys, params, axes = [], [], []
        for kk, q in [*zip(spec.keys, spec.params, strict=True), *zip(ad.effects[old].keys, ad.effects[old].params,
                                                                      strict=True)]:
            if kk in (k_new, k_old) or (q.optional and kk not in theta):
                continue  # the forces follow the share; an optional shape stays as the fit holds it
            keys.append(kk)
            params.append(q)
            here = [theta[kk]] if kk in theta else []  # an accepted shape: where it is, and its grid
            axes.append(_searched_axis(q, *here) if q.grid and not q.optional
                        else np.array([theta.get(kk, q.typical)]))
        grid = np.array(np.meshgrid(np.array(SPLIT_SHARES), *axes, indexing="ij")).reshape(len(axes) + 1, -1).T
        shares = grid[:, 0]
        forces = np.column_stack([[p_new.clip(p_new.absent + s * new) for s in shares],
                                  [p_old.clip(p_old.absent + (1.0 - s) * force) for s in shares]])
        pts = np.column_stack([forces, grid[:, 1:]])
        all_keys = [k_new, k_old, *keys]
        prob = SimulationErrorProblem(ad, {kk: v for kk, v in theta.items() if kk not in all_keys}, all_keys,
                                      [p_new, p_old, *params], mask)
        cost = _batch_cost(prob, pts)
        i = int(np.argmin(cost))
        if np.isfinite(cost[i]) and (best is None or cost[i] < best[0]):
            best = (float(cost[i]), {kk: float(v) for kk, v in zip(all_keys, pts[i], strict=True)})
    return best[1] if best else {}
