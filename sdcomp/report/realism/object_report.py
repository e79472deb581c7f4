"""The per-object part of the realism report (``sdcomp realism --objects``).

    from sdcomp.report.realism.object_report import objects_report
    result = objects_report("dataset/", "frames/", real_labels="frames.json")

Writes OUT/objects.md (per category, generated vs real side by side), OUT/objects.json and
OUT/object_crops.png (per category a row of generated and a row of real crops at one scale,
each box outlined). Statistics: :mod:`.objects`; a set: :mod:`.object_sets`. With real
frames also the object realism classifier (:mod:`.object_classifier`: per category, how well
a classifier tells a real object's crop from a generated one) and OUT/object_classifier.png,
the crops as it sees them.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import cv2
import numpy as np

from ...errors import UserError
from ...util.files import atomic_write_bytes
from . import object_classifier as oc
from . import object_crops
from .crops import Crop, crop_at_gsd, crop_window, montage
from .object_sets import ObjectTable, measure_objects
from .objects import MIN_SIZE, STATS, UNITS
from .report import MAX_IMAGES, jsonable
from .sources import FrameSet, frame_rgb, load_generated, load_real

OBJECT_FILES = ("objects.md", "objects.json", "object_crops.png")
#: written besides where real frames are given
CLASSIFIER_FILES = ("object_classifier.png",)
CROP_PX = 112  #: side of a crop, pixels
FILL = 0.4  #: the category's median box spans this share of a crop
OUTLINE_RGB = (255, 230, 0)


def objects_report(generated_dir, real=None, out_dir=None, real_labels=None,
                   real_gsd: float | None = None, real_fov: float | None = None,
                   max_images: int | None = MAX_IMAGES, seed: int = 0,
                   min_size: float = MIN_SIZE, n_crops: int = 6, folds: int = 5,
                   cnn: bool = True, log=None) -> dict:
    """Measure the labelled boxes of ``generated_dir`` and optionally of the real frames
    ``real`` (labelled by ``real_labels``, a COCO json file or YOLO labels folder), write the
    files of :data:`OBJECT_FILES` into ``out_dir`` (default ``generated_dir/realism``) and
    return the objects.json dict.

    Args:
        real_gsd: metres per pixel of every real frame; real_fov: their diagonal field of
            view as stored (degrees), which with a COCO file's ``meta`` (altitude, gimbal
            pitch) gives each box's GSD.
        max_images: at most this many images of each set (seeded random choice; None: all).
        min_size: boxes with sqrt(w h) below this many pixels are left out.
        n_crops: crops per category and set in object_crops.png.
        folds: cross-validation folds (by image) of the object classifier (with real
            frames); cnn: its CNN too (where torch imports), not only the logistic
            regression.
    UserError for bad folders, files or values, before anything is written."""
    if max_images is not None and max_images < 1:
        raise UserError(f"--max-images {max_images} is too small: use 1 or more")
    if not 2 <= folds <= 50:
        raise UserError(f"--folds {folds} is out of range: use 2 to 50")
    if not (math.isfinite(min_size) and min_size >= 1):
        raise UserError(f"--min-size {min_size} is out of range: use 1 pixel or more")
    if real is None and (real_labels is not None or real_gsd is not None
                         or real_fov is not None):
        raise UserError("--real-labels, --real-gsd and --real-fov need --real FRAMES")
    if real is not None and real_labels is None:
        raise UserError("--objects with --real needs --real-labels (a COCO json file or a YOLO "
                        "labels folder): the real objects are its boxes")
    say = log or (lambda msg: None)
    t0 = time.perf_counter()
    gen = load_generated(generated_dir, max_images, seed)
    real_set = (load_real(real, real_labels, real_gsd, real_fov, max_images, seed)
                if real is not None else None)
    out = Path(out_dir) if out_dir is not None else Path(generated_dir) / "realism"
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    say(f"objects: generated: {len(gen.frames)} images from {gen.folder}")
    gt = measure_objects(gen, min_size, say)
    rt = None
    if real_set is not None:
        say(f"objects: real: {len(real_set.frames)} frames from {real_set.folder}")
        rt = measure_objects(real_set, min_size, say)
        if rt.images_read == 0:
            raise UserError(f"--real {real}: none of its frames could be read")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot create it ({exc.strerror})") from None
    crops = crops_picture(out / "object_crops.png", (gen, gt),
                          (real_set, rt) if real_set is not None and rt is not None else None,
                          n_crops, seed)
    classifier = None
    if real_set is not None and rt is not None:
        gc = object_crops.collect_crops(gen, table_rows(gt), min_size=min_size, log=say)
        rc = object_crops.collect_crops(real_set, table_rows(rt), min_size=min_size, log=say)
        full = oc.classify_objects(gc, rc, folds, seed, cnn, log=say)
        oc.classifier_picture(out / "object_classifier.png", full, gc, rc, seed=seed)
        classifier = {"categories": oc.public(full), "crop_px": object_crops.CROP_PX,
                      "context": object_crops.CONTEXT,
                      "left_out": {"generated": gc.left_out, "real": rc.left_out},
                      "folds": folds}
    result = {
        "generated": gt.info(gen), "real": rt.info(real_set) if rt and real_set else None,
        "categories": {"generated": gt.summary(), "real": rt.summary() if rt else None},
        "crops": crops, "classifier": classifier, "settings": {
            "min_size_px": min_size, "max_images": max_images, "seed": seed,
            "real_gsd": real_gsd, "real_fov": real_fov, "folds": folds, "cnn": cnn},
        "seconds": round(time.perf_counter() - t0, 2)}
    atomic_write_bytes(out / "objects.json",
                       (json.dumps(jsonable(result), indent=1) + "\n").encode())
    atomic_write_bytes(out / "objects.md", objects_markdown(result).encode())
    say(f"wrote {out / 'objects.md'}")
    return result


def table_rows(t: ObjectTable) -> list[tuple[int, np.ndarray, str]]:
    """(frame index, box, category) of each measured box of a table."""
    return [(int(t.frames[i]), t.boxes[i], str(t.categories[i])) for i in range(len(t.boxes))]


# --------------------------------------------------------------------------- markdown

def fmt(stat: str, row: dict | None) -> str:
    """'median [p10, p90]' of one statistic's summary row; '-' when there is none."""
    if not row or not row.get("n"):
        return "-"
    digits = {"size_px": 0, "size_image_px": 0}.get(stat, 2)
    sign = "+" if stat == "contrast" else ""
    text = (f"{row['median']:{sign}.{digits}f} [{row['p10']:{sign}.{digits}f}, "
            f"{row['p90']:{sign}.{digits}f}]")
    if "nonzero" in row:
        text += f"; in {100 * row['nonzero']:.0f} % of boxes"
    return text


