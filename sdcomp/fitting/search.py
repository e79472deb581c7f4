"""The search of ``sdcomp fit``: the generator's settings whose images' statistics match the
footage's (:mod:`.stats`).

Two steps, repeated once the camera is known:

1. the water, by inversion of its colour: a table of the chromaticity (R, B shares) that each
   water type renders at turbidities 0..1 (a few small frames per cell, interpolated to
   steps of 0.05) is looked up with each frame's water colour; the types that explain at
   least :data:`TYPE_SHARE` of the frames are kept, and the turbidity range covers the
   10th to 90th percentile of their frames' turbidities;
2. a coordinate search over candidate values of the other settings (the camera's look,
   exposure bias, white balance, contrast, shot noise and recording, JPEG quality,
   sky, sun elevation, wind, motion and defocus blur): each
   candidate config renders the same ``n_render`` water-only frames (seeded, no objects)
   and the candidate whose statistics' :func:`~.stats.loss` to the footage's is lowest is
   kept.

Both run from the defaults' camera, then, when the footage's highlights carry a colour cast
(:func:`cast_start`), again from the white balance that cast implies; the fit with the
lower loss is kept.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np

from ..pipeline import Generator
from ..report.realism.patches import empty_water
from ..report.realism.sources import sky_mask
from ..scene.config import GeneratorConfig
from ..scene.sample import sample_scene
from ..scene.scene import Scene
from ..scene.water import WATER_TYPES
from .footage import Footage
from .stats import image_stats, loss, stack, summary

TYPE_SHARE = 0.2  #: a water type is kept when this share of frames is closest to it
TABLE_TURBIDITY = (0.0, 0.25, 0.5, 0.75, 1.0)  #: turbidities of the colour table's cells
TABLE_FRAMES = 2  #: frames rendered per cell of the colour table
#: the candidates of each searched setting (config field(s) -> values), in search order
CANDIDATES: dict[str, list[dict]] = {
    "sky": [{"sky": v} for v in (("clear", "broken", "overcast"), ("clear",),
                                 ("clear", "broken"), ("broken", "overcast"), ("overcast",))],
    "sun_elevation": [{"sun_elevation": v} for v in ("25-80", "10-35", "30-60", "55-85")],
    "wind": [{"wind": v} for v in ("1-8", "0-2", "1-4", "3-7", "6-11", "10-16")],
    "look": [{"look": v} for v in ("auto", "phantom4pro", "zenmuse-x5", "clean")],
    # the camera's exposure bias and white balance: unset (the look's own draws) or fixed
    "exposure": [{"exposure_bias": v} for v in (None, "-1.5:-0.9", "-0.9:-0.3", "-0.3:0.3",
                                                 "0.3:0.9", "0.9:1.5")],
    "wb_red": [{"wb_red": v} for v in (None, 0.4, 0.5, 0.6, 0.75, 0.9, 1.1, 1.3, 1.6)],
    "wb_blue": [{"wb_blue": v} for v in (None, 0.4, 0.5, 0.6, 0.75, 0.9, 1.1, 1.3, 1.6)],
    # the tone curve's contrast: unset or fixed (saturation is not searched: on water-only
    # frames the water type and white balance reach it)
    "contrast": [{"contrast": v} for v in (None, 0.7, 0.85, 1.0, 1.15, 1.35, 1.6, 1.9)],
    # the sensor's shot noise: unset or fixed, from the looks' top (6e-4, under the
    # compression's floor at these sizes) to a dim scene's (the in-camera sharpening is not
    # searched: drawn at the native scale, at the fit's sizes it moves the sharpness by
    # 0.01, under the frames' own spread)
    "noise": [{"shot_noise": v} for v in (None, 2e-3, 6e-3, 0.02, 0.06)],
    "recording": [{"recording": v} for v in ("video", "photo")],
    "jpeg_quality": [{"jpeg_quality": v} for v in ("90-95", "75-90", "50-75", "96-100")],
    "blur": [{"motion_blur": m, "defocus_blur": d}
             for m, d in ((0.5, 0.05), (0.0, 0.0), (0.2, 0.0), (1.0, 0.3))],
}


@dataclass
class Trial:
    """One evaluated candidate: the settings it changed, its loss, its summary."""

    group: str
    settings: dict
    loss: float
    summary: dict


@dataclass
class SearchResult:
    """The fitted config, its statistics (``summary``, ``per_image``, ``frames``: a few
    rendered (h, w, 3) uint8 RGB frames), the defaults' (at the footage's size and
    geometry), every trial, the water table lookups and the seconds taken."""

    config: GeneratorConfig
    summary: dict
    per_image: dict
    frames: list
    default_summary: dict
    default_frames: list
    trials: list[Trial] = field(default_factory=list)
    water_votes: dict = field(default_factory=dict)
    turbidities: list = field(default_factory=list)
    seconds: float = 0.0
    #: the second search from the highlights' cast, when there was one: its white balance
    #: start (``wb_red``, ``wb_blue``), both searches' losses and which was kept
    cast: dict | None = None


def with_settings(config: GeneratorConfig, **settings) -> GeneratorConfig:
    """``config`` with ``settings`` (config-file forms: ``"1-8"``, lists...), checked."""
    return GeneratorConfig.from_mapping(settings, base=config)


def water_only(config: GeneratorConfig) -> GeneratorConfig:
    """``config`` without objects of interest or clutter (the search measures water), its
    objects the defaults' (none is drawn: a preset's many would only cost their atlases)."""
    return replace(with_settings(config, count=0, clutter=0),
                   objects=GeneratorConfig().objects)


_GENERATOR: dict[tuple, Generator] = {}  # this process's last water generator


def water_generator(config: GeneratorConfig, sprites_dir: str | Path | None) -> Generator:
    """A :class:`Generator` for the camera and frame size of ``config`` (kept for the next
    call with the same ones: building its textures and sprites takes seconds, and the
    search's candidates change only the scene settings, which it takes per call)."""
    key = (str(sprites_dir), config.camera, config.fov, config.sensor_px, config.width,
           config.height, config.seed)
    if key not in _GENERATOR:
        _GENERATOR.clear()
        _GENERATOR[key] = Generator(config, sprites_dir, progress=False)
    return _GENERATOR[key]


class Renderer:
    """Renders water-only frames of candidate configs with one :class:`Generator` (the
    compositor's assets do not depend on the scene settings) and measures them; results
    are cached per config."""

    def __init__(self, base: GeneratorConfig, sprites_dir: str | Path | None, n_render: int,
                 mask_sky: bool = False):
        self.base = water_only(base)
        self.gen = water_generator(self.base, sprites_dir)
        self.n_render = n_render
        self.mask_sky = mask_sky  # keep the sky of oblique frames out, as the footage's
        self._cache: dict[str, tuple[dict, dict, list]] = {}

    def measure(self, config: GeneratorConfig, n: int | None = None, start: int = 0
                ) -> tuple[dict, dict, list]:
        """(summary, per_image, first frames) of ``n`` (default ``n_render``) frames of
        ``config`` (objects and clutter off), indices from ``start``."""
        config = water_only(config)
        n = n or self.n_render
        key = f"{sorted(config.to_dict().items())!r}{n}/{start}"
        if key not in self._cache:
            rows, frames = [], []  # type: list[dict[str, float] | None], list[np.ndarray]
            for i in range(start, start + n):
                scene = sample_scene(config, i, self.gen.model)
                rgb = self.render(config, scene)
                rows.append(image_stats(rgb, self._water(scene) if self.mask_sky else None))
                if len(frames) < 4:
                    frames.append(rgb)
            per = stack(rows)
            self._cache[key] = (summary(per), per, frames)
        return self._cache[key]

    @staticmethod
    def _water(scene: Scene) -> np.ndarray | None:
        """(n,) bool grid patches below ``scene``'s horizon (and its margin), None looking
        straight down."""
        if scene.camera.pitch >= 90:
            return None
        m = scene.model
        return empty_water((m.height, m.width), valid=sky_mask(m, scene.camera.pitch))

    def render(self, config: GeneratorConfig, scene: Scene) -> np.ndarray:
        """(H, W, 3) uint8 RGB image of ``scene`` (drawn from ``config``) as its file would
        hold it (a JPEG round trip at the scene's quality for ``image_format`` jpg)."""
        image = self.gen.render_scene(scene).image
        if config.image_format != "jpg":
            return image
        ok, data = cv2.imencode(".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR),
                                [cv2.IMWRITE_JPEG_QUALITY, int(scene.jpeg_quality)])
        decoded = cv2.imdecode(data, cv2.IMREAD_COLOR) if ok else None
        if decoded is None:
            raise RuntimeError(f"could not JPEG-encode a frame of shape {image.shape}")
        return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)


