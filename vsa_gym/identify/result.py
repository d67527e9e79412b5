"""What an identification returns: fitted models, candidates, metrics and the result object.

:class:`IdentificationResult` follows the estimator-result shape (``to_frame()``, ``plot()``,
``to_json()``); :class:`FittedModel` is one fitted parameter set with its CIs and scores;
:class:`Candidate` one effect tried in one round, with the reason it was accepted or not.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.effects import ParamSpec
from vsa_gym.identify.record import Record
from vsa_gym.identify.selection import Ambiguity


# ----------------------------------------------------------------------------- metrics
def output_metrics(meas: np.ndarray, sim: np.ndarray) -> dict[str, float]:
    e = sim - meas
    rmse = float(np.sqrt(np.mean(e**2)))
    sd = float(np.std(meas)) or 1.0
    fit = 100.0 * (1.0 - np.linalg.norm(e) / (np.linalg.norm(meas - meas.mean()) or 1.0))
    return {"rmse": rmse, "nrmse": rmse / sd, "fit_percent": float(fit)}


def acf(x: np.ndarray, lags: int) -> np.ndarray:
    x = x - x.mean()
    d = float(np.dot(x, x)) or 1.0
    return np.array([np.dot(x[:-k], x[k:]) / d for k in range(1, lags + 1)])


def residual_tests(res: np.ndarray, u: np.ndarray, lags: int = 25) -> dict[str, float]:
    """Whiteness (autocorrelation) and residual-input cross-correlation, with the 95 % bound 1.96/sqrt(N)."""
    n = res.shape[0]
    bound = 1.96 / math.sqrt(n)
    acf_values = acf(res, lags)
    r = res - res.mean()
    v = u - u.mean()
    den = (np.linalg.norm(r) * np.linalg.norm(v)) or 1.0
    xc = np.array([np.dot(r[k:], v[:n - k]) / den for k in range(lags + 1)])
    return {"acf_max": float(np.max(np.abs(acf_values))),
            "acf_frac_outside": float(np.mean(np.abs(acf_values) > bound)),
            "xcorr_input_max": float(np.max(np.abs(xc))), "bound": bound,
            "white": bool(np.mean(np.abs(acf_values) > bound) <= 0.1)}


# ----------------------------------------------------------------------------- fitted models
@dataclasses.dataclass
class FittedModel:
    """A model: effects, fitted values of all free keys, CIs, scores."""

    effects: tuple[str, ...]
    keys: list[str]
    specs: list[ParamSpec]
    values: np.ndarray
    ci: np.ndarray  # (k, 2)
    sse_fit: float
    n_fit: int
    val_score: float  # mean over outputs of rmse / std on the validation part
    at_bound: list[str]
    rho: float = 0.0
    fit_score: float = float("nan")  # the same NRMSE on the fit part
    #: the replay on the validation part, ``(samples, outputs)``, normalised by the measured std there
    val_pred: np.ndarray | None = dataclasses.field(default=None, repr=False)

    @property
    def bic(self) -> float:
        return self.n_fit * math.log(max(self.sse_fit / self.n_fit, 1e-300)) + len(self.keys) * math.log(self.n_fit)

    def theta(self) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.keys, self.values, strict=True)}

    def param(self, key: str) -> tuple[float, float, float]:
        i = self.keys.index(key)
        return float(self.values[i]), float(self.ci[i, 0]), float(self.ci[i, 1])


@dataclasses.dataclass
class Candidate:
    round: int
    name: str
    score: float  # share of residual SSE explained by the signature (ranking)
    fitted: bool = False
    val_score: float = float("nan")
    bic: float = float("nan")
    share: float = float("nan")  # share of the excess misfit (above the noise floor) it removes (``judged_on``)
    judged_on: str = "validation"  # "fit" where the validation part cannot tell the candidate from the model before
    ci_excludes_absent: bool = False
    at_bound: bool = False
    accepted: bool = False
    reason: str = ""
    values: dict[str, float] = dataclasses.field(default_factory=dict)


# ----------------------------------------------------------------------------- result
@dataclasses.dataclass
class IdentificationResult:
    record: Record
    adapter: Adapter
    nominal: FittedModel
    final: FittedModel
    candidates: list[Candidate]
    metrics_before: dict[str, dict[str, float]]
    metrics_after: dict[str, dict[str, float]]
    diagnostics_before: dict[str, Any]
    diagnostics_after: dict[str, Any]
    test_name: str
    test_data: dict[str, np.ndarray]  # t, measured, nominal, extended (held-out part)
    unexplained: float  # share of the nominal validation residual that remains
    ambiguous: list[Ambiguity] = dataclasses.field(default_factory=list)  # look-alikes the data cannot separate
    replay_mode: str = ""  # how the record was replayed (full replay or multiple shooting, and why)
    noise_floor: float = 0.0  # estimated measurement noise, as a validation NRMSE

    @property
    def ambiguous_names(self) -> set[str]:
        return {n for a in self.ambiguous for n in a.between}

    @property
    def effects(self) -> list[dict[str, Any]]:
        """The effects the workbench asserts (an ambiguous look-alike is in the model but not asserted)."""
        out = []
        for name in self.final.effects:
            if name in self.ambiguous_names:
                continue
            spec = self.adapter.effects[name]
            params, ci = {}, {}
            for p in spec.params:  # an optional shape parameter not freed is held at its default
                key = f"{name}.{p.name}"
                v, lo, hi = self.final.param(key) if key in self.final.keys else (p.absent,) * 3
                params[p.name] = v
                ci[p.name] = [lo, hi]
            out.append({"name": name, "location": spec.location, "parameters": params, "ci": ci,
                        "units": {p.name: p.unit for p in spec.params}})
        return out

    def statements(self) -> list[str]:
        """The causes in words."""
        describe = {n: s.description for n, s in self.adapter.effects.items()}
        amb = [a.statement(describe) for a in self.ambiguous]
        if not self.effects:
            return [*amb, f"No significant effect{' asserted' if amb else ''}: the nominal model is kept; "
                    f"{100 * self.unexplained:.0f} % of the validation residual variance remains unexplained "
                    "(noise and unmodelled effects)."]
        lines = []
        for e in self.effects:
            spec = self.adapter.effects[e["name"]]
            main = spec.main_param[1]
            v = e["parameters"][main.name]
            lo, hi = e["ci"][main.name]
            unit = f" {main.unit}" if main.unit and main.unit != "-" else ""
            # a shape parameter the data asked to free (held at its default otherwise) is part of the cause
            freed = set(self.final.keys)
            shapes = "".join(f"; {p.name}" if p.pinned else  # a switch: on
                             f"; {p.name} = {e['parameters'][p.name]:.3g}"
                             f"{f' {p.unit}' if p.unit and p.unit != '-' else ''} (freed; held at {p.absent:.3g})"
                             for p in spec.params if p.optional and f"{e['name']}.{p.name}" in freed)
            # an effect accepted on the fit part alone (the validation part could not tell it apart) says so
            blind = any(c.accepted and c.name == e["name"] and c.judged_on == "fit" for c in self.candidates)
            where = ("; judged on the fit part: the validation part cannot tell it from the model without it "
                     "(e.g. an offset seen only in the transient from the declared start)") if blind else ""
            lines.append(f"{spec.description[0].upper()}{spec.description[1:]} {spec.location}: {main.name} = "
                         f"{v:.4g}{unit} (95 % CI {lo:.4g}–{hi:.4g}){shapes}{where}")
        lines += amb
        lines.append(f"{100 * self.unexplained:.2g} % of the nominal validation residual variance remains "
                     "unexplained.")
        return lines

    def to_frame(self) -> pd.DataFrame:
        """Before/after metrics per output on the held-out data."""
        rows = []
        for out, m in self.metrics_before.items():
            a = self.metrics_after[out]
            rows.append({"output": out, "rmse_before": m["rmse"], "rmse_after": a["rmse"], "nrmse_before": m["nrmse"],
                         "nrmse_after": a["nrmse"], "fit_before_%": m["fit_percent"], "fit_after_%": a["fit_percent"]})
        return pd.DataFrame(rows)

    def candidates_frame(self) -> pd.DataFrame:
        return pd.DataFrame([dataclasses.asdict(c) for c in self.candidates])

    def extended_model(self) -> dict[str, Any]:
        theta = self.final.theta()
        desc = getattr(self.adapter, "describe_model", None)
        return {"device": self.record.device, "params": desc(theta) if desc else theta, "effects": self.effects}

    def to_dict(self) -> dict[str, Any]:
        return {
            "record": self.record.path, "device": self.record.device, "experiment": self.record.experiment,
            "test": self.test_name, "statements": self.statements(), "effects": self.effects,
            "ambiguous": [a.to_dict() for a in self.ambiguous], "replay": self.replay_mode,
            "noise_floor_nrmse": self.noise_floor,
            "metrics": {"before": self.metrics_before, "after": self.metrics_after},
            "diagnostics": {"before": self.diagnostics_before, "after": self.diagnostics_after},
            "unexplained_fraction": self.unexplained,
            "nominal_params": self.nominal.theta(), "final_params": self.final.theta(),
            "candidates": [dataclasses.asdict(c) for c in self.candidates],
            "extended_model": self.extended_model(),
        }

    def to_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2, default=float) + "\n")

    def plot(self, out_dir: str | Path) -> list[Path]:
        """Measured vs nominal vs extended, and the residual before and after (held-out part)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        d = self.test_data
        names = list(self.metrics_before)
        files = []
        fig, axes = plt.subplots(2 * len(names), 1, figsize=(9, 3.2 * 2 * len(names)), sharex=True, squeeze=False)
        for j, name in enumerate(names):
            sig = self.record.outputs.get(name)
            unit = f" [{sig.unit}]" if sig is not None and sig.unit else ""
            ax = axes[2 * j, 0]
            ax.plot(d["t"], d["measured"][:, j], "k", lw=1, label="measured")
            ax.plot(d["t"], d["nominal"][:, j], "C0", lw=1, label="nominal")
            ax.plot(d["t"], d["extended"][:, j], "C3--", lw=1, label="extended")
            ax.set_ylabel(f"{name}{unit}")
            ax.legend(loc="best", fontsize=8)
            ax = axes[2 * j + 1, 0]
            ax.plot(d["t"], d["nominal"][:, j] - d["measured"][:, j], "C0", lw=0.8, label="residual before")
            ax.plot(d["t"], d["extended"][:, j] - d["measured"][:, j], "C3", lw=0.8, label="residual after")
            ax.set_ylabel(f"{name} residual{unit}")
            ax.legend(loc="best", fontsize=8)
        axes[-1, 0].set_xlabel("t [s]")
        fig.suptitle(f"{self.record.experiment}: held-out {self.test_name}")
        fig.tight_layout()
        f = out / "identification.png"
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(f)
        return files

    def report_markdown(self) -> str:
        lines = [f"# Identification of {self.record.experiment} ({self.record.device})", ""]
        lines += [f"- {s}" for s in self.statements()]
        lines += ["", f"Replay: {self.replay_mode}."]
        lines += ["", f"Held-out data: {self.test_name}.", "", self.to_frame().to_markdown(index=False, floatfmt=".4g")
                  if _has_tabulate() else self.to_frame().to_string(index=False), ""]
        lines += ["## Candidates", "", self.candidates_frame().drop(columns=["values"]).to_string(index=False)]
        return "\n".join(lines) + "\n"


