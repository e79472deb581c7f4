"""The realism report of a generated dataset, optionally against real drone frames.

    from sdcomp.report.realism import realism_report
    result = realism_report("dataset/", "frames/", "out/", real_labels="frames.json")

Writes OUT/report.md and OUT/report.json, plus OUT/spectrum.png (radially averaged luminance
power spectra), OUT/histograms.png (the four per-patch metrics, generated vs real) and
OUT/crops.png (object and empty-water crops at one ground sampling distance). Without real
frames: the generated set's statistics against the targets only (no classifier).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from ...errors import UserError
from ...util.files import atomic_write_bytes
from . import classifier as clf
from .analysis import SetAnalysis, analyse_set, plot_histograms
from .crops import crops_figure, median_gsd
from .markdown import render_markdown
from .sources import load_generated, load_real
from .spectrum import SpectrumAccumulator, metre_edges, plot_spectra
from .targets import REAL_REFERENCE, SDCOMP_ISSUE, evaluate_targets

FILES = ("report.md", "report.json", "spectrum.png", "histograms.png", "crops.png")
MAX_IMAGES = 500  #: images of each set measured by default (a seeded random choice)


def realism_report(generated_dir, real=None, out_dir=None, real_labels=None,
                   real_gsd: float | None = None, real_fov: float | None = None,
                   max_images: int | None = MAX_IMAGES, seed: int = 0, folds: int = 5,
                   cnn: bool = False, exclude_clutter: bool = False, match_gsd: bool = False,
                   log=None) -> dict:
    """Measure ``generated_dir`` (a generated dataset folder) and optionally ``real`` (a
    folder or file of real photos and videos), write the files of :data:`FILES` into
    ``out_dir`` (default ``generated_dir/realism``) and return the report.json dict.

    Args:
        real_labels: COCO json file or YOLO labels folder of the real frames: boxes kept out
            of empty water; a COCO file's ``meta`` (altitude, gimbal pitch) gives the GSD.
        real_gsd: metres per pixel of every real frame; real_fov: their diagonal field of
            view as stored (degrees), which with the COCO meta gives each frame's GSD.
        max_images: at most this many images of each set (seeded random choice; None: all).
        folds: cross-validation folds (split by image).
        cnn: also the tiny CNN classifier (needs torch).
        exclude_clutter: also keep sdcomp's unannotated clutter out of empty water.
        match_gsd: resample real frames of known GSD to the generated median GSD first.
    UserError for bad folders, files or values, before anything is written."""
    if max_images is not None and max_images < 2:
        raise UserError(f"--max-images {max_images} is too small: use 2 or more")
    if folds < 2:
        raise UserError(f"--folds {folds} is too small: use 2 or more")
    if real is None and (real_labels is not None or real_gsd is not None
                         or real_fov is not None):
        raise UserError("--real-labels, --real-gsd and --real-fov need --real FRAMES")
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    gen = load_generated(generated_dir, max_images, seed, exclude_clutter)
    real_set = None
    if real is not None:
        real_set = load_real(real, real_labels, real_gsd, real_fov, max_images, seed)
    out = Path(out_dir) if out_dir is not None else Path(generated_dir) / "realism"
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    say(f"generated: {len(gen.frames)} images from {gen.folder}")
    ga = analyse_set(gen, seed, cnn, log=say)
    if ga.images_read == 0:
        raise UserError(f"none of the images of {str(gen.folder)!r} could be read")
    ra = None
    if real_set is not None:
        say(f"real: {len(real_set.frames)} frames from {real_set.folder}")
        target = median_gsd(gen) if match_gsd else None
        ra = analyse_set(real_set, seed + 1, cnn, rescale_to=target, log=say)
        if ra.images_read == 0:
            raise UserError(f"--real {real}: none of its frames could be read")
    gs = ga.summary()
    rs = ra.summary() if ra is not None else None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot create it ({exc.strerror})") from None
    plot_spectra(out / "spectrum.png", ga.spectrum, ra.spectrum if ra else None)
    plot_histograms(out / "histograms.png", ga, ra)
    crops = crops_figure(out / "crops.png", gen, real_set, seed=seed)
    result: dict = {
        "generated": _set_info(ga), "real": _set_info(ra) if ra else None,
        "summary": {"generated": gs, "real": rs},
        "reference": {"real_issue": REAL_REFERENCE, "sdcomp_issue": SDCOMP_ISSUE},
        "targets": evaluate_targets(gs, rs), "crops": crops, "settings": {
            "max_images": max_images, "seed": seed, "folds": folds, "cnn": cnn,
            "exclude_clutter": exclude_clutter, "match_gsd": match_gsd,
            "real_gsd": real_gsd, "real_fov": real_fov},
        "classifier": None, "cnn": None,
    }
    edges = metre_edges(*[a.spectrum for a in (ga, ra) if a is not None])
    result["spectrum"] = {"generated": _spectrum_json(ga.spectrum, edges),
                          "real": _spectrum_json(ra.spectrum, edges) if ra else None}
    if ra is not None:
        result["classifier"], result["cnn"] = _classify(ga, ra, folds, seed, cnn, say)
    result["seconds"] = round(time.perf_counter() - t0, 2)
    atomic_write_bytes(out / "report.json",
                       (json.dumps(jsonable(result), indent=1) + "\n").encode())
    atomic_write_bytes(out / "report.md", render_markdown(result).encode())
    say(f"wrote {out / 'report.md'}")
    return result


def _classify(ga: SetAnalysis, ra: SetAnalysis, folds: int, seed: int, cnn: bool, say):
    """(logistic CV dict or {"error": why}, the CNN's (:func:`_cnn`) or None); class 1 is
    real."""
    x = np.concatenate([ga.features, ra.features])
    y = np.concatenate([np.zeros(len(ga.features), np.int64),
                        np.ones(len(ra.features), np.int64)])
    groups = np.concatenate([ga.groups, ra.groups + 10 ** 7])
    try:
        say("classifier: logistic regression, cross-validated by image")
        lr = clf.cross_validate(x, y, groups, folds, seed=seed).to_dict()
    except ValueError as exc:
        lr = {"error": str(exc)}
    return lr, (_cnn(ga, ra, folds, seed, say) if cnn else None)


def _cnn(ga: SetAnalysis, ra: SetAnalysis, folds: int, seed: int, say) -> dict:
    """The tiny CNN's cross-validated result dict, or {"error": why not}."""
    if not clf.torch_available():
        return {"error": "torch is not importable"}
    if ga.patches is None or ra.patches is None or ga.patch_groups is None or \
            ra.patch_groups is None:
        return {"error": "no patches"}
    say("classifier: tiny CNN, cross-validated by image")
    y = np.concatenate([np.zeros(len(ga.patches), np.int64), np.ones(len(ra.patches),
                                                                     np.int64)])
    groups = np.concatenate([ga.patch_groups, ra.patch_groups + 10 ** 7])
    try:
        return clf.cross_validate_cnn(np.concatenate([ga.patches, ra.patches]), y, groups,
                                      folds, seed=seed).to_dict()
    except ValueError as exc:
        return {"error": str(exc)}


def _set_info(a: SetAnalysis) -> dict:
    f = a.frames
    g = [fr.gsd for fr in f.frames if fr.gsd]
    return {
        "folder": str(f.folder), "kind": f.kind, "images": len(f.frames),
        "images_read": a.images_read, "unreadable": a.unreadable,
        "patches": a.patches_total, "empty_water_patches": a.patches_empty,
        "classifier_patches": int(len(a.groups)),
        "gsd_m_per_px": ({"known": len(g), "min": min(g), "median": float(np.median(g)),
                          "max": max(g)} if g else {"known": 0}),
        "rescaled_to_match_gsd": a.rescaled,
        "valid_pixels": dict(a.valid_how), "notes": list(f.notes),
        "seconds": round(a.seconds, 2),
        "ms_per_image": round(1000 * a.seconds / max(a.images_read, 1), 1),
    }


def _spectrum_json(acc: SpectrumAccumulator, edges) -> dict:
    px = acc.per_pixel()
    out = {"cycles_per_px": px.centres.tolist(), "power_px": px.power.tolist()}
    pm = acc.per_metre(edges) if edges is not None else None
    if pm is not None:
        out |= {"cycles_per_m": pm.centres.tolist(), "power_m": pm.power.tolist()}
    return out


def jsonable(o):
    """``o`` with NumPy scalars as Python numbers and non-finite floats as None (JSON)."""
    if isinstance(o, dict):
        return {str(k): jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, (np.floating, float)):
        return float(o) if math.isfinite(float(o)) else None
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    return o
