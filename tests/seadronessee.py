"""SeaDronesSee's validation annotations (``../shared/reference/seadronessee``, tests only)
and the statistics a generated ``--preset seadronessee`` dataset is compared on: per-class
box sizes, altitudes, gimbal pitches and boxes per frame, as quantiles."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from .conftest import REFERENCE

VAL = REFERENCE / "seadronessee" / "instances_val.json"
CLASSES = ("swimmer", "boat", "jetski", "life_saving_appliances", "buoy")
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)


def load_val() -> dict:
    """The SeaDronesSee val COCO file; skips the test where it is absent."""
    if not VAL.exists():
        pytest.skip(f"SeaDronesSee reference annotations not found at {VAL} (validation "
                    f"only; set SDCOMP_REFERENCE to point at the reference folder)")
    return json.loads(VAL.read_text())


def stats(coco: dict, width: int | None = 3840, scale: float = 1.0) -> dict:
    """Per class: box sizes ``sqrt(w * h)`` in pixels (times ``scale``); and per frame:
    altitudes (m), gimbal pitches (degrees), boxes per frame, of the frames ``width``
    pixels wide (all where None) that have flight metadata."""
    names = {c["id"]: c["name"] for c in coco["categories"]}
    images = {im["id"]: im for im in coco["images"] if width is None or im["width"] == width}
    sizes: dict[str, list[float]] = {c: [] for c in CLASSES}
    per_image = dict.fromkeys(images, 0)
    for a in coco["annotations"]:
        if a["image_id"] in images and names.get(a["category_id"]) in sizes:
            sizes[names[a["category_id"]]].append(scale * float(np.sqrt(a["bbox"][2]
                                                                        * a["bbox"][3])))
            per_image[a["image_id"]] += 1
    meta = [im.get("meta") or {} for im in images.values()]
    flown = [m for m in meta if "height_above_takeoff(meter)" in m]
    return {"size": {c: np.array(v) for c, v in sizes.items()},
            "altitude": np.array([m["height_above_takeoff(meter)"] for m in flown]),
            "pitch": np.array([m["gimbal_pitch(degrees)"] for m in flown]),
            "count": np.array(list(per_image.values()), float)}


def quantiles(values: np.ndarray) -> np.ndarray:
    return np.quantile(values, QUANTILES)


def merged_coco(folder: Path) -> dict:
    """The train and val COCO files of a generated dataset as one."""
    files = [json.loads((folder / "annotations" / f"instances_{s}.json").read_text())
             for s in ("train", "val")]
    return {"categories": files[0]["categories"],
            "images": [im for f in files for im in f["images"]],
            "annotations": [a for f in files for a in f["annotations"]]}


def table(real: dict, synth: dict) -> str:
    """Quantiles of both side by side, for a report or a failing assertion."""
    rows = [f"{'':26s} {'q':>5s} " + " ".join(f"{q:>6.2f}" for q in QUANTILES)]
    for key in ("altitude", "pitch", "count"):
        for who, s in (("real", real), ("synthetic", synth)):
            rows.append(f"{key + ' ' + who:26s} {len(s[key]):5d} "
                        + " ".join(f"{v:6.1f}" for v in quantiles(s[key])))
    for c in CLASSES:
        for who, s in (("real", real), ("synthetic", synth)):
            v = s["size"][c]
            rows.append(f"{c[:14] + ' px ' + who:26s} {len(v):5d} "
                        + (" ".join(f"{x:6.1f}" for x in quantiles(v)) if len(v) else ""))
    return "\n".join(rows)
