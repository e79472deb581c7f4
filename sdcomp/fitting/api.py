"""The Python API of ``sdcomp fit``: :func:`fit` (footage -> :class:`GeneratorConfig`) and
:func:`fit_footage` (everything measured, for the report)."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..pipeline import DEFAULT_SPRITES
from ..render.camera.grade import SiteGrade, save_grade
from ..scene.config import GeneratorConfig
from ..scene.presets import preset
from ..scene.sample import sample_scene
from .footage import Footage, read_footage
from .grade import GradeFit, fit_grade, water_patches
from .search import Renderer, SearchResult, search, with_settings


@dataclass
class FitResult:
    """A fit: the ``config`` to generate with (without its grade: the caller writes it,
    :func:`~sdcomp.render.camera.grade.save_grade`, and names it in the config), the
    ``footage`` measured, the ``search`` (fitted and default statistics, trials), whether
    the geometry was fitted, and the site ``grade`` with the graded frames' ``graded``
    (summary, first frames) and how it was chosen, ``grade_fit`` (None: not fitted)."""

    config: GeneratorConfig
    footage: Footage
    search: SearchResult
    geometry: str
    grade: SiteGrade | None = None
    graded: tuple[dict, list] | None = None
    grade_fit: GradeFit | None = None


def geometry_param(values: Sequence[float], digits: int = 0) -> str | None:
    """A generator range covering ``values`` (10th to 90th percentile, rounded), a single
    value when they agree; None without values."""
    if not values:
        return None
    lo, hi = (round(float(v), digits) for v in np.percentile(values, (10, 90)))
    return f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"


def base_config(footage: Footage, seed: int = 0, fov: float | None = None,
                preset_name: str | None = None) -> tuple[GeneratorConfig, str]:
    """The defaults (or preset ``preset_name``'s settings: the scene the fitted config will
    be generated under, ``generate --preset NAME --config FITTED``) at the footage's working
    size, with its altitude and pitch where known and, given ``fov`` (the frames' diagonal
    field of view, degrees), a custom camera whose frames are the footage's (``sensor_px``
    its working size); and a line saying what geometry was fitted."""
    start = (GeneratorConfig.from_mapping(preset(preset_name), source="--preset")
             if preset_name else GeneratorConfig())
    base = with_settings(start, width=footage.width, height=footage.height, seed=seed)
    if fov is not None:
        base = with_settings(base, camera="custom", fov=round(float(fov), 2),
                             sensor_px=(footage.width, footage.height))
    alt, pitch = geometry_param(footage.altitude), geometry_param(footage.pitch)
    if alt is not None:
        base = with_settings(base, altitude=alt)
    if pitch is not None:
        base = with_settings(base, pitch=pitch)
    kept = f"--preset {preset_name}'s" if preset_name else "the defaults'"
    if alt is None and pitch is None:
        how = ("geometry not fitted: no --altitude/--pitch and no altitude or gimbal pitch "
               f"in the labels' meta or the DJI flight logs (XMP, SRT); {kept} "
               "altitude and pitch are kept")
    else:
        how = (f"geometry from the footage: altitude {base.altitude} m"
               f"{'' if alt else ' (default: not known)'}, pitch {base.pitch} degrees"
               f"{'' if pitch else ' (default: not known)'}")
    if fov is not None:
        how += f"; camera: custom, {base.fov:g} degrees diagonally (--fov or the photos' EXIF)"
    else:
        how += _stretch_note(base)
    return base, how


def _stretch_note(config: GeneratorConfig) -> str:
    """'' when ``config``'s frames keep its camera's pixels square, else a clause saying
    how much taller for their width its objects are drawn and that ``--fov`` mends it."""
    m = config.camera_model()
    stretch = m.fy / m.fx  # output pixels per sensor pixel, rows over columns
    if abs(math.log(stretch)) < math.log(1.02):
        return ""
    return (f"; camera: {config.camera}'s {m.sensor_width} x {m.sensor_height} sensor resized "
            f"to the footage's {config.width} x {config.height} frames draws objects "
            f"{stretch:.2f} times as tall for their width as they are: give --fov (the "
            f"frames' diagonal field of view) for a camera whose frames are the footage's")


def fit_footage(frames: str | Path, labels: str | Path | None = None,
                altitude: float | None = None, pitch: float | None = None,
                size: int | None = None, max_frames: int = 200, n_render: int = 16,
                sprites_dir: str | Path | None = DEFAULT_SPRITES,
                groups: tuple[str, ...] | None = None, passes: int = 2, seed: int = 0,
                log: Callable[[str], None] | None = None,
                fov: float | None = None, grade: bool = False,
                preset_name: str | None = None) -> FitResult:
    """Measure the footage at ``frames`` (folder or file of photos and videos; ``labels``
    COCO json / YOLO folder keep objects out) and search the generator's settings that match
    it (:func:`sdcomp.fitting.search.search`: ``n_render`` frames per candidate, the
    search ``groups`` of :data:`~sdcomp.fitting.search.CANDIDATES`, ``passes`` rounds;
    ``fov``: the frames' diagonal field of view, degrees, which keeps the sky of oblique
    frames of known pitch out of the statistics; ``grade``: also fit the site grade,
    :func:`site_grade`; ``preset_name``: fit under that preset's scene, see
    :func:`base_config`). UserError for bad input."""
    footage = read_footage(frames, labels, size, max_frames, altitude, pitch, seed, fov=fov)
    if log:
        log(f"footage: {footage.frames} frames measured at {footage.width} x "
            f"{footage.height} px")
    base, how = base_config(footage, seed, footage.fov, preset_name)
    result = search(footage, base, sprites_dir, n_render, groups, passes, log)
    config = replace(result.config, count=base.count, clutter=base.clutter, n=base.n)
    out = FitResult(config, footage, result, how)
    if grade:
        out.grade_fit, out.graded = site_grade(footage, config, sprites_dir, n_render, seed)
        out.grade = out.grade_fit.grade
        if log:
            f = out.grade_fit
            log(f"site grade: the realism classifier's accuracy at the fit {f.before:.3f} "
                f"-> {f.after:.3f}" + (" (no grade helps: none)" if out.grade.identity
                                        else ""))
    return out


def site_grade(footage: Footage, config: GeneratorConfig, sprites_dir: str | Path | None,
               n_render: int = 16, seed: int = 0) -> tuple[GradeFit, tuple[dict, list]]:
    """The site grade (:func:`~.grade.fit_grade`) from the footage's water patches to those
    of ``n_render`` water-only frames of the fitted ``config`` (indices from 20 000, apart
    from the search's; at least 2), and the graded frames' (summary, first frames) as the
    search measures them."""
    r = Renderer(config, sprites_dir, n_render, mask_sky=footage.sky_masked)
    rng = np.random.default_rng([int(seed), 0x6AE])
    patches = []
    for i in range(20_000, 20_000 + n_render):
        scene = sample_scene(r.base, i, r.gen.model)
        keep = r._water(scene)
        patches.append(water_patches(r.render(r.base, scene), keep, rng))
    of_frame = np.repeat(np.arange(len(patches)), [len(p) for p in patches])
    fitted = fit_grade(np.concatenate(patches), of_frame, footage.patches,
                       footage.patch_frames, footage.width,
                       f"fitted to {footage.frames} frames at {footage.width} x "
                       f"{footage.height} px")
    with tempfile.TemporaryDirectory(prefix="sdcomp-grade-") as tmp:
        path = Path(tmp) / "grade.json"
        save_grade(fitted.grade, path)
        summary_, _, first = r.measure(replace(config, grade=str(path)))
    return fitted, (summary_, first)


def fit(frames: str | Path, **options) -> GeneratorConfig:
    """The generator config whose images look like the footage at ``frames``: see
    :func:`fit_footage` for the options."""
    return fit_footage(frames, **options).config
