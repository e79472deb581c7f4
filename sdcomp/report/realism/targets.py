"""The reference figures and targets of docs/realism.md, and the PASS/FAIL check.

Figures are per-patch statistics over empty-water 64 x 64 patches: median, 10th and 90th
percentiles (see :mod:`.patches`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

from .patches import METRICS

#: real SeaDronesSee-like frames as measured for the reference (at matched GSD)
REAL_REFERENCE: dict[str, dict[str, float]] = {
    "saturation": {"median": 0.18, "p10": 0.04, "p90": 0.32},
    "luminance": {"median": 121.0},
    "highpass_std": {"median": 6.2, "p10": 2.1, "p90": 26.2},
    "glint_fraction": {"median": 0.003, "p10": 0.0, "p90": 0.18},
}
#: sdcomp (brown, blue, green water) as measured for the reference
SDCOMP_ISSUE: dict[str, dict[str, float]] = {
    "saturation": {"median": 0.41, "p10": 0.16, "p90": 0.65},
    "luminance": {"median": 90.0},
    "highpass_std": {"median": 13.7, "p10": 7.6, "p90": 23.2},
    "glint_fraction": {"median": 0.007, "p10": 0.0, "p90": 0.05},
}
#: target ranges of the medians (inclusive), default settings at 416 px, 10-50 m
MEDIAN_TARGETS: dict[str, tuple[float, float]] = {
    "saturation": (0.10, 0.25),
    "luminance": (100.0, 150.0),
    "highpass_std": (4.0, 8.0),
}
HIGHPASS_P90_MIN = 15.0  #: the 90th percentile of highpass_std must exceed this


def spread(row: Mapping[str, float]) -> float:
    """p90 - p10 of a summary row (NaN when either is missing)."""
    try:
        return float(row["p90"]) - float(row["p10"])
    except (KeyError, TypeError, ValueError):
        return float("nan")


def _fmt(v: float) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{v:.4g}"


def evaluate_targets(generated: Mapping[str, Mapping[str, float]],
                     real: Mapping[str, Mapping[str, float]] | None = None) -> list[dict]:
    """The targets checked on the generated set's summary (:func:`.patches.summarise`).

    Returns one dict per target: ``target`` (text), ``value`` (the measured number), ``ok``
    (True / False; None when it cannot be judged, e.g. no reference spread). Spread targets
    compare with the measured real spread when ``real`` is given, else with
    :data:`REAL_REFERENCE` (no luminance spread there)."""
    out = []
    for m, (lo, hi) in MEDIAN_TARGETS.items():
        v = float(generated[m]["median"])
        out.append({"target": f"median {m} in [{lo:g}, {hi:g}]", "metric": m, "value": v,
                    "ok": (lo <= v <= hi) if math.isfinite(v) else False})
    v = float(generated["highpass_std"]["p90"])
    out.append({"target": f"p90 highpass_std > {HIGHPASS_P90_MIN:g}", "metric": "highpass_std",
                "value": v, "ok": v > HIGHPASS_P90_MIN if math.isfinite(v) else False})
    for m in METRICS:
        ref_src = "measured real" if real is not None else "reference real"
        ref = spread(real[m]) if real is not None else spread(REAL_REFERENCE[m])
        v = spread(generated[m])
        ok = None if not math.isfinite(ref) else (v >= ref if math.isfinite(v) else False)
        out.append({"target": f"{m} p10-p90 spread >= {ref_src} ({_fmt(ref)})", "metric": m,
                    "value": v, "reference": ref, "ok": ok})
    return out


def verdict(ok: bool | None) -> str:
    """"PASS", "FAIL" or "n/a" (cannot be judged)."""
    return "n/a" if ok is None else ("PASS" if ok else "FAIL")
