"""Draw docs/sar/<kind>.jpg: every variant of each search-and-rescue kind rendered by sdcomp
at 20, 40 and 60 m, straight down and oblique (gimbal pitch 45 degrees), with the camera of
``--preset seadronessee`` (3840 x 2160 frames, 72.8 degrees diagonal, fx 2987 px).

    python docs/sar/make_sheets.py [--sprites sprites] [--out docs/sar] [KIND ...]

Each cell is the object as it appears in such a frame, cropped around its mask with a
margin and scaled to the cell (its box size in the full frame is written under it, in
pixels): the preset's green coastal water (coastal type, turbidity 0.75, the middle of its
0.5-1.0), wind 3 m/s, a clear sky with
the sun at 55 degrees, no camera effects (the clean look: the renderer's image).
The object stands at the image centre, heading 30 degrees; a window of the full frame
around it is rendered (same focal length: the same pixels). A variant whose top stands more
than half the altitude above the water is not drawn there by the generator (a sailboat's mast
under a drone at 10 m): its cell says so.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from sdcomp import Generator, GeneratorConfig
from sdcomp.assets import sar
from sdcomp.scene.camera import CameraModel, CameraPose, ground_point
from sdcomp.scene.look_table import clean_look
from sdcomp.scene.presets import preset
from sdcomp.scene.scene import Placement, Role
from sdcomp.scene.water import WaterParams, constituents

VIEWS = ((20.0, 90.0), (20.0, 45.0), (40.0, 90.0), (40.0, 45.0), (60.0, 90.0),
         (60.0, 45.0))  # altitude m, pitch deg
CELL = 200  # pixels
TURBIDITY = 0.75
CHL, CDOM, TSM = constituents("coastal", TURBIDITY)
#: the water of every cell: the preset's green coastal water, calm, deep, a clear sky
WATER = WaterParams(name="coastal", water_type="coastal", chl=CHL, cdom=CDOM, tsm=TSM,
                    turbidity=TURBIDITY, patchiness=0.0, wind=3.0, sky="clear",
                    sun_elevation=55.0, sun_azimuth=135.0)
WINDOWS = (256, 512, 1024, 2048, 3840)  # square frame windows, pixels


def window_model(fx: float, size: int) -> CameraModel:
    """A ``size`` px square camera with focal length ``fx`` px (a window of the frame)."""
    fov = 2 * math.degrees(math.atan(size * math.sqrt(0.5) / fx))
    return CameraModel(size, size, fov, size, size)


def cell(gen: Generator, asset: str, span: float, altitude: float, pitch: float
         ) -> np.ndarray:
    """The (CELL, CELL, 3) RGB cell of ``asset`` (``span`` m across) seen from
    ``altitude`` m at ``pitch`` degrees."""
    fx = gen.model.fx
    distance = altitude / math.sin(math.radians(pitch))
    want = span * fx / distance * 1.6 + 48
    size = next((w for w in WINDOWS if w >= want), WINDOWS[-1])
    model = window_model(fx, size)
    pose = CameraPose(altitude, pitch, 0.0)
    x, y = ground_point(model, pose, size / 2, size / 2) or (0.0, 0.0)
    base = gen.scene(0)
    scene = replace(base, model=model, camera=pose, water=WATER, shore=None, hills=None,
                    look=clean_look(size, size, model.fx, model.fy), defocus_blur=None,
                    jpeg_quality=95,
                    placements=(Placement(Role.OBJECT, asset, 1, x, y, 30.0, 0.0, 0.0, 0.0),))
    frame = gen.render_scene(scene)
    ys, xs = np.nonzero(frame.instances)
    if len(xs) == 0:
        return np.zeros((CELL, CELL, 3), np.uint8)
    x0, x1, y0, y1 = xs.min(), xs.max() + 1, ys.min(), ys.max() + 1
    w, h = x1 - x0, y1 - y0
    half = max(w, h) * 0.7 + 6
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    a0, a1 = int(max(cx - half, 0)), int(min(cx + half, size))
    b0, b1 = int(max(cy - half, 0)), int(min(cy + half, size))
    crop = frame.image[b0:b1, a0:a1]
    side = max(crop.shape[:2])
    square = np.zeros((side, side, 3), np.uint8)
    square[:crop.shape[0], :crop.shape[1]] = crop
    interp = cv2.INTER_AREA if side > CELL else cv2.INTER_NEAREST
    out = cv2.resize(square, (CELL, CELL), interpolation=interp)
    cv2.putText(out, f"{w}x{h} px", (3, CELL - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.38,
                (255, 255, 0), 1, cv2.LINE_AA)
    return out


def note(*lines: str) -> np.ndarray:
    """A dark cell with ``lines`` of text."""
    out = np.full((CELL, CELL, 3), 40, np.uint8)
    for k, line in enumerate(lines):
        cv2.putText(out, line, (8, CELL // 2 + 18 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.42,
                    (235, 235, 235), 1, cv2.LINE_AA)
    return out


def kind_sheet(gen: Generator, kind: str) -> np.ndarray:
    """Rows: the variants of ``kind``; columns: :data:`VIEWS`; with a header row."""
    head = np.full((24, CELL * len(VIEWS), 3), 30, np.uint8)
    for c, (alt, pitch) in enumerate(VIEWS):
        label = f"{alt:.0f} m, " + ("nadir" if pitch == 90 else f"pitch {pitch:.0f}")
        cv2.putText(head, label, (c * CELL + 4, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (235, 235, 235), 1, cv2.LINE_AA)
    rows = [head]
    for name in sar.variant_names(kind):
        mesh = sar.build(*(sar.parse_name(name) or (kind, 0)))
        span = float(np.linalg.norm(mesh.extents))
        top = sar.top_above_water(kind, int(name[-2:]))
        row = np.concatenate([cell(gen, name, span, a, p) if top <= a / 2 else
                              note(f"not drawn: top {top:.1f} m", "above altitude / 2")
                              for a, p in VIEWS], axis=1)
        sub = sar.describe_variant(kind, int(name[-2:]))["sub_type"]
        cv2.putText(row, f"{name} {sub}", (3, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (255, 255, 255), 1, cv2.LINE_AA)
        rows.append(row)
    return np.concatenate(rows, axis=0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("kinds", nargs="*", default=list(sar.KINDS))
    p.add_argument("--sprites", default="sprites")
    p.add_argument("--out", default=str(Path(__file__).parent))
    args = p.parse_args()
    config = GeneratorConfig.from_mapping({**preset("seadronessee"),
                                           "objects": list(args.kinds)})
    gen = Generator(config, args.sprites)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    for kind in args.kinds:
        path = Path(args.out) / f"{kind}.jpg"
        image = cv2.cvtColor(kind_sheet(gen, kind), cv2.COLOR_RGB2BGR)
        if not cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, 88]):
            raise SystemExit(f"could not write {path}")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
