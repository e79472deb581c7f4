"""The report of ``sdcomp fit``: the footage's statistics beside the fitted config's and the
defaults' (markdown and JSON), the settings chosen, and a picture of crops of each at the
working size (one scale)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..render.camera.grade import SiteGrade
from ..report.realism.crops import Crop, montage
from ..scene.config import GeneratorConfig
from ..util.files import atomic_write_bytes, write_png
from .api import FitResult
from .config_file import KEYS
from .search import TYPE_SHARE
from .stats import EXTRA, SCALES, STATS, UNITS, distance

CROP_PX = 128  #: side of the report picture's crops, pixels of the working size


def comparison(result: FitResult) -> list[dict]:
    """Per statistic (:data:`STATS`, then :data:`EXTRA`): the footage's, fitted and default
    (p10, p50, p90), the distances to the footage (units of :data:`SCALES`) and whether the
    fitted one is the closer."""
    foot, fit, dflt = result.footage.summary, result.search.summary, result.search.default_summary
    graded = result.graded[0] if result.graded is not None else None
    d_fit, d_dflt = distance(fit, foot), distance(dflt, foot)
    d_graded = distance(graded, foot) if graded is not None else None
    rows = []
    for k in (*STATS, *EXTRA):
        row = {"statistic": k, "unit": UNITS[k], "footage": foot[k], "fitted": fit[k],
               "default": dflt[k]}
        if graded is not None:
            row["graded"] = graded[k]
        if k in SCALES:
            row |= {"fitted_distance": d_fit[k], "default_distance": d_dflt[k],
                    "closer": bool(d_fit[k] <= d_dflt[k]) if math.isfinite(
                        d_fit[k] + d_dflt[k]) else None}
            if d_graded is not None:
                row["graded_distance"] = d_graded[k]
        rows.append(row)
    return rows


def _triple(v) -> str:
    if not all(math.isfinite(x) for x in v):
        return "n/a"
    return f"{v[1]:.4g} ({v[0]:.3g}-{v[2]:.3g})"


def markdown(result: FitResult, config_path: str, picture: str | None) -> str:
    """The report as markdown text."""
    f, s = result.footage, result.search
    rows = comparison(result)
    graded = result.graded is not None
    lines = ["# sdcomp fit", "",
             f"{f.frames} frames measured at {f.width} x {f.height} px; {s.seconds:.0f} s of "
             f"search ({len(s.trials)} candidates, {s.per_image['luminance'].size} rendered "
             f"frames each). Config: `{config_path}` (`sdcomp generate --config "
             f"{config_path} --out DIR`).", "", f"- {result.geometry}",
             *(f"- {n}" for n in f.notes), "",
             "## Statistics: footage, fitted, defaults", "",
             "Median over frames (10th-90th percentile); \"defaults\" are the generator's "
             "defaults at the footage's frame size and geometry; distance to the footage in "
             "units of the fit's scale (median difference + a quarter of the p10 and p90 "
             "differences); definitions in docs/fit.md.", "",
             "| statistic | unit | footage | fitted | defaults | distance fitted | "
             "distance defaults | closer |" + (" graded | distance graded |" if graded else ""),
             "|---|---|---|---|---|---|---|---|" + ("---|---|" if graded else "")]
    for r in rows:
        dist = (f"{r['fitted_distance']:.2f} | {r['default_distance']:.2f} | "
                f"{_closer(r['closer'])}" if "closer" in r else "- | - | report only")
        if graded:
            dist += f" | {_triple(r['graded'])} | " + (
                f"{r['graded_distance']:.2f}" if "graded_distance" in r else "-")
        lines.append(f"| {r['statistic']} | {r['unit']} | {_triple(r['footage'])} | "
                     f"{_triple(r['fitted'])} | {_triple(r['default'])} | {dist} |")
    if graded:
        gf = result.grade_fit
        lines += ["", f"Graded: the fitted config with its site grade (`grade` in the config, "
                  f"the camera's last stage, {grade_text(result.grade)}), chosen on "
                  f"{len(f.patches)} water patches of the footage by the realism classifier "
                  f"(its cross-validated accuracy telling them from the generated water's, "
                  f"0.5: indistinguishable): {gf.before:.3f} for the fitted scene, "
                  f"{gf.after:.3f} graded. The distances are to the footage as above."
                  if gf is not None and result.grade is not None else ""]
    missed = [r["statistic"] for r in rows if r.get("closer") is False]
    far = [r["statistic"] for r in rows if r.get("fitted_distance", 0) > 2]
    lines += ["", _reach_text(missed, far), "", "## Settings", "",
              "| setting | fitted | default |", "|---|---|---|"]
    default = GeneratorConfig()
    for key, _ in KEYS:
        lines.append(f"| {key} | {_value(result.config, key)} | {_value(default, key)} |")
    lines += ["", water_line(s.water_votes, result.config.water), ""]
    if s.cast is not None:
        c = s.cast
        lines += [f"The footage's highlights carry a colour cast: the search ran again from "
                  f"white balance red {c['wb_red']:g}, blue {c['wb_blue']:g} (loss "
                  f"{c['loss_cast']:.3g}, against {c['loss_defaults']:.3g} from the "
                  f"defaults' camera); the fit from "
                  f"{'the cast' if c['kept'] == 'cast' else 'the defaults'} is kept.", ""]
    if picture:
        names = "footage, fitted, graded, defaults" if graded else "footage, fitted, defaults"
        lines += ["## Crops", "", f"![{names}]({picture})", "",
                  f"Rows: {names}; {CROP_PX} px crops at the working size."]
    return "\n".join(lines) + "\n"


def grade_text(grade: SiteGrade) -> str:
    """A clause on what a grade does."""
    if grade.identity:
        return "none: no grade tried did better"
    m = grade.matrix
    return (f"colour x -> M x + b, M = {np.round(m, 3).tolist()}, b = "
            f"{np.round(grade.offset, 1).tolist()}; luma spectrum gains "
            f"{', '.join(f'{g:.2f}' for g in grade.spectrum)} from coarse to fine; chroma "
            f"detail x {grade.chroma:.2f}")


def _closer(ok: bool | None) -> str:
    return "n/a" if ok is None else ("yes" if ok else "**no**")


def _reach_text(missed: list[str], far: list[str]) -> str:
    """One paragraph on the statistics the fit did not reach."""
    parts = []
    if missed:
        parts.append(f"Not reached (the defaults are as close or closer): {', '.join(missed)}; "
                     "no candidate setting moves them nearer the footage without moving "
                     "others further (the fit minimises the sum).")
    if far:
        parts.append(f"Still more than 2 units off: {', '.join(far)} (the generator's "
                     f"settings cannot match the footage there, or the footage has too few "
                     f"frames to tell).")
    return " ".join(parts) or "Every statistic is at least as close as the defaults'."


def _value(config: GeneratorConfig, key: str) -> str:
    v = config.to_dict()[key]
    if v is None:
        return "unset (the look's draws)"
    return ", ".join(map(str, v)) if isinstance(v, list) else str(v)


def picture(result: FitResult) -> np.ndarray:
    """(H, W, 3) uint8 RGB: rows of up to 4 centre crops of the footage, the fitted config's,
    the graded ones (where a grade was fitted) and the defaults' frames, all at the working
    size."""
    rows = [("footage", result.footage.crops), ("fitted", result.search.frames),
            *([("graded", result.graded[1])] if result.graded is not None else []),
            ("defaults", result.search.default_frames)]
    side = min(CROP_PX, result.footage.width, result.footage.height)
    out = [(name, [Crop(_centre(a, side), f"{a.shape[1]}x{a.shape[0]}", True) for a in imgs])
           for name, imgs in rows]
    names = ", ".join(n for n, _ in rows)
    return montage(out, f"sdcomp fit: {names} (one scale)", 4, side)


def _centre(rgb: np.ndarray, side: int) -> np.ndarray:
    h, w = rgb.shape[:2]
    y, x = (h - side) // 2, (w - side) // 2
    return np.ascontiguousarray(rgb[y:y + side, x:x + side])


def write_report(result: FitResult, folder: str | Path, config_path: str) -> Path:
    """Write ``fit_report.md``, ``fit_report.json`` and ``fit_crops.png`` into ``folder``;
    returns the markdown's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_png(picture(result), folder / "fit_crops.png")
    md = folder / "fit_report.md"
    atomic_write_bytes(md, markdown(result, config_path, "fit_crops.png").encode())
    data = {"frames": result.footage.frames, "size": [result.footage.width,
                                                       result.footage.height],
            "geometry": result.geometry, "seconds": result.search.seconds,
            "statistics": comparison(result), "config": result.config.to_dict(),
            "water_votes": result.search.water_votes, "cast_search": result.search.cast,
            "grade": None if result.grade is None else json.loads(result.grade.to_json()),
            "grade_search": None if result.grade_fit is None else {
                "accuracy_fitted": result.grade_fit.before,
                "accuracy_graded": result.grade_fit.after,
                "trials": result.grade_fit.trials},
            "trials": [{"group": t.group, "settings": t.settings, "loss": t.loss}
                       for t in result.search.trials]}
    atomic_write_bytes(folder / "fit_report.json",
                       json.dumps(data, indent=1, default=_json).encode())
    return md


def _json(o):
    if isinstance(o, tuple):
        return list(o)
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def water_line(votes: dict[str, int], water: tuple[str, ...]) -> str:
    """The report's Water line: how many frames were nearest each type's colour in the last
    inversion and, where the config's water is not what that inversion chose, why (the fit
    keeps a water the inversion does not beat under the fitted camera and light)."""
    line = f"Water: frames nearest each type's colour (the last inversion): {votes}."
    total = sum(votes.values())
    chosen = {n for n, v in votes.items() if v >= TYPE_SHARE * total} or (
        {max(votes, key=lambda n: votes[n])} if votes else set())
    if votes and chosen != set(water):
        line += (f" That inversion chose {', '.join(sorted(chosen))}, but the config keeps "
                 f"{', '.join(water)}: rendered under the fitted camera and light, the "
                 f"inversion's water was no closer to the footage's statistics.")
    return line