def water_table(r: Renderer, config: GeneratorConfig) -> dict[str, np.ndarray]:
    """{water type: (21, 2) float64 mean (chroma_r, chroma_b) at turbidity 0, 0.05 .. 1}
    rendered under ``config``'s other settings (:data:`TABLE_FRAMES` frames per cell of
    :data:`TABLE_TURBIDITY`, interpolated)."""
    fine = np.linspace(0.0, 1.0, 21)
    out = {}
    for wt in WATER_TYPES:
        cells = []
        for t in TABLE_TURBIDITY:
            _, per, _ = r.measure(with_settings(config, water=(wt,), turbidity=t), TABLE_FRAMES,
                                  start=10_000)
            cells.append([np.nanmean(per["chroma_r"]), np.nanmean(per["chroma_b"])])
        c = np.array(cells)
        out[wt] = np.stack([np.interp(fine, TABLE_TURBIDITY, c[:, k]) for k in (0, 1)], 1)
    return out


def invert_water(table: dict[str, np.ndarray], per_image: dict[str, np.ndarray]
                 ) -> tuple[tuple[str, ...], tuple[float, float], dict, list]:
    """(water types, (turbidity lo, hi), {type: frames closest to it}, the kept frames'
    turbidities) from the footage's per-frame water chromaticity and the colour ``table``
    of :func:`water_table`: each frame takes its nearest (type, turbidity) cell."""
    names = list(table)
    cells = np.stack([table[n] for n in names])  # (types, 21, 2)
    obs = np.stack([per_image["chroma_r"], per_image["chroma_b"]], 1)  # (frames, 2)
    obs = obs[np.all(np.isfinite(obs), axis=1)]
    d = np.linalg.norm(cells[None] - obs[:, None, None], axis=-1)  # (frames, types, 21)
    flat = d.reshape(len(obs), -1).argmin(axis=1)
    kind, step = np.divmod(flat, cells.shape[1])
    votes = {n: int(np.sum(kind == k)) for k, n in enumerate(names)}
    top = max(votes, key=lambda n: votes[n])
    keep = tuple(n for n in names if votes[n] >= TYPE_SHARE * len(obs)) or (top,)
    mask = np.isin(kind, [names.index(n) for n in keep])
    turb = step[mask] / (cells.shape[1] - 1)
    lo, hi = np.percentile(turb, (10, 90))
    lo, hi = max(0.0, lo - 0.05), min(1.0, hi + 0.05)
    return keep, (round(float(lo), 2), round(float(hi), 2)), votes, turb.tolist()