def objects_markdown(result: dict) -> str:
    """objects.md of an :func:`objects_report` result: the sets, then per category a table
    of the statistics, generated vs real (median [p10, p90])."""
    g, r = result["generated"], result["real"]
    gs, rs = result["categories"]["generated"], result["categories"]["real"]
    lines = ["# Object appearance (`sdcomp realism --objects`)", "",
             "Per labelled box with sqrt(w h) >= "
             f"{result['settings']['min_size_px']:g} px, against the water around it (the box "
             "grown by its longer side, minus every labelled box); median [p10, p90]. "
             "Definitions: docs/realism.md.", ""]
    for name, info in (("generated", g), ("real", r)):
        if info is None:
            continue
        lines.append(f"- {name}: {info['folder']}: {info['images_read']} images read "
                     f"({info['unreadable']} unreadable), {info['boxes']} boxes, "
                     f"{info['measured']} measured, size in metres known for "
                     f"{info['size_m_known']}")
        lines += [f"  - {n}" for n in info["notes"]]
    if r is None:
        lines.append("- real: none given (`--real FRAMES --real-labels LABELS`)")
    cats = sorted(set(gs) | set(rs or {}))
    if not cats:
        lines += ["", "No box was large enough to measure."]
    for cat in cats:
        a, b = gs.get(cat), (rs or {}).get(cat)
        lines += ["", f"## {cat}", "",
                  f"| per box | unit | generated ({a['count'] if a else 0}) |"
                  + (f" real ({b['count'] if b else 0}) |" if rs is not None else ""),
                  "|---|---|---|" + ("---|" if rs is not None else "")]
        for stat in STATS:
            row = f"| {stat} | {UNITS[stat]} | {fmt(stat, a[stat] if a else None)} |"
            if rs is not None:
                row += f" {fmt(stat, b[stat] if b else None)} |"
            lines.append(row)
    lines += classifier_markdown(result.get("classifier"))
    crops = result.get("crops") or {}
    lines += ["", f"Crops: object_crops.png ({crops.get('note', '')}).", ""]
    return "\n".join(lines)


def classifier_markdown(c: dict | None) -> list[str]:
    """The object classifier's section of objects.md (nothing without real frames)."""
    if not c:
        return []
    lines = ["", "## Object realism classifier", "",
             f"Per category, real vs generated crops (each whole box and its water: a window "
             f"{c['context']:g} times the box's longer side, resampled to {c['crop_px']} px), "
             f"cross-validated by image ({c['folds']} folds, the larger set subsampled to "
             "the smaller's count). Accuracy (95 % bootstrap interval over images): 0.5 = "
             "indistinguishable, 1.0 = always told apart. Crops: object_classifier.png.", "",
             "| category | crops generated | crops real | CNN | logistic (hand features) |"
             " features that tell them apart (logistic; + = higher in real) |",
             "|---|---|---|---|---|---|"]
    for cat, e in c["categories"].items():
        if "error" in e:
            lines.append(f"| {cat} | {e['generated']} | {e['real']} | - | - | {e['error']} |")
            continue
        lr = e.get("logistic") or {}
        top = ", ".join(f"{n} {w:+.1f}" for n, w in (lr.get("top_features") or [])[:5])
        lines.append(f"| {cat} | {e['generated']} | {e['real']} | "
                     f"{oc.accuracy_text(e.get('cnn'))} | {oc.accuracy_text(lr)} | {top} |")
    for kind in ("generated", "real"):
        left = c["left_out"].get(kind) or {}
        if left:
            lines.append(f"- {kind}: not cropped: " + ", ".join(
                f"{v} {k}" for k, v in sorted(left.items())))
    return lines


