"""The Python API: build a generator from a config, render image ``i`` to arrays.

    >>> from sdcomp import GeneratorConfig, Generator
    >>> gen = Generator(GeneratorConfig(n=10, seed=1))
    >>> sample = gen.sample(3)          # nothing touches the disk but the sprite cache
    >>> sample.image.shape, sample.masks.shape, sample.annotations[0]["bbox"]

A :class:`Generator` puts the stages together for one config: the assets (meshes -> sprite
atlases, ground textures, the user's photos), the scene of image ``i``
(:func:`sdcomp.scene.sample.sample_scene`), its rendering (:class:`sdcomp.render.Compositor`),
the labels of what it shows (:func:`sdcomp.annotate.label_map`), the camera's recording of both
(:meth:`Compositor.record`: its lens moves the labels with the pixels) and the annotated
objects measured on the recorded labels (:func:`sdcomp.annotate.measure`). Image ``i`` depends
only on (config, i): any process, any order, same pixels.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .annotate import (
    AnnotationRule,
    Frame,
    amodal_masks,
    image_meta,
    label_map,
    measure,
    object_annotations,
)
from .assets import clutter as clutter_meshes
from .assets import sar
from .assets.library import MeshSpec, build_builtin, is_builtin
from .assets.mesh import ColoredMesh
from .assets.meshfile import safe_name
from .atlas.builtin import clutter_atlas, object_atlas
from .atlas.cache import announce_build, ensure_atlas, missing_atlases, sprites_folder
from .atlas.sprites import SpriteSource
from .atlas.store import AtlasConfig
from .errors import UserError
from .render.camera.grade import load_grade
from .render.compositor import Compositor, RenderAssets
from .render.photos import Backgrounds
from .render.textures import Textures
from .scene.config import GeneratorConfig
from .scene.moorings import ASSETS as MOORING_ASSETS
from .scene.moorings import MOORED_KINDS
from .scene.objects import (
    CLUTTER_PREFIX,
    clutter_assets,
    clutter_mesh_name,
    measure_all,
    object_assets,
    object_kind,
)
from .scene.sample import sample_scene
from .scene.scene import FeatureSeeds, Role, Scene
from .util.heap import keep_freed_memory
from .util.progress import Progress

DEFAULT_SPRITES = None  # the user's atlas folder: see sdcomp.atlas.cache.sprites_folder
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
    built there first, once: one per mesh, and each variant of a search-and-rescue kind is a
    mesh (the BlueROV2's takes a few seconds; all five kinds' 60 about a minute or two on
    2 cores; see :mod:`sdcomp.atlas.builtin`)."""

    def __init__(self, config: GeneratorConfig, sprites_dir: str | Path | None = DEFAULT_SPRITES,
                 progress: bool | None = None, build_workers: int | None = None):
        keep_freed_memory()  # frames' temporaries reused, not faulted in again
        self.config = config
        self.model = config.camera_model()
        if config.grade is not None:
            load_grade(config.grade)  # a grade file it cannot use stops it here, named
        sprites = _all_sprites(config, sprites_folder(sprites_dir), progress, build_workers)
        photos = (Backgrounds(config.backgrounds, config.background_labels)
                  if config.backgrounds else None)
        assets = RenderAssets(sprites, Textures.build(config.seed), photos)
        self.compositor = Compositor(assets)
        self.compositor.prepare(self.model, FeatureSeeds.of(0, config.seed).noise_tile)
        self.rule = AnnotationRule(config.min_visible_px, config.amodal, config.min_in_frame)
        self.names = {c["id"]: c["name"] for c in config.categories}

    def warm(self) -> None:
        """Build every water tile (:meth:`WaterTextures.build_all`, 1.3 s), measure every
        object's footprint and visible hull (:func:`~sdcomp.scene.objects.measure_all`, 0.8
        s for the default's 25 meshes) and prepare the sprites' small mip levels
        (:meth:`SpriteSource.warm`, 0.2 s) now: call it before forking workers, which then
        inherit them. Frames wider or higher than :data:`WARM_MAX_SIDE` pixels draw their
        objects from the large levels: for them the sprites are not prepared."""
        self.compositor.assets.textures.water.build_all()
        measure_all(self.compositor.assets.sprites)
        if max(self.model.width, self.model.height) > WARM_MAX_SIDE:
            return
        for src in self.compositor.assets.sprites.values():
            src.warm()

    def scene(self, index: int) -> Scene:
        """The scene description of image ``index``."""
        return sample_scene(self.config, index, self.model)

    def render(self, index: int) -> Frame:
        """Image ``index`` with its instance map and annotated objects."""
        return self.render_scene(self.scene(index))

    def render_scene(self, scene: Scene, rule: AnnotationRule | None = None) -> Frame:
        """Any ``scene`` of this generator's assets (e.g. :meth:`scene` with placements of
        your own, :func:`dataclasses.replace`-d) rendered and annotated by ``rule``
        (default: the config's). With ``--unlabelled skip``, objects of interest that cannot
        be labelled are not drawn: the scene is drawn again without them (hiding one only
        uncovers others) until every object drawn with a visible pixel is labelled; images
        with nothing to skip are drawn once, as with ``draw``."""
        rule = rule or self.rule
        frame = self._render_once(scene, rule)
        if self.config.unlabelled != "skip":
            return frame
        skipped = 0
        while frame.ignored:
            skipped += len(frame.ignored)
            hidden = tuple(sorted({*frame.scene.hidden, *(o.placement for o in frame.ignored)}))
            frame = self._render_once(replace(frame.scene, hidden=hidden), rule)
        frame.skipped = skipped
        frame.dropped -= skipped
        return frame

    def _render_once(self, scene: Scene, rule: AnnotationRule) -> Frame:
        """``scene`` drawn and annotated by ``rule`` (every placement but its hidden ones)."""
        out = self.compositor.render(scene)
        labels, objs = label_map(scene, out.layers)
        amodal = amodal_masks(labels.shape, objs) if rule.amodal else None
        image, labels, amodal, camera = self.compositor.record(scene, out.image, labels, amodal)
        found = measure(labels, objs, rule, amodal, "lens" in camera["stages"],
                        camera.get("zoom", 1.0))
        dropped = found.dropped + scene.count(Role.OBJECT) - len(objs)
        return Frame(image, labels, found.objects, dropped, scene, camera, found.ignored,
                     found.ignore)

    def sample(self, index: int) -> Sample:
        """Image ``index`` as arrays with COCO-style annotations (no ids, no RLE)."""
        frame = self.render(index)
        return Sample(frame.image, frame.instances, object_annotations(frame, self.names),
                      image_meta(frame), frame)