def search(footage: Footage, base: GeneratorConfig, sprites_dir: str | Path | None,
           n_render: int = 16, groups: tuple[str, ...] | None = None, passes: int = 2,
           log: Callable[[str], None] | None = None) -> SearchResult:
    """Fit ``base`` (size and geometry already the footage's) to ``footage``: water by
    colour inversion, then up to ``passes`` rounds of coordinate search over ``groups``
    (default: all of :data:`CANDIDATES`), each followed by the water again under the fitted
    camera and light; a round that changes nothing ends the search. When the footage's
    highlights carry a colour cast (:func:`cast_start`), the search runs again from that
    cast and the closer of the two fits is kept: from the defaults' camera, a green frame
    is explained by green water first, and no single step of the search reaches the cast
    from there."""
    t0 = time.perf_counter()
    say = log or (lambda s: None)
    r = Renderer(base, sprites_dir, n_render, mask_sky=footage.sky_masked)
    default_summary, _, default_frames = r.measure(base)
    trials: list[Trial] = []
    found = _descend(r, base, footage, groups, passes, trials, say)
    start = cast_start(base, footage.summary, default_summary, groups)
    cast = None
    if start is not None:
        gains = {k: float(getattr(start, k).lo) for k in ("wb_red", "wb_blue")}
        say(f"the highlights carry a cast: searching again from white balance red "
            f"{gains['wb_red']:g}, blue {gains['wb_blue']:g}")
        again = _descend(r, start, footage, groups, passes, trials, say)
        losses = [loss(r.measure(f[0])[0], footage.summary) for f in (found, again)]
        cast = {**gains, "loss_defaults": losses[0], "loss_cast": losses[1],
                "kept": "cast" if losses[1] < losses[0] else "defaults"}
        say(f"from the defaults' camera: loss {losses[0]:.3g}; from the cast: "
            f"{losses[1]:.3g}: the fit from the {cast['kept']} is kept")
        if cast["kept"] == "cast":
            found = again
    config, votes, turb = found
    fitted, per, frames = r.measure(config)
    return SearchResult(config, fitted, per, frames, default_summary, default_frames, trials,
                        votes, turb, time.perf_counter() - t0, cast)