def _has_tabulate() -> bool:
    try:
        import tabulate  # noqa: F401
    except ImportError:
        return False
    return True



def scored_result(record: Record, ad: Adapter, nominal: FittedModel, final: FittedModel, cands: list[Candidate],
                  masks: dict[str, np.ndarray], test_record: Record | None) -> IdentificationResult:
    """The result of an identification: ``nominal`` and ``final`` replayed once on the held-out data (the test
    record where one is given, else the record's test part, else its validation part) and scored there."""
    if test_record is not None:
        tad = ad.for_record(test_record)
        skip = int(test_record.meta.get("skip_samples", 0))
        tm = test_record.masks().get("test")
        if tm is None:
            tm = np.zeros(len(test_record), dtype=bool)
            tm[skip:] = True
        name = f"test record {Path(test_record.path).name} (samples {int(np.argmax(tm))}…{len(test_record) - 1})"
    elif "test" in masks:
        tad, tm = ad, masks["test"]
        name = "test part of the record"
    else:
        tad, tm = ad, masks["validation"]
        name = "validation part of the record (no test part given)"

    def sim(fm: FittedModel) -> np.ndarray:
        return tad.simulate({k: np.array([v]) for k, v in fm.theta().items()}, 1)[:, 0, :]

    y0, y1 = sim(nominal), sim(final)
    meas = tad.measured
    before, after, dbef, daft = {}, {}, {}, {}
    u = getattr(tad, "u", np.zeros(len(tad.t)))
    for j, s in enumerate(tad.outputs):
        before[s.column] = output_metrics(meas[tm, j], y0[tm, j])
        after[s.column] = output_metrics(meas[tm, j], y1[tm, j])
        dbef[s.column] = residual_tests(y0[tm, j] - meas[tm, j], u[tm])
        daft[s.column] = residual_tests(y1[tm, j] - meas[tm, j], u[tm])
    unexplained = (final.val_score / nominal.val_score) ** 2 if nominal.val_score > 0 else 0.0
    data = {"t": tad.t[tm], "measured": meas[tm], "nominal": y0[tm], "extended": y1[tm]}
    return IdentificationResult(record, ad, nominal, final, cands, before, after, dbef, daft, name, data,
                                float(unexplained))


__all__ = ["Candidate", "FittedModel", "IdentificationResult", "acf", "output_metrics", "residual_tests",
           "scored_result"]