# --------------------------------------------------------------------------- crops

def crops_picture(path: Path, generated: tuple[FrameSet, ObjectTable],
                  real: tuple[FrameSet, ObjectTable] | None, n: int = 6,
                  seed: int = 0, out_px: int = CROP_PX) -> dict:
    """Write object_crops.png: per category a row of up to ``n`` generated crops and one of
    real crops (random boxes, seeded), both at one scale: the same metres per pixel when
    every chosen box's GSD is known (the category's median size in metres spans
    :data:`FILL` of a crop), else the same enlargement of image pixels. Returns
    {"note", "scales": {category: {"m_per_px" or "px_per_image_px": value}}}."""
    sets = [("generated", *generated)] + ([("real", *real)] if real is not None else [])
    cats = sorted({c for _, _, t in sets for c in t.categories})
    rng = np.random.default_rng(seed)
    rows: list[tuple[str, list[Crop]]] = []
    scales: dict[str, dict] = {}
    for cat in cats:
        picks = [(kind, fs, t, _pick(t, cat, n, rng)) for kind, fs, t in sets]
        chosen = [(t, i) for _, _, t, rows_ in picks for i in rows_]
        sizes = np.array([math.sqrt(t.boxes[i, 2] * t.boxes[i, 3]) for t, i in chosen])
        gsd = np.array([t.gsd[i] for t, i in chosen])
        metric = bool(chosen) and bool(np.isfinite(gsd).all())
        target, zoom, label = None, None, ""
        if metric:
            target = float(np.median(sizes * gsd)) / (FILL * out_px)
            scales[cat] = {"m_per_px": target}
            label = f"{target * 100:.1f} cm/px"
        elif chosen:
            zoom = FILL * out_px / float(np.median(sizes))
            scales[cat] = {"px_per_image_px": zoom}
            label = f"x{zoom:.2f} image px (GSD unknown)"
        for kind, fs, t, idx in picks:
            crops = [_crop(fs, t, i, target, zoom, out_px) for i in idx]
            rows.append((f"{cat}: {kind}" + (f", {label}" if idx else ""),
                         [c for c in crops if c is not None]))
    note = ("per category one scale: metres per pixel where every box's GSD is known, "
            "else the same enlargement of image pixels; boxes outlined")
    img = montage(rows, "sdcomp realism --objects: " + note, n, out_px) if rows else (
        np.full((40, 400, 3), 25, np.uint8))
    cv2.imwrite(str(path), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    return {"note": note, "scales": scales}


def _pick(table: ObjectTable, cat: str, n: int, rng: np.random.Generator) -> list[int]:
    """Up to ``n`` rows of ``cat``, random, from distinct frames first."""
    rows = [i for i, c in enumerate(table.categories) if c == cat]
    first: list[int] = []
    rest: list[int] = []
    seen: set[int] = set()
    for j in rng.permutation(len(rows)):
        i = rows[int(j)]
        frame = int(table.frames[i])
        (rest if frame in seen else first).append(i)
        seen.add(frame)
    return (first + rest)[:n]


def _crop(fs: FrameSet, t: ObjectTable, i: int, m_per_px: float | None, zoom: float | None,
          out_px: int) -> Crop | None:
    """The crop of row ``i``, the box outlined: at ``m_per_px`` (metric) or ``zoom`` output
    pixels per image pixel."""
    rgb = frame_rgb(fs.frames[int(t.frames[i])])
    if rgb is None:
        return None
    x, y, w, h = (float(v) for v in t.boxes[i])
    src, dst = (float(t.gsd[i]), m_per_px) if m_per_px else (1.0, 1.0 / (zoom or 1.0))
    centre = (x + w / 2, y + h / 2)
    img, _ = crop_at_gsd(rgb, centre, src, dst, out_px)
    x0, y0, side, _ = crop_window(centre, src, dst, out_px)
    k = out_px / side
    img = np.ascontiguousarray(img)
    p0 = (int(round((x - x0) * k)) - 1, int(round((y - y0) * k)) - 1)
    p1 = (int(round((x + w - x0) * k)), int(round((y + h - y0) * k)))
    cv2.rectangle(img, p0, p1, OUTLINE_RGB, 1)
    size = math.sqrt(w * h)
    cap = (f"{size * t.gsd[i]:.1f}m" if math.isfinite(t.gsd[i]) else f"{size:.0f}px")
    return Crop(img, cap, True)
