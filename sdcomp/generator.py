"""The Python API: build a generator from a config, render image ``i`` to arrays.

    >>> from sdcomp import GeneratorConfig, Generator
    >>> gen = Generator(GeneratorConfig(n=10, seed=1))
    >>> sample = gen.sample(3)          # nothing touches the disk but the sprite cache
    >>> sample.image.shape, sample.masks.shape, sample.annotations[0]["bbox"]

Image ``i`` depends only on (config, i): any process, any order, same pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .atlas import AtlasConfig, ensure_atlas
from .backgrounds import Backgrounds
from .clutter import build as build_clutter
from .coloredmesh import ColoredMesh
from .compositor import Compositor, Frame
from .config import GeneratorConfig
from .errors import UserError
from .mesh import MeshSpec
from .poses import PoseGrid
from .scene import Scene, sample_scene
from .sprites import SpriteSource
from .water import floor_tile, land_tile, wave_tile

DEFAULT_SPRITES = "sprites"
#: atlas parameters of clutter meshes: smaller sprites, a coarser pose grid
CLUTTER_ATLAS = AtlasConfig(size=64, supersample=3,
                            grid=PoseGrid(off_nadir_step=15.0, max_error=10.0))
WAVE_DIRECTIONS = (0.0, 45.0, 90.0, 135.0)
WARM_MAX_SIDE = 1024  # pixels: Generator.warm() prepares sprites for frames up to this size


@dataclass
class Sample:
    """One rendered image as arrays.

    Attributes:
        image: (H, W, 3) uint8 RGB.
        instances: (H, W) uint16 instance ids (0 = no object), as in the mask PNGs.
        masks: (N, H, W) bool, one per annotation, ``masks[k] == (instances == k + 1)``.
        annotations: N dicts: instance_id, category_id, category, bbox [x, y, w, h] px,
            area px, pose {heading_deg, roll_deg, pitch_deg, draft_m, x_m, y_m}.
        meta: the image's metadata (altitude, pitch, GSD, water, sun, ...).
    """

    image: np.ndarray
    instances: np.ndarray
    annotations: list[dict]
    meta: dict
    frame: Frame

    @property
    def masks(self) -> np.ndarray:
        n = len(self.annotations)
        return self.instances[None, :, :] == np.arange(1, n + 1, dtype=np.uint16)[:, None, None]


class Generator:
    """Renders the images of ``config``. Sprite atlases are loaded from ``sprites_dir`` or
    built there first (the BlueROV2's takes a few seconds, once)."""

    def __init__(self, config: GeneratorConfig, sprites_dir: str | Path = DEFAULT_SPRITES,
                 progress: bool | None = None, build_workers: int | None = None):
        self.config = config
        self.model = config.camera_model()
        objects = [self._source(_load_object(o.mesh), AtlasConfig(), sprites_dir,
                                progress, build_workers, f"--object {o.mesh}")
                   for o in config.objects]
        clutter = []
        if config.clutter > 0:
            clutter = [self._source(build_clutter(k), CLUTTER_ATLAS, sprites_dir, progress,
                                    build_workers, "") for k in config.clutter_kinds]
        seed = config.seed
        waves = [wave_tile(seed, d) for d in WAVE_DIRECTIONS]
        floor = floor_tile(seed, config.rocks)
        land = land_tile(seed)
        bgs = Backgrounds(config.backgrounds) if config.backgrounds else None
        self.compositor = Compositor(config, objects, clutter, waves, floor, land, bgs)

    @staticmethod
    def _source(mesh: ColoredMesh, atlas_config: AtlasConfig, sprites_dir, progress,
                workers, what: str) -> SpriteSource:
        cmd = f"python -m sdcomp.atlas build --mesh {mesh.name}" if not what else ""
        atlas, _ = ensure_atlas(mesh, atlas_config, sprites_dir, progress=progress,
                                workers=workers, rebuild_command=cmd, sheet=False)
        return SpriteSource(atlas)

    def warm(self) -> None:
        """Prepare the sprites' small mip levels now (:meth:`SpriteSource.warm`, 0.2 s): call
        it before forking workers, which then inherit them. Frames wider or higher than
        :data:`WARM_MAX_SIDE` pixels draw their objects from the large levels: for them it
        does nothing."""
        if max(self.model.width, self.model.height) > WARM_MAX_SIDE:
            return
        for src in self.compositor.objects + self.compositor.clutter:
            src.warm()

    def scene(self, index: int) -> Scene:
        """The scene description of image ``index``."""
        return sample_scene(self.config, index, self.model)

    def render(self, index: int) -> Frame:
        """Image ``index`` with its instance map and annotated objects."""
        return self.compositor.render(self.scene(index), amodal=self.config.amodal)

    def sample(self, index: int) -> Sample:
        """Image ``index`` as arrays with COCO-style annotations (no ids, no RLE)."""
        frame = self.render(index)
        return Sample(frame.image, frame.instances, annotations(self.config, frame),
                      metadata(frame), frame)


def _load_object(source: str) -> ColoredMesh:
    try:
        return MeshSpec(source).load()
    except UserError as e:
        raise UserError(f"--object {source}: {e}") from None


def annotations(config: GeneratorConfig, frame: Frame) -> list[dict]:
    """Per annotated object: instance_id, category_id, category, bbox, area, pose."""
    out = []
    for inst in frame.objects:
        pl = frame.scene.placements[inst.placement]
        out.append({
            "instance_id": inst.instance_id,
            "category_id": inst.category_id,
            "category": config.objects[pl.model].category,
            "bbox": list(inst.bbox),
            "area": inst.area,
            "pose": {"heading_deg": round(pl.heading % 360.0, 3),
                     "roll_deg": round(pl.roll, 3), "pitch_deg": round(pl.pitch, 3),
                     "draft_m": round(pl.draft, 4), "x_m": round(pl.x, 3),
                     "y_m": round(pl.y, 3)},
        })
    return out


def metadata(frame: Frame) -> dict:
    """Per-image metadata (names follow SeaDronesSee's ``meta`` where they overlap)."""
    s = frame.scene
    fx = s.effects
    return {
        "height_above_takeoff(meter)": round(s.camera.altitude, 4),
        "gimbal_pitch(degrees)": round(s.camera.pitch, 4),
        "gimbal_heading(degrees)": round(s.camera.heading, 4),
        "gsd(m/px)": round(frame.gsd, 6),
        "water_color": s.water_name,
        "water_rgb": list(s.water_rgb),
        "turbidity": round(s.turbidity, 4),
        "attenuation(1/m)": round(s.attenuation, 5),
        "wind(m/s)": round(s.wind, 3),
        "floor_depth(meter)": round(s.floor_depth, 3),
        "sun_elevation(degrees)": round(s.sun_elevation, 3),
        "sun_azimuth(degrees)": round(s.sun_azimuth, 3),
        "shore": s.shore is not None,
        "hills": s.hills is not None,
        "clutter": sum(1 for p in s.placements if p.kind == "clutter"),
        "objects_placed": sum(1 for p in s.placements if p.kind == "object"),
        "objects_dropped": frame.dropped,
        "exposure(stops)": round(fx.exposure, 4),
        "noise_sigma": round(fx.noise, 4),
        "motion_blur_px": round(fx.motion_blur[0], 3) if fx.motion_blur else 0.0,
        "defocus_sigma_px": round(fx.defocus_blur, 3) if fx.defocus_blur else 0.0,
    }
