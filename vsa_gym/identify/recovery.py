"""Recovery of planted effects on the device generators: one case, and the tables over seeds.

One *case* is ``(device, experiment, effect, seed)``: a seeded synthetic record with that effect
of random realistic magnitude (``effect=None``: a negative control) is identified with the
configuration the tests use, and the outcome records what was named and how far the main
parameter landed from the truth.  :func:`summarise` turns the outcomes of one catalogue entry
into the row of a recovery table.  Used by ``benchmarks/identify_recovery_devices.py`` and the
device tests (``tests/identify/test_{vsaut2,elpas}_effects.py``).

Each device declares its bench (:class:`SyntheticBench`) in :mod:`vsa_gym.devices`:

* vsaUT-II (:data:`vsa_gym.devices.vsaut2.synthetic.BENCH`): the catalogue is ``RANGES[experiment]``,
  fitted with ``Identifier()`` on the record's own fit/validation parts, scored on its test part.
* eLPAS (:data:`vsa_gym.devices.elpas.synthetic.BENCH`): the catalogue is ``ELPAS_RANGES``; the fit
  record is a sine or step force test of ``ELPAS_DURATION`` s, the held-out record the
  other kind of test of the same device (same planted parameters, another seed),
  ``Identifier(n_fit=2, max_nfev=15)``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from vsa_gym.devices import device, devices
from vsa_gym.identify.pipeline import IdentificationResult


@dataclasses.dataclass(frozen=True)
class SyntheticBench:
    """A device's synthetic-recovery bench (declared by the device, :mod:`vsa_gym.devices`).

    ``catalogue()``: the ``(experiment, effect)`` pairs its generator can plant; ``negative_experiments()``: the
    experiments that get negative controls; ``identify_case(experiment, effect, seed)``: identify one seeded
    record with ``effect`` planted (``None``: none), returning the result and the truth; ``main``: the main
    parameter of each effect (the device's effect library, :func:`vsa_gym.identify.library.main_parameters`).
    """

    catalogue: Callable[[], list[tuple[str, str]]]
    negative_experiments: Callable[[], list[str]]
    identify_case: Callable[[str, str | None, int], tuple[IdentificationResult, dict[str, Any]]]
    main: Mapping[str, str]


def _bench(device_name: str) -> SyntheticBench:
    if device_name not in DEVICES:
        raise ValueError(f"device must be one of {DEVICES}, got {device_name!r}")
    return device(device_name).recovery_bench()


def main_key(device_name: str, effect: str) -> str:
    """The main parameter of ``effect`` on the device."""
    return _bench(device_name).main[effect]


def catalogue(device_name: str) -> list[tuple[str, str]]:
    """``(experiment, effect)`` pairs the device's generator can plant."""
    return _bench(device_name).catalogue()


def negative_experiments(device_name: str) -> list[str]:
    """The experiments that get negative controls."""
    return _bench(device_name).negative_experiments()


def identify_case(device_name: str, experiment: str, effect: str | None,
                  seed: int) -> tuple[IdentificationResult, dict[str, Any]]:
    """Identify one seeded synthetic record with ``effect`` planted; returns the result and the truth."""
    return _bench(device_name).identify_case(experiment, effect, seed)


def run_case(device: str, experiment: str, effect: str | None, seed: int) -> dict[str, Any]:
    """One case as a JSON-able outcome: names accepted, planted and fitted main parameter, error, held-out RMSEs."""
    t0 = time.perf_counter()
    res, truth = identify_case(device, experiment, effect, seed)
    names = [e["name"] for e in res.effects]
    out: dict[str, Any] = {"device": device, "experiment": experiment, "effect": effect, "seed": seed,
                           "named": names, "truth": truth["params"],
                           "rmse_before": {k: v["rmse"] for k, v in res.metrics_before.items()},
                           "rmse_after": {k: v["rmse"] for k, v in res.metrics_after.items()},
                           "fitted": None, "rel_error": None}
    if effect is not None and effect in names:
        k = main_key(device, effect)
        got = float(res.effects[names.index(effect)]["parameters"][k])
        want = float(truth["params"][f"{effect}.{k}"])
        out["fitted"], out["rel_error"] = got, abs(got - want) / abs(want)
    out["seconds"] = time.perf_counter() - t0
    return out


def summarise(outcomes: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Row of a recovery table from the outcomes of one catalogue entry (or of its negative controls).

    Recovered: exactly the planted effect is named.  Parameter error: ``|fitted - true| / |true|`` of
    the main parameter over the recovered seeds.  ``extra``: runs that named the planted effect plus
    another one.  For negative controls, ``false_positive_rate`` is the share of runs naming anything.
    """
    n = len(outcomes)
    effect = outcomes[0]["effect"] if outcomes else None
    row: dict[str, Any] = {"seeds": n, "seconds_median": float(np.median([o["seconds"] for o in outcomes]))
                           if outcomes else None}
    if effect is None:
        fp = [o for o in outcomes if o["named"]]
        row["false_positive_rate"] = len(fp) / n if n else None
        row["false_positives"] = sorted({name for o in fp for name in o["named"]})
        return row
    hits = [o for o in outcomes if o["named"] == [effect]]
    errs = [o["rel_error"] for o in hits]
    row["recovery_rate"] = len(hits) / n if n else None
    row["median_param_error"] = float(np.median(errs)) if errs else None
    row["max_param_error"] = float(np.max(errs)) if errs else None
    row["extra"] = sum(1 for o in outcomes if effect in o["named"] and len(o["named"]) > 1)
    wrong: dict[str, int] = {}
    for o in outcomes:
        if effect not in o["named"]:
            key = "+".join(o["named"]) or "none"
            wrong[key] = wrong.get(key, 0) + 1
    row["missed_as"] = wrong
    return row


#: the devices with a synthetic-recovery bench
DEVICES: tuple[str, ...] = tuple(d.name for d in devices() if d.recovery)

__all__ = ["DEVICES", "SyntheticBench", "catalogue", "identify_case", "main_key", "negative_experiments",
           "run_case", "summarise"]