def _sprite_jobs(config: GeneratorConfig) -> list[tuple[str, str, bool]]:
    """The atlases a config draws from: (asset key, atlas name, known without building the
    mesh; whether it is a clutter asset), objects first."""
    jobs: list[tuple[str, str, bool]] = []
    for o in config.objects:
        jobs += [(key, key if is_builtin(key) else safe_name(Path(key)), False)
                 for key in object_assets(o.mesh)]
    if config.clutter > 0:
        jobs += [(key, clutter_mesh_name(key), True)
                 for kind in config.clutter_kinds for key in clutter_assets(kind)]
    if config.moored > 0 and any(object_kind(o.mesh) in MOORED_KINDS for o in config.objects):
        jobs += [(key, clutter_mesh_name(key), True) for key in MOORING_ASSETS]
    first: dict[str, tuple[str, str, bool]] = {}
    for job in jobs:
        first.setdefault(job[0], job)
    return list(first.values())


def _all_sprites(config: GeneratorConfig, folder: Path, progress: bool | None,
                 workers: int | None) -> dict[str, SpriteSource]:
    """Every atlas of ``config`` from ``folder``, those missing built first: announced in one
    line on stderr (unless ``progress`` is False) and, on a terminal, one progress bar over
    the atlases instead of one per atlas."""
    jobs = _sprite_jobs(config)
    missing = missing_atlases(folder, [name for _, name, _ in jobs])
    bar = None
    if missing and progress is not False:
        announce_build(folder, len(missing))
        bar = Progress(len(missing), "sprite atlases", enabled=progress, unit="atlas")
    sprites: dict[str, SpriteSource] = {}
    for key, name, clutter in jobs:
        mesh = _clutter_mesh(key) if clutter else _load_object(key)
        atlas_config = clutter_atlas(mesh) if clutter else object_atlas(mesh, object_kind(key))
        rebuild = (key.removeprefix(CLUTTER_PREFIX) == mesh.name) if clutter else is_builtin(key)
        sprites[key] = _sprites(mesh, atlas_config, folder,
                                False if bar is not None else progress, workers, rebuild)
        if bar is not None and name in missing:
            bar.update()
    if bar is not None:
        bar.close()
    return sprites


def _sprites(mesh: ColoredMesh, atlas_config: AtlasConfig, sprites_dir: str | Path,
             progress: bool | None, workers: int | None, rebuild: bool) -> SpriteSource:
    """The sprites of ``mesh``'s atlas (built first when missing); ``rebuild``: its index
    names the command that rebuilds it."""
    cmd = f"python -m sdcomp.atlas build --mesh {mesh.name}" if rebuild else ""
    atlas, _ = ensure_atlas(mesh, atlas_config, sprites_dir, progress=progress,
                            workers=workers, rebuild_command=cmd, sheet=False)
    return SpriteSource(atlas)


def _load_object(source: str) -> ColoredMesh:
    try:
        mesh = MeshSpec(source).load()
    except UserError as e:
        raise UserError(f"--object {source}: {e}") from None
    _remember_top(source, mesh)
    return mesh


def _remember_top(name: str, mesh: ColoredMesh) -> None:
    """Tell the scene sampler how tall a variant is (it keeps variants lower than half the
    altitude) from the mesh built here anyway: workers forked later inherit it."""
    parsed = sar.parse_name(name)
    if parsed is not None:
        sar.top_above_water(*parsed, mesh=mesh)


def _clutter_mesh(key: str) -> ColoredMesh:
    """The mesh of a clutter asset key, named after its own atlas (a variant's clutter
    atlas is smaller than its object atlas, so they must not share a file name)."""
    name = clutter_mesh_name(key)
    if name in clutter_meshes.KINDS:
        return clutter_meshes.build(name)
    variant = name.removeprefix("clutter-")
    mesh = build_builtin(variant)
    _remember_top(variant, mesh)
    return replace(mesh, name=name)


_CACHED: dict[tuple[str, str], Generator] = {}  # per process: see cached_generator


def cached_generator(config: GeneratorConfig, sprites_dir: str | Path) -> Generator:
    """This process's generator of ``config`` (built on first use, then kept; one config at a
    time: textures and sprites are large). For workers that receive a config rather than
    inherit a generator: Dask tasks and spawned pool workers."""
    key = (repr(sorted(config.to_dict().items())), str(sprites_dir))
    gen = _CACHED.get(key)
    if gen is None:
        _CACHED.clear()
        gen = _CACHED[key] = Generator(config, sprites_dir, progress=False)
    return gen
