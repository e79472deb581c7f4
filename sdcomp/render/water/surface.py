"""Render the sea (and the sky above the horizon) seen by a pinhole drone camera.

Two steps, so that a caller can light objects (or meter a photo) from the first alone:

1. :func:`view_water`, the **coarse grid** (~32 px cells at 416 px, half-height rows in
   oblique views; the cells grow with the frame): view rays, sea points, pixel footprints
   -> the wave level drawn per pixel (:func:`sdcomp.render.water.geometry.view_plan`) and
   the slope variance left unresolved; long waves (bands too long for the three texture
   layers) and swell; the water-leaving radiance from the IOPs (Gordon et al. 1988) with
   patchy constituents, shallow bottom, cloud shadows; the sky's reflection (exact Fresnel,
   reflected ray of the local long-wave normal, sky blurred by the unresolved roughness),
   haze. Evaluated at the mean normal and at normals tilted by one standard deviation of the
   drawn slopes along the tile's two axes: the differences are the texture's response per
   unit slope code (linearised shading). Then **auto-exposure** (:func:`auto_exposure`) on
   the coarse terms with the expected clipped glitter, and the light a floating object sees
   (:class:`~sdcomp.render.water.coarse.WaterLight`).
2. :func:`draw_water`, **per pixel** (uint8, OpenCV, thread-local scratch buffers): three
   texture layers (level ``l`` at full resolution, ``l + 2`` at 1/4, ``l + 4`` at 1/16;
   straight down: tile crops, one texel per sample; oblique: one remap per run of rows of one
   level, cross-faded at level changes), shaded as ``A + B z`` (smooth colour ``A``, smooth
   per-channel amplitude ``B``, unit texture variable ``z`` along one slope direction per
   image, with the grain of the unresolved facets), whitecaps, glitter (per pixel a compound
   Poisson number of sparkles from the Cox-Munk PDF of the facet slope that mirrors the sun,
   given the pixel's drawn slope), the sky above the horizon.

:func:`render_water` runs both. Nothing random is drawn: per-image offsets come from
``params.seed`` through a hash, so the same (model, pose, params, textures) give the same bytes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...scene.camera import CameraModel, CameraPose, camera_basis
from ...scene.water import WaterParams
from .animate import textures_for
from .base import tick, uniforms
from .coarse import (
    WaterLight,
    auto_exposure,
    build_sky,
    draw_sky,
    sea_terms,
    sky_grid_terms,
    srgb_terms,
    water_light,
)
from .geometry import ViewPlan, view_plan
from .glitter import add_glitter, add_mean_glint
from .layers import wave_layers
from .optics import luminance
from .shading import add_foam, shade_exact, shade_fast
from .sky import Sky
from .textures import N_LEVELS, SET_ANGLES, WaterTextures, pitch
from .waves import WaveState, level_continuous, wave_state

SHADINGS = ("fast", "exact")
VIDEO_MAX_PITCH = 89.99  # degrees: video frames' water is drawn as (barely) oblique views
#: how the sun's glint is drawn: sparkles (compound Poisson per pixel), its smooth mean, or
#: not at all (for comparisons with a glint-free reference)
GLINTS = ("sparkles", "mean", "none")


@dataclass(frozen=True, eq=False)
class WaterView:
    """The coarse terms of one image's water (:func:`view_water`): what :func:`draw_water`
    draws from, with the exposure ``gain`` and the object ``light``."""

    plan: ViewPlan
    altitude: float  # metres
    params: WaterParams
    sky: Sky
    waves: WaveState
    frame: dict  # the tiles' frame: set, x, y, e_u, e_c, flev, fp (see _tile_frame)
    levels_rows: np.ndarray  # (H,) int64 wave level drawn per row
    world_off: np.ndarray  # (2,) metres: where the view lies on the tiles
    noise_off: tuple[int, int]  # pixels: the glitter noise window
    sea: dict  # the sea's coarse terms (sea_terms)
    sky_terms: dict | None  # the sky's, when the horizon is in view
    gain: float  # exposure gain: exposed linear = gain x relative radiance
    light: WaterLight


def view_water(model: CameraModel, pose: CameraPose, params: WaterParams,
               textures: WaterTextures) -> WaterView:
    """The coarse terms, exposure and object light of the sea seen by ``model`` at ``pose``
    (step 1 of the module docstring). Raises ValueError for a view that sees no sea
    (sdcomp's poses always do: at pitch >= 2 degrees the bottom rows look below the
    horizon)."""
    w, h = int(model.width), int(model.height)
    pitch_deg = float(pose.pitch)
    if params.time is not None:  # a video frame: never the straight-down crops, whose one
        # level per image would pop as the altitude wanders across a level boundary and
        # switch paths as the gimbal jitters at 90 degrees; the per-row levels cross-fade
        pitch_deg = min(pitch_deg, VIDEO_MAX_PITCH)
    plan = view_plan(w, h, float(model.fx), float(model.fy), pitch_deg)
    if plan.sea is None:
        raise ValueError(f"a view at pitch {pose.pitch} degrees sees no sea")
    alt = float(pose.altitude)
    basis = camera_basis(pose.pitch, pose.heading)
    sky = build_sky(params, textures)  # (clouds drift with the wind aloft in a video)
    waves = wave_state(params.wind, params.wave_age)
    u = uniforms(params.seed, 0x0FF5E7, 4)
    world_off = np.array([u[0] * 1e4, u[1] * 1e4])
    nn = textures.noise.shape[0]
    span = nn - max(w, h) if max(w, h) < nn else nn
    if params.time is not None:  # sparkles are facets of capillaries that live for
        # tens of milliseconds: a video's frames draw them anew (a window per millisecond)
        u = u[:2] + uniforms(params.seed, 0x0FF5E7 + 1 + int(round(params.time * 1000)), 2)
    noise_off = (int(u[2] * span), int(u[3] * span))
    frame, levels_rows = _tile_frame(plan, pose, alt, basis, params.wind_dir,
                                     params.frame_heading)
    frame["origin"] = np.asarray(params.origin, np.float64)
    frame["video"] = params.time is not None
    textures = textures_for(params, textures, frame["downwind"])
    tick("frame")
    sea = sea_terms(plan, basis, alt, params, sky, textures, waves, frame["e_u"],
                    frame["e_c"], world_off, levels_rows, frame["flev"], frame["fp"])
    tick("sea_terms")
    sky_terms = sky_grid_terms(plan, basis, sky) if plan.sky is not None else None
    tick("sky_terms")
    gain = _exposure(plan, sea, sky_terms, params)
    tick("exposure")
    return WaterView(plan, alt, params, sky, waves, frame, levels_rows, world_off, noise_off,
                     sea, sky_terms, gain, water_light(sky, sea, gain, plan.sea))


def _tile_frame(plan: ViewPlan, pose: CameraPose, alt: float, basis: np.ndarray,
                wind_dir: float, frame_heading: float | None = None
                ) -> tuple[dict, np.ndarray]:
    """The texture frame of a view and the wave level drawn per row (H,) int64.

    The tiles' x axis runs along the image rows (the camera's right); y runs down the image
    straight down, forward (away from the camera) in oblique views. With ``frame_heading``
    (degrees counter-clockwise from world +x) the frame is fixed in the world instead: x at
    that heading, y 90 degrees counter-clockwise from it (``cam_x``, ``cam_y``: the
    camera's own axes, which the layers are sampled along). The wind is drawn in the
    direction set nearest to it in that frame (within 22.5 degrees); ``downwind`` (+1 /
    -1): whether it blows towards +e_u or -e_u. Straight down, tiles are drawn one texel
    per pixel: the level nearest the footprint (its waves scaled by at most 2**0.5)."""
    h = plan.height
    row_geo = plan.row_geometry(alt)
    x_axis = basis[0][:2]
    if plan.nadir:
        y_axis = basis[1][:2]
        fp = max(alt / plan.fx, alt / plan.fy)
        flev = np.full(h, float(np.clip(np.log2(fp / pitch(0)), 0.0, N_LEVELS - 1.0)))
        fp_rows = np.full(h, fp)
        levels_rows = np.full(h, int(round(flev[0])), np.int64)
    else:
        hd = math.radians(pose.heading)
        y_axis = np.array([math.cos(hd), math.sin(hd)])
        fp_rows = np.maximum(row_geo["across"], row_geo["along"])
        flev = np.where(row_geo["ok"],
                        level_continuous(np.where(row_geo["ok"], fp_rows, 1.0)),
                        float(N_LEVELS))
        levels_rows = np.clip(np.ceil(flev - 1e-9), 0, N_LEVELS).astype(np.int64)
    cam_x, cam_y = x_axis, y_axis
    if frame_heading is not None:
        fh = math.radians(frame_heading)
        x_axis = np.array([math.cos(fh), math.sin(fh)])
        y_axis = np.array([-math.sin(fh), math.cos(fh)])
    wind = math.radians(wind_dir)
    ws = np.array([math.cos(wind), math.sin(wind)])
    psi = math.degrees(math.atan2(ws @ y_axis, ws @ x_axis)) % 180.0
    tile_set = int(np.argmin([abs((psi - a + 90.0) % 180.0 - 90.0) for a in SET_ANGLES]))
    th = math.radians(SET_ANGLES[tile_set])
    e_u = math.cos(th) * x_axis + math.sin(th) * y_axis
    e_c = -math.sin(th) * x_axis + math.cos(th) * y_axis
    frame = {"set": tile_set, "x": x_axis, "y": y_axis, "e_u": e_u, "e_c": e_c,
             "flev": flev, "fp": np.where(np.isfinite(fp_rows), fp_rows, 1e3),
             "rows": row_geo, "cam_x": cam_x, "cam_y": cam_y,
             "fixed": frame_heading is not None,
             "downwind": 1.0 if float(ws @ e_u) >= 0 else -1.0}
    return frame, levels_rows


def _exposure(plan: ViewPlan, sea: dict, sky_terms: dict | None, params: WaterParams
              ) -> float:
    """The auto-exposure gain of a view from its coarse sea (and sky) luminances: average
    or centre-weighted metering (``params.metering``). Cameras' evaluative metering
    discounts small specular highlights: the expected clipped glitter counts at half."""
    assert plan.sea is not None
    g = plan.sea
    lum = [luminance(sea["L0"]).ravel()]
    wts = [np.full(lum[0].size, (g.r1 - g.r0) / g.gh)]
    fixed = [0.5 * np.minimum(sea["glint_white"], 1.0).ravel()]
    grids = [g]
    if sky_terms is not None and plan.sky is not None:
        lum.append(luminance(sky_terms["L"]).ravel())
        wts.append(np.full(lum[-1].size, (plan.sky.r1 - plan.sky.r0) / plan.sky.gh))
        fixed.append(np.zeros(lum[-1].size))
        grids.append(plan.sky)
    weights = np.concatenate(wts)
    if params.metering == "centre":
        uv = np.concatenate([np.stack(np.meshgrid(q.u, q.v), -1).reshape(-1, 2)
                             for q in grids])
        r2 = ((uv[:, 0] / plan.width - 0.5) ** 2 + (uv[:, 1] / plan.height - 0.5) ** 2) / 0.5
        weights = weights * np.exp(-r2 / (2 * 0.25 ** 2))
    return auto_exposure(np.concatenate(lum), weights, params.exposure_target,
                         fixed=np.concatenate(fixed))


def draw_water(view: WaterView, textures: WaterTextures, out: np.ndarray | None = None,
               shading: str = "fast", glint: str = "sparkles") -> tuple[np.ndarray, dict]:
    """The pixels of ``view`` (step 2 of the module docstring).

    Args:
        view: the image's :class:`WaterView`.
        textures: the :class:`WaterTextures` it was viewed with.
        out: optional (H, W, 3) uint8 array to draw into (else a new one).
        shading: ``"fast"`` (one slope direction per image; uint8 passes) or ``"exact"``
            (the full linearised response per pixel, float32: a slower reference).
        glint: ``"sparkles"`` (the sun's glitter), ``"mean"`` (its smooth expected
            brightness: cheaper) or ``"none"``.

    Returns:
        (image (H, W, 3) uint8 sRGB after auto-exposure, info dict): ``gain``, ``sea_mask``
        (H, W) bool (the pixel's ray hits the sea), ``water_srgb`` (3,) mean sRGB of the
        sea, ``light``, ``level`` (wave level drawn at the centre row), ``glitter_box`` (x0,
        y0, x1, y1) or None, ``wind_dir_drawn`` (degrees), ``sky``, ``waves``.
    """
    if shading not in SHADINGS:
        raise ValueError(f"shading {shading!r}: use one of {', '.join(SHADINGS)}")
    if glint not in GLINTS:
        raise ValueError(f"glint {glint!r}: use one of {', '.join(GLINTS)}")
    plan, sea, waves, frame = view.plan, view.sea, view.waves, view.frame
    w, h = plan.width, plan.height
    image = out if out is not None else np.empty((h, w, 3), np.uint8)
    r0 = plan.sea_row0
    info: dict = {"gain": view.gain, "glitter_box": None}
    sea_img = image[r0:]
    textures = textures_for(view.params, textures, frame["downwind"])
    layers = wave_layers(plan, textures, view.altitude, frame, view.world_off, frame["rows"])
    tick("textures")
    a_srgb, resp = srgb_terms(sea, view.gain)
    tick("srgb_terms")
    (shade_exact if shading == "exact" else shade_fast)(sea_img, layers, a_srgb, resp, plan,
                                                        waves)
    tick("shade")
    if waves.foam * view.params.foam_scale > 1e-4:
        add_foam(sea_img, layers["a4"], sea, waves, view.gain, a_srgb)
        tick("foam")
    if glint == "sparkles":
        info["glitter_box"] = add_glitter(sea_img, layers, sea, view.gain, plan, textures,
                                          view.noise_off, view.sky, waves, frame["fp"][r0:])
        tick("glitter")
    elif glint == "mean":
        add_mean_glint(sea_img, sea, view.gain, plan)
    info["water_srgb"] = a_srgb.reshape(-1, 3).mean(0)
    if view.sky_terms is not None:
        draw_sky(image[:r0], view.sky_terms, view.gain, plan)
        tick("draw_sky")
    mask = np.zeros((h, w), bool)
    mask[r0:] = True
    e_u = frame["e_u"]
    info.update(sea_mask=mask, level=int(view.levels_rows[min(h - 1, max(r0, h // 2))]),
                wind_dir_drawn=math.degrees(math.atan2(e_u[1], e_u[0])) % 360.0,
                light=view.light, sky=view.sky, waves=waves)
    return image, info


def render_water(model: CameraModel, pose: CameraPose, params: WaterParams,
                 textures: WaterTextures, out: np.ndarray | None = None,
                 shading: str = "fast", glint: str = "sparkles") -> tuple[np.ndarray, dict]:
    """The sea and sky of one image: :func:`view_water` then :func:`draw_water` (see them
    for the arguments and the info dict). ``model``: pixels and focal lengths; ``pose``:
    altitude (m), pitch (degrees, 15..90), heading (degrees)."""
    tick()
    return draw_water(view_water(model, pose, params, textures), textures, out, shading,
                      glint)
