"""Does fitting help a detector? The experiment of docs/fit.md, end to end, for one pair of
seeds (about 50 minutes on 2 cores):

1. the stand-in footage: 40 frames of BlueROV2s at 640 x 360, 5-9 m, straight down (seed
   ``--standin-seed``), tinted green (R x 0.55 + 10, G x 0.75 + 35, B x 0.6 + 20) and saved
   as JPEG 95, with its labels as one COCO file;
2. ``sdcomp fit`` on it (its labels keep the robots out of the water statistics);
3. two training sets of 400 images (320 train, 80 val, seed ``--train-seed``): the
   defaults and the fitted config, the same geometry: the footage's aspect at
   ``--train-width`` px wide (384 x 216), flown lower in proportion (3-5.4 m), so that the
   robots show the footage's shapes and pixel sizes. Before 2026-11-28 the sets were
   256 x 256 at 3-6 m: a 3:2 sensor squeezed into a square draws every box 1.8 times as
   tall for its width as the 16:9 footage does (``sdcomp realism --objects``: median box
   aspect 1.47 against 0.82), in both arms;
4. ``sdcomp bench sim2real`` on each (MobileNetV3-FPN from scratch, SGD lr 0.01, 400
   iterations of 4 images, one torch thread each, both at once), which scores the
   detector on the stand-in as trained and after BatchNorm re-estimation on it.

    python tools/fit_sim2real.py WORKDIR [--standin-seed 7] [--train-seed 11]
        [--train-width 384] [--refit]

A ``fitted.toml`` already in WORKDIR is used as it is unless ``--refit``.

Prints one line per detector: generated val AP50, footage AP50 as trained and after
BatchNorm re-estimation (read from each run's ``sim2real.json``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

TINT = ((0.55, 10.0), (0.75, 35.0), (0.6, 20.0))  # (gain, offset) for R, G, B
STANDIN_SIZE = (640, 360)  #: the stand-in footage's frame, px
STANDIN_ALTITUDE = (5.0, 9.0)  #: metres


def train_geometry(width: int = 384) -> list[str]:
    """``generate`` flags of a training set (400 images) with the stand-in footage's aspect
    and pixel sizes at ``width`` px wide: the same lens over a narrower frame, flown lower
    in proportion."""
    scale = width / STANDIN_SIZE[0]
    altitude = f"{STANDIN_ALTITUDE[0] * scale:.2f}-{STANDIN_ALTITUDE[1] * scale:.2f}"
    return ["--n", "400", "--width", str(width), "--height",
            str(round(STANDIN_SIZE[1] * scale)), "--altitude", altitude]


def run(*args: str) -> None:
    """Run ``sdcomp ARGS`` in this interpreter, failing loudly."""
    subprocess.run([sys.executable, "-m", "sdcomp", *args], check=True)


def tint(dataset: Path, out: Path) -> Path:
    """Write ``dataset``'s images tinted (:data:`TINT`, JPEG 95) flat into ``out`` and their
    boxes as ``out/labels.json`` (COCO, file names without folders); returns that file."""
    out.mkdir(parents=True, exist_ok=True)
    images, anns, cats = [], [], None
    for split in ("train", "val"):
        coco = json.loads((dataset / "annotations" / f"instances_{split}.json").read_text())
        cats = coco["categories"]
        for img in coco["images"]:
            bgr = cv2.imread(str(dataset / "images" / img["file_name"])).astype(np.float32)
            for c, (gain, offset) in zip((2, 1, 0), TINT, strict=True):
                bgr[..., c] = bgr[..., c] * gain + offset
            name = Path(img["file_name"]).name
            cv2.imwrite(str(out / name), np.clip(np.rint(bgr), 0, 255).astype(np.uint8),
                        [cv2.IMWRITE_JPEG_QUALITY, 95])
            images.append({**img, "file_name": name})
        anns += [a for a in coco["annotations"] if a["category_id"] > 0]
    labels = out / "labels.json"
    labels.write_text(json.dumps({"images": images, "annotations": anns,
                                  "categories": cats}))
    return labels


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("workdir", type=Path)
    ap.add_argument("--standin-seed", type=int, default=7)
    ap.add_argument("--train-seed", type=int, default=11)
    ap.add_argument("--sprites", default=None)
    ap.add_argument("--train-width", type=int, default=384,
                    help="training images' width; height and altitude follow the footage")
    ap.add_argument("--refit", action="store_true", help="fit again over a fitted.toml")
    a = ap.parse_args()
    w: Path = a.workdir
    sprites = ["--sprites", a.sprites] if a.sprites else []
    quiet = ["--no-progress", "-q"]
    if not (w / "standin" / "dataset.json").exists():
        run("generate", "--n", "40", "--width", str(STANDIN_SIZE[0]), "--height",
            str(STANDIN_SIZE[1]), "--altitude", f"{STANDIN_ALTITUDE[0]:g}-{STANDIN_ALTITUDE[1]:g}",
            "--seed", str(a.standin_seed), "--out", str(w / "standin"), *sprites, *quiet)
    labels = tint(w / "standin", w / "footage")
    if a.refit or not (w / "fitted.toml").exists():
        run("fit", str(w / "footage"), "--labels", str(labels), "--out",
            str(w / "fitted.toml"), *sprites, "-q")
    train = [*train_geometry(a.train_width), "--seed", str(a.train_seed), *sprites, *quiet]
    if not (w / "defaults" / "dataset.json").exists():
        run("generate", *train, "--out", str(w / "defaults"))
    run("generate", "--config", str(w / "fitted.toml"), *train, "--out", str(w / "fitted"),
        "--overwrite")
    detector = ["--backbone", "mobilenet_v3-fpn", "--weights", "none", "--optimizer", "sgd",
                "--lr", "0.01", "--max-iter", "400", "--batch-size", "4", "--threads", "1",
                "--device", "cpu", "--no-progress"]
    procs = [subprocess.Popen([sys.executable, "-m", "sdcomp", "bench", "sim2real", "--train",
                               str(w / name), "--real", str(w / "footage"), "--real-labels",
                               str(labels), "--out", str(w / f"s2r_{name}"), *detector])
             for name in ("defaults", "fitted")]
    if any(p.wait() for p in procs):
        sys.exit("a training failed")
    for name in ("defaults", "fitted"):
        print(name, json.dumps(json.loads((w / f"s2r_{name}" / "sim2real.json").read_text()),
                               indent=None)[:2000])


if __name__ == "__main__":
    main()
