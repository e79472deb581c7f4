"""Statistics of a generated dataset: a table on stdout and a PNG figure.

Reads the folder that ``sdcomp generate`` wrote (the COCO files, or the run's journal
``records.jsonl`` when the run wrote YOLO labels only) and reports:

- images, images with no objects, objects per category and ignore regions (COCO
  ``iscrowd`` entries: visible objects too small to label), per split;
- object sizes in pixels (COCO ``area``, the mask's pixel count) against the COCO bounds:
  small < 32^2, medium 32^2 to 96^2, large >= 96^2 pixels;
- histograms of the per-image metadata: altitude (m), gimbal pitch (degrees below the
  horizon), turbidity (0-1) and water colour.

The command line is ``sdcomp stats`` (:mod:`sdcomp.cli.stats`). Python::

    from sdcomp.report.stats import dataset_stats, format_table, plot_stats
    s = dataset_stats("dataset/")          # plain dict (JSON-able)
    print(format_table(s)); plot_stats(s, "stats.png")
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..io.layout import SPLITS, DatasetLayout, journal_dataset, load_dataset
from ..util.files import atomic_write_bytes

#: COCO size classes by area in pixels: small < 32^2 <= medium < 96^2 <= large
SIZE_BOUNDS = (32 ** 2, 96 ** 2)
SIZE_NAMES = ("small", "medium", "large")
#: (metadata key, label, unit) of the numeric histograms
META_HISTOGRAMS = (("height_above_takeoff(meter)", "altitude", "m"),
                   ("gimbal_pitch(degrees)", "pitch", "degrees"),
                   ("turbidity", "turbidity", "0-1"))
WATER_KEY = "water_color"


def _entries(folder: Path) -> tuple[list[tuple[str, dict, list, list]], dict[int, str]]:
    """(split, image, annotations, ignore regions) of every image, and the category names
    by id: from the COCO files, or from the journal where there are none."""
    layout = DatasetLayout(folder)
    if any(layout.coco_file(s).is_file() for s in SPLITS):
        ds = load_dataset(folder, "all")
    else:
        if not folder.is_dir() or not layout.journal.is_file():
            raise UserError(f"{str(folder)!r} is not a generated dataset (no COCO files, no "
                            f"records.jsonl): give the --out folder of `sdcomp generate`")
        ds = journal_dataset(folder)
    return ([(e.split, e.image, e.annotations, e.ignore) for e in ds.entries],
            dict(ds.categories))


def _histogram(values: Sequence[float], bins: int) -> dict:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], np.float64)
    if v.size == 0:
        return {"n": 0, "min": None, "max": None, "mean": None, "edges": [], "counts": []}
    lo, hi = float(v.min()), float(v.max())
    if hi == lo:
        lo, hi = lo - 0.5, hi + 0.5
    counts, edges = np.histogram(v, bins=bins, range=(lo, hi))
    return {"n": int(v.size), "min": float(v.min()), "max": float(v.max()),
            "mean": float(v.mean()), "edges": [float(e) for e in edges],
            "counts": [int(c) for c in counts]}


def size_class(area: float) -> str:
    """``"small"``, ``"medium"`` or ``"large"`` of an area in pixels (COCO's bounds)."""
    return SIZE_NAMES[int(np.searchsorted(SIZE_BOUNDS, area, side="right"))]


def dataset_stats(folder: str | Path, bins: int = 10) -> dict:
    """The statistics of the dataset in ``folder`` as a JSON-able dict::

        {"folder", "categories": {id: name},
         "splits": {split: {"images", "empty_images", "objects": {name: n},
                            "ignore_regions"}},
         "sizes": {name: {"small", "medium", "large", "sqrt_area_px": [...]}},
         "meta": {label: histogram}, "water": {colour: images}}

    where a histogram is ``{"n", "min", "max", "mean", "edges", "counts"}`` (``bins`` bins).
    """
    if isinstance(bins, bool) or not isinstance(bins, int) or not 1 <= bins <= 1000:
        raise UserError(f"--bins {bins!r} is out of range: use 1 to 1000")
    folder = Path(folder)
    entries, names = _entries(folder)
    if not entries:
        raise UserError(f"{str(folder)!r} has no images yet: finish the run with "
                        f"`sdcomp generate ... --resume`")
    cat_name = {**names}
    splits: dict[str, dict] = {}
    sizes: dict[str, dict] = {}
    roots: list[float] = []
    meta_values: dict[str, list[float]] = {label: [] for _, label, _ in META_HISTOGRAMS}
    water: dict[str, int] = {}
    for split, image, anns, ignore in entries:
        s = splits.setdefault(split, {"images": 0, "empty_images": 0, "objects": {},
                                      "ignore_regions": 0})
        s["images"] += 1
        s["ignore_regions"] += len(ignore)
        s["empty_images"] += not anns
        _count_objects(anns, cat_name, s["objects"], sizes, roots)
        _count_meta(image.get("meta") or {}, meta_values, water)
    for name in sizes:
        sizes[name] = dict(sizes[name])
    return {
        "folder": str(folder),
        "categories": {int(k): v for k, v in sorted(cat_name.items())},
        "splits": {s: splits[s] for s in sorted(splits, key=lambda s: (s not in SPLITS, s))},
        "sizes": sizes,
        "object_size": _histogram(roots, bins),
        "meta": {label: _histogram(meta_values[label], bins) for _, label, _ in
                 META_HISTOGRAMS},
        "water": dict(sorted(water.items(), key=lambda kv: -kv[1])),
    }


def _count_objects(anns: list, cat_name: dict[int, str], objects: dict[str, int],
                   sizes: dict[str, dict], roots: list[float]) -> None:
    """Count one image's COCO annotations ``anns`` (in place): per category name in
    ``objects`` (its split's counts) and per size class in ``sizes`` ({name: {"small",
    "medium", "large"}}), and append each object's sqrt(area) in pixels to ``roots``.
    ``cat_name``: names by category id; an id without one gets its number as name (added)."""
    for a in anns:
        name = cat_name.setdefault(int(a["category_id"]), str(a["category_id"]))
        objects[name] = objects.get(name, 0) + 1
        area = float(a["area"])
        z = sizes.setdefault(name, {"small": 0, "medium": 0, "large": 0})
        z[size_class(area)] += 1
        roots.append(math.sqrt(area))


def _count_meta(meta: dict, meta_values: dict[str, list[float]], water: dict[str, int]
                ) -> None:
    """Add one image's metadata (in place): the numbers of :data:`META_HISTOGRAMS` to
    ``meta_values`` (by label; values that are not numbers are left out) and its water
    colour, if it has one, to the image counts ``water``."""
    for key, label, _ in META_HISTOGRAMS:
        v = meta.get(key)
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            meta_values[label].append(float(v))
    colour = meta.get(WATER_KEY)
    if colour is not None:
        water[str(colour)] = water.get(str(colour), 0) + 1


# --------------------------------------------------------------------------- table

def _row(cells: Iterable, widths: Sequence[int]) -> str:
    cells = list(cells)
    return "  ".join([str(cells[0]).ljust(widths[0])] +
                     [str(c).rjust(w) for c, w in zip(cells[1:], widths[1:], strict=True)])


def _hist_line(h: dict, unit: str) -> str:
    if not h["n"]:
        return "no values"
    bars = " ".join(f"{lo:g}-{hi:g}:{c}" for lo, hi, c in
                    zip(_round(h["edges"][:-1]), _round(h["edges"][1:]), h["counts"],
                        strict=True) if c)  # empty bins left out
    return (f"min {h['min']:.4g}, mean {h['mean']:.4g}, max {h['max']:.4g} {unit}; "
            f"{bars}")


def _round(xs: Sequence[float]) -> list[float]:
    return [float(f"{x:.3g}") for x in xs]


def format_table(stats: dict) -> str:
    """The statistics as plain-text tables (what ``sdcomp stats`` prints)."""
    splits = stats["splits"]
    cols = [*splits, "all"]
    names = list(stats["categories"].values())
    rows = [["images", *(splits[s]["images"] for s in splits),
             sum(s["images"] for s in splits.values())],
            ["images with no objects", *(splits[s]["empty_images"] for s in splits),
             sum(s["empty_images"] for s in splits.values())]]
    for name in names:
        per = [splits[s]["objects"].get(name, 0) for s in splits]
        rows.append([f"objects: {name}", *per, sum(per)])
    per = [splits[s].get("ignore_regions", 0) for s in splits]
    rows.append(["ignore regions", *per, sum(per)])
    widths = [max(len(str(r[0])) for r in [["counts"], *rows])] + [
        max(len(str(c)), *(len(str(r[i + 1])) for r in rows)) for i, c in enumerate(cols)]
    out = [f"dataset {stats['folder']}", "", _row(["counts", *cols], widths)]
    out += [_row(r, widths) for r in rows]
    lo, hi = SIZE_BOUNDS
    head = ["object size (COCO area, px)", f"small <{lo}", f"medium {lo}-{hi}",
            f"large >={hi}"]
    srows = [[name, *(stats["sizes"].get(name, {}).get(k, 0) for k in SIZE_NAMES)]
             for name in names]
    widths = [max(len(str(r[0])) for r in [head, *srows])] + [
        max(len(head[i]), *(len(str(r[i])) for r in srows)) for i in range(1, 4)]
    out += ["", _row(head, widths)] + [_row(r, widths) for r in srows]
    out += ["", "object size sqrt(area): " + _hist_line(stats["object_size"], "px")]
    for _, label, unit in META_HISTOGRAMS:
        out.append(f"{label}: " + _hist_line(stats["meta"][label], unit))
    total = sum(stats["water"].values()) or 1
    out.append("water colour: " + ", ".join(f"{k} {v} ({100 * v / total:.0f}%)"
                                            for k, v in stats["water"].items()))
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- figure

def _water_rgb(name: str) -> tuple[float, float, float]:
    """Bar colour of a water name or "R,G,B" (grey when it is neither): a custom colour
    itself, else the swatch of the (first) type's middle constituents."""
    from ..render.water.optics import iops, swatch
    from ..scene.water import WATER_TYPES, parse_water

    try:
        _, types, rgb = parse_water(name)
    except UserError:
        return (0.5, 0.5, 0.5)
    if rgb is None:
        chl, cdom, tsm = (math.sqrt(lo * hi) for lo, hi in WATER_TYPES[types[0]])
        rgb = swatch(*iops(chl, cdom, tsm))
    return (rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0)


def plot_stats(stats: dict, path: str | Path | None = None, dpi: int = 100) -> bytes:
    """Draw the statistics (2 x 3 panels) as PNG bytes; also written to ``path`` (atomically)
    when given. Uses matplotlib's Agg canvas, not pyplot (no global backend change)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13.5, 7.5), dpi=dpi)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 3)
    fig.suptitle(f"sdcomp dataset {Path(stats['folder']).name}: "
                 f"{sum(s['images'] for s in stats['splits'].values())} images")
    _plot_counts(axes[0, 0], stats)
    _plot_sizes(axes[0, 1], stats)
    # metadata histograms
    for ax, (_, label, unit) in zip((axes[0, 2], axes[1, 0], axes[1, 1]), META_HISTOGRAMS,
                                    strict=True):
        _plot_meta(ax, stats["meta"][label], label, unit)
    _plot_water(axes[1, 2], stats)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    data = buf.getvalue()
    if path is not None:
        atomic_write_bytes(path, data)
    return data


def _plot_meta(ax, h: dict, label: str, unit: str) -> None:
    """The histogram ``h`` of one metadata value over the images; a value that is the same
    in every image is said in words instead (a histogram of it is one bar at a meaningless
    place)."""
    ax.set_title(label)
    if h["n"] and h["min"] == h["max"]:
        ax.text(0.5, 0.5, f"constant:\n{h['min']:g} {unit}\n(all {h['n']} images)",
                ha="center", va="center", fontsize=14, transform=ax.transAxes)
        ax.set_xticks([])
        ax.set_yticks([])
        return
    if h["n"]:
        ax.stairs(h["counts"], h["edges"], fill=True, alpha=0.7)
    ax.set_xlabel(f"{label}, {unit}")
    ax.set_ylabel("images")


def _plot_counts(ax, stats: dict) -> None:
    """Bars of the objects per category and of the images with no objects, one bar per
    split (:func:`dataset_stats` ``stats``)."""
    splits = list(stats["splits"])
    labels = [*stats["categories"].values(), "no objects"]
    x = np.arange(len(labels))
    width = 0.8 / max(len(splits), 1)
    for k, s in enumerate(splits):
        d = stats["splits"][s]
        vals = [d["objects"].get(n, 0) for n in labels[:-1]] + [d["empty_images"]]
        ax.bar(x + (k - (len(splits) - 1) / 2) * width, vals, width, label=s)
    ax.set_xticks(x, labels, rotation=20, ha="right")
    ax.set_title("objects per category; images with no objects")
    ax.set_ylabel("count")
    ax.legend()


def _plot_sizes(ax, stats: dict) -> None:
    """The histogram of the objects' sqrt(area) in pixels, the COCO bounds (32, 96 px)
    dashed, the objects per size class in the title."""
    h = stats["object_size"]
    if h["n"]:
        ax.stairs(h["counts"], h["edges"], fill=True, alpha=0.7)
    for b, n in zip((math.sqrt(b) for b in SIZE_BOUNDS), ("32", "96"), strict=True):
        ax.axvline(b, color="k", ls="--", lw=1)
        ax.text(b, ax.get_ylim()[1] * 0.95, f" {n}", va="top")
    sums = {k: sum(v.get(k, 0) for v in stats["sizes"].values()) for k in SIZE_NAMES}
    ax.set_title("object size: " + ", ".join(f"{k} {v}" for k, v in sums.items()))
    ax.set_xlabel("sqrt(mask area), pixels (COCO bounds 32, 96)")
    ax.set_ylabel("objects")


def _plot_water(ax, stats: dict) -> None:
    """Bars of the images per water colour, each in its colour."""
    names = list(stats["water"])
    ax.bar(names, [stats["water"][n] for n in names],
           color=[_water_rgb(n) for n in names], edgecolor="k")
    ax.set_title("water colour")
    ax.set_ylabel("images")
