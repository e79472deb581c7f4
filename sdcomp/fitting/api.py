"""The Python API of ``sdcomp fit``: :func:`fit` (footage -> :class:`GeneratorConfig`) and
:func:`fit_footage` (everything measured, for the report)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..pipeline import DEFAULT_SPRITES
from ..scene.config import GeneratorConfig
from .footage import Footage, read_footage
from .search import SearchResult, search, with_settings


@dataclass
class FitResult:
    """A fit: the ``config`` to generate with, the ``footage`` measured, the ``search``
    (fitted and default statistics, trials) and whether the geometry was fitted."""

    config: GeneratorConfig
    footage: Footage
    search: SearchResult
    geometry: str


def geometry_param(values: Sequence[float], digits: int = 0) -> str | None:
    """A generator range covering ``values`` (10th to 90th percentile, rounded), a single
    value when they agree; None without values."""
    if not values:
        return None
    lo, hi = (round(float(v), digits) for v in np.percentile(values, (10, 90)))
    return f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"


def base_config(footage: Footage, seed: int = 0, fov: float | None = None
                ) -> tuple[GeneratorConfig, str]:
    """The defaults at the footage's working size, with its altitude and pitch where known
    and, given ``fov`` (the frames' diagonal field of view, degrees), a custom camera whose
    frames are the footage's (``sensor_px`` its working size); and a line saying what
    geometry was fitted."""
    base = GeneratorConfig(width=footage.width, height=footage.height, seed=seed)
    if fov is not None:
        base = with_settings(base, camera="custom", fov=round(float(fov), 2),
                             sensor_px=(footage.width, footage.height))
    alt, pitch = geometry_param(footage.altitude), geometry_param(footage.pitch)
    if alt is not None:
        base = with_settings(base, altitude=alt)
    if pitch is not None:
        base = with_settings(base, pitch=pitch)
    if alt is None and pitch is None:
        how = ("geometry not fitted: no --altitude/--pitch and no altitude or gimbal pitch "
               "in the labels' meta or the DJI flight logs (XMP, SRT); the defaults' "
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
                fov: float | None = None) -> FitResult:
    """Measure the footage at ``frames`` (folder or file of photos and videos; ``labels``
    COCO json / YOLO folder keep objects out) and search the generator's settings that match
    it (:func:`sdcomp.fitting.search.search`: ``n_render`` frames per candidate, the
    search ``groups`` of :data:`~sdcomp.fitting.search.CANDIDATES`, ``passes`` rounds;
    ``fov``: the frames' diagonal field of view, degrees, which keeps the sky of oblique
    frames of known pitch out of the statistics). UserError for bad input."""
    footage = read_footage(frames, labels, size, max_frames, altitude, pitch, seed, fov=fov)
    if log:
        log(f"footage: {footage.frames} frames measured at {footage.width} x "
            f"{footage.height} px")
    base, how = base_config(footage, seed, footage.fov)
    result = search(footage, base, sprites_dir, n_render, groups, passes, log)
    config = replace(result.config, count=base.count, clutter=base.clutter, n=base.n)
    return FitResult(config, footage, result, how)


def fit(frames: str | Path, **options) -> GeneratorConfig:
    """The generator config whose images look like the footage at ``frames``: see
    :func:`fit_footage` for the options."""
    return fit_footage(frames, **options).config