def _descend(r: Renderer, config: GeneratorConfig, footage: Footage,
             groups: tuple[str, ...] | None, passes: int, trials: list[Trial],
             say: Callable[[str], None]) -> tuple[GeneratorConfig, dict, list]:
    """The search of :func:`search` from ``config``: (fitted config, the last water
    inversion's votes and turbidities)."""
    config, votes, turb = _fit_water(r, config, footage, say)
    for _ in range(passes):
        start = config
        for group in groups if groups is not None else tuple(CANDIDATES):
            config = _coordinate(r, config, footage, group, trials, say)
        config, votes, turb = _fit_water(r, config, footage, say)
        if config == start:  # a pass that changed nothing: the next would not either
            break
    return config, votes, turb


#: an encoded (sRGB) ratio of channels becomes a linear gain to about this power
ENCODED_GAMMA = 2.2


def cast_start(base: GeneratorConfig, footage: dict, defaults: dict,
               groups: tuple[str, ...] | None) -> GeneratorConfig | None:
    """``base`` with the white balance that tints the defaults' highlights as the
    footage's are tinted, or None when that is no cast (both gains snap to 0.9-1.1), the
    highlights are unknown or white balance is not searched. ``footage`` and ``defaults``
    are :func:`~.stats.summary` dicts: the highlights' (R, B) shares give R/G and B/G
    ratios; the footage's over the defaults', to the power :data:`ENCODED_GAMMA` (the
    highlights are bright: their encoded levels follow a linear gain about so), snapped to
    the nearest candidate gain."""
    if groups is not None and not {"wb_red", "wb_blue"} <= set(groups):
        return None
    ratios = []  # (R/G, B/G) of the footage's highlights, then of the defaults'
    for s in (footage, defaults):
        r, b = s["highlight_r"][1], s["highlight_b"][1]
        g = 1.0 - r - b
        if not all(np.isfinite([r, b, g])) or min(r, b, g) <= 0:
            return None
        ratios.append((r / g, b / g))
    gains = [(f / d) ** ENCODED_GAMMA for f, d in zip(*ratios, strict=True)]
    snapped = []
    for key, gain in zip(("wb_red", "wb_blue"), gains, strict=True):
        values = [c[key] for c in CANDIDATES[key] if c[key] is not None]
        snapped.append(min(values, key=lambda v: abs(math.log(v / gain))))
    if all(0.9 <= g <= 1.1 for g in snapped):
        return None
    return with_settings(base, wb_red=snapped[0], wb_blue=snapped[1])


def _fit_water(r: Renderer, config: GeneratorConfig, footage: Footage,
               say: Callable[[str], None]) -> tuple[GeneratorConfig, dict, list]:
    """``config`` with the water types and turbidity range inverted from the footage's
    colour under its other settings, when its rendered statistics are closer to the
    footage's than ``config``'s (or ``config`` has the defaults' water)."""
    water, (lo, hi), votes, turb = invert_water(water_table(r, config), footage.per_image)
    new = with_settings(config, water=water, turbidity=f"{lo:g}-{hi:g}")
    default = GeneratorConfig()
    if (config.water, config.turbidity) != (default.water, default.turbidity) and loss(
            r.measure(new)[0], footage.summary) >= loss(r.measure(config)[0], footage.summary):
        say("water: kept (the inversion under the fitted camera and light is no closer)")
        return config, votes, turb
    say(f"water: {', '.join(water)}, turbidity {lo:g}-{hi:g} (frames per type {votes})")
    return new, votes, turb


def _coordinate(r: Renderer, config: GeneratorConfig, footage: Footage, group: str,
                trials: list[Trial], say: Callable[[str], None]) -> GeneratorConfig:
    """``config`` with the candidate of ``group`` whose rendered statistics are closest to
    the footage's (the current value wins ties)."""
    best, best_loss = config, loss(r.measure(config)[0], footage.summary)
    for cand in CANDIDATES[group]:
        c = with_settings(config, **cand)
        s = r.measure(c)[0]
        value = loss(s, footage.summary)
        trials.append(Trial(group, cand, value, s))
        if value < best_loss - 1e-9:
            best, best_loss = c, value
    say(f"{group}: {_settings_text(best, group)} (loss {best_loss:.3g})")
    return best


def _settings_text(config: GeneratorConfig, group: str) -> str:
    """The fitted values of one search group, as text."""
    keys = CANDIDATES[group][0].keys()
    return ", ".join(f"{k} {getattr(config, k)}" for k in keys)
