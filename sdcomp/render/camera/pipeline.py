"""The camera stage: :func:`apply_camera` runs the camera's stages for one
:class:`~sdcomp.scene.look.CameraLook`.

Order (physical, with the fusions that keep it cheap):

1. ``motion``: motion blur along the flight direction (scene light during the exposure);
2. ``lens``: radial distortion + lateral CA + zoom in one resampling (cached maps); the
   instance map and amodal masks follow by nearest neighbour;
3. ``vignetting``: radial linear gain (applied to sRGB levels as ``g^(1/2.2)``);
4. ``photometric``: auto exposure metering, then ONE per-channel table: sRGB -> linear ->
   exposure x white balance -> tone curve (shoulder, flat/log mix, contrast, gamma, black
   lift) -> output levels;
5. ``noise``: shot + read noise of the linear signal, carried through the tone curve's
   slope, fused into step 4 (two float tables, a tile window; see
   :func:`~sdcomp.render.camera.sensor.apply_lut_noise`): first-order equal to adding it before the
   curve;
6. ``demosaic``: at the native scale a real RGGB mosaic + OpenCV demosaicing (plus the
   optics blur), else the equivalent Gaussian blur reduced to the output scale;
7. ``colour``: saturation (luma-preserving 3 x 3, ``cv2.transform``);
8. ``sharpen``: in-camera unsharp mask (halos), reduced by the scale rule;
9. ``compression``: block-DCT quantisation (JPEG proxy of H.264/H.265 at the bitrate's
   bits per pixel, or the photo's JPEG) with deblocking, at native block size;
10. ``grade``: the site grade fitted to the user's footage (:mod:`.grade`), where the look
    names one.

**Scale rule.** The output is the native recording reduced by ``sx = native_width /
out_width``, ``sy = native_height / out_height`` (at least 1). Native-pixel sizes are
divided by the scale (blur sigmas per axis; sharpening via
:func:`~sdcomp.render.camera.scale.scaled_sharpen`; motion length along its direction), noise
sigma is divided by ``sqrt(sx sy)`` (averaging), compression runs on the frame magnified by the
rounded scale so blocks are native-sized, and a stage whose reduced effect falls below its
threshold (:data:`THRESHOLDS`) is skipped: far from the native scale (416 px from 4K) only the
photometric look, the lens geometry, vignetting and long motion blur remain.

**Huge frames** (a side over :data:`HUGE_SIDE` pixels: mosaics, not a camera's frames) get
the point-wise stages only (photometric, noise, saturation, the grade's colour), band by
band in place (a 30000 x 30000 frame is 2.7 GB: no stage may copy it); their geometry stays
the pinhole's.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import cv2
import numpy as np

from ...scene.look import STAGES, CameraLook
from ..effects import blur
from .codec import block_compress, unsharp
from .grade import SiteGrade, apply_colour_grade, apply_grade, load_grade
from .lens import lens_maps
from .photometric import (
    Photometric,
    apply_colour,
    apply_lut,
    colour_matrix,
    exposure_gain,
    mean_luminance,
    photometric_tables,
    thumbnail,
    white_balance_gains,
)
from .remap import remap_image, remap_labels, remap_masks, vignette
from .scale import scaled_blur, scaled_sharpen
from .sensor import DEMOSAIC_SIGMA, apply_lut_noise, demosaic, noise_window, sigma_present, soften

HUGE_SIDE = 8192  # pixels: larger frames get the point-wise stages only, in place
HUGE_BAND_PIXELS = 1 << 22  # huge frames are processed in bands of about this many pixels
#: below these a stage is skipped (output units)
THRESHOLDS = {
    "motion_px": 0.5,  # motion blur length, output px
    "lens_shift_px": 0.05,  # largest distance of a source point from its output pixel
    "ca_px": 0.25,  # lateral CA displacement at the frame corner, output px
    "noise_levels": 0.5,  # largest noise sigma over the frame's levels (thumbnail), levels
    "blur_sigma": 0.15,  # Gaussian sigma, output px (Nyquist response > 0.9)
    "sharpen_amount": 0.03,  # unsharp amount after the scale rule
    "saturation": 0.01,  # |saturation - 1|
    "native_scale": 1.5,  # demosaic through a real Bayer mosaic below this scale
    "compression_scale": 4.0,  # compression is skipped when both sx, sy reach this
}


def apply_camera(image: np.ndarray, instances: np.ndarray, look: CameraLook,
                 noise_tile: np.ndarray | None, amodal: np.ndarray | None = None, *,
                 enabled=None, timings: dict | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict]:
    """The camera's image of a rendered frame.

    Args:
        image: (H, W, 3) uint8 sRGB from the renderer (scene radiance through the sRGB
            curve at the nominal exposure); not modified, except huge frames (see the
            module docstring), which are changed in place and returned with ``instances``
            itself (their geometry is the pinhole's: no copy of gigabytes).
        instances: (H, W) uint16 instance ids (0 = background); not modified.
        look: the image's :class:`CameraLook` (``out_width`` x ``out_height`` must be W x H).
        noise_tile: (nh, nw, 3) uint8 ``128 + 32 N(0, 1)`` tile
            (:func:`~sdcomp.render.camera.sensor.make_noise_tile`), or None (no noise).
        amodal: optional (N, H, W) bool per-object full masks.
        enabled: the stages to run (names in :data:`STAGES`; default all): switches for
            speed. The look's ``off`` stages never run.
        timings: if a dict, seconds spent per step are added to it (keys: stage names,
            ``labels`` for the instance/amodal remap, ``tables`` for building the tables).

    Returns:
        (image (H, W, 3) uint8 RGB, instances (H, W) uint16 moved by the lens geometry,
        amodal (N, H, W) bool moved likewise or None, info): ``info`` says what was applied:
        ``stages`` (names run), ``scale`` (sx, sy), ``zoom`` and ``K`` (3 x 3, the output
        camera's intrinsics: the rendered fx, fy times zoom, principal point at the centre
        in pixel-index coordinates) with ``dist`` (OpenCV k1, k2, p1, p2, k3),
        ``exposure_gain``, ``mean_luminance``, ``noise_sigma_max`` (output levels),
        ``blur_sigma``, ``sharpen`` (amount, sigma), ``jpeg_quality``, ``bpp_target`` (bits
        per native pixel), ``bpp_jpeg`` (measured), ``motion_px`` (output px).
    """
    run = _Run.start(image, instances, look, enabled, timings)
    if max(image.shape[:2]) > HUGE_SIDE:
        out = _huge(image, run, noise_tile)
        return out, instances, None if amodal is None else np.asarray(amodal, bool), \
            run.info
    out = _motion(image, run)
    out, instances, amodal = _lens(out, instances, amodal, run)
    out = _photometric(out, run, noise_tile)
    out = _demosaic(out, run)
    out = _colour(out, run)
    out = _sharpen(out, run)
    out = _compression(out, run)
    out = _grade(out, run)
    if out is image:
        out = image.copy()
    if "lens" not in run.ran:  # always new arrays
        instances = instances.copy()
        amodal = None if amodal is None else np.array(amodal, bool)
    return out, instances, amodal, run.info


@dataclass
class _Run:
    """One call of :func:`apply_camera`: the look, the stages switched on, the scale, what
    ran (``ran``, also ``info["stages"]``), the info dict and the clock."""

    look: CameraLook
    on: set
    sx: float
    sy: float
    ran: list
    info: dict
    clock: _Clock
    width: int
    height: int

    @classmethod
    def start(cls, image: np.ndarray, instances: np.ndarray, look: CameraLook, enabled,
              timings: dict | None) -> _Run:
        h, w = image.shape[:2]
        if (w, h) != (look.out_width, look.out_height):
            raise ValueError(f"image is {w} x {h} but the look is for {look.out_width} x "
                             f"{look.out_height}")
        if instances.shape != (h, w):
            raise ValueError(f"instances {instances.shape} do not match the image {(h, w)}")
        on = set(STAGES if enabled is None else enabled)
        unknown = (on | set(look.off)) - set(STAGES)
        if unknown:
            raise ValueError(f"unknown stages {sorted(unknown)}; use {', '.join(STAGES)}")
        on -= set(look.off)
        sx, sy = look.scale
        ran: list[str] = []
        info: dict = {"stages": ran, "scale": (sx, sy), "zoom": 1.0, "exposure_gain": 1.0,
                      "noise_sigma_max": 0.0, "blur_sigma": 0.0, "bpp_jpeg": 0.0,
                      "jpeg_quality": look.jpeg_quality, "bpp_target": look.target_bpp}
        info["K"] = [[look.fx, 0.0, (w - 1) / 2], [0.0, look.fy, (h - 1) / 2],
                     [0.0, 0.0, 1.0]]
        info["dist"] = [0.0] * 5
        return cls(look, on, sx, sy, ran, info, _Clock(timings), w, h)


def _motion(out: np.ndarray, run: _Run) -> np.ndarray:
    """1. Motion blur along the flight direction, its length in output px."""
    look = run.look
    a = math.radians(look.motion_angle)
    motion = look.motion_px * math.hypot(math.cos(a) / run.sx, math.sin(a) / run.sy)
    run.info["motion_px"] = motion
    if "motion" in run.on and motion >= THRESHOLDS["motion_px"]:
        angle = math.degrees(math.atan2(math.sin(a) / run.sy, math.cos(a) / run.sx))
        out = blur(out, (motion, angle), None)
        run.ran.append("motion")
    run.clock("motion")
    return out


def _lens(out: np.ndarray, instances: np.ndarray, amodal: np.ndarray | None, run: _Run
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """2-3. The lens geometry (distortion, lateral CA, zoom: the labels follow) and
    vignetting."""
    look, on, w, h = run.look, run.on, run.width, run.height
    if "lens" not in on and not ("vignetting" in on and look.vignetting > 0):
        return out, instances, amodal
    corner = math.hypot(w - 1, h - 1) / 2
    ca_r = look.ca_red if abs(look.ca_red) * corner >= THRESHOLDS["ca_px"] else 0.0
    ca_b = look.ca_blue if abs(look.ca_blue) * corner >= THRESHOLDS["ca_px"] else 0.0
    if "lens" not in on:
        ca_r = ca_b = 0.0
    k1, k2 = (look.k1, look.k2) if "lens" in on else (0.0, 0.0)
    lens = lens_maps(w, h, look.fx, look.fy, k1, k2, ca_r, ca_b)
    run.clock("lens_maps")
    if "lens" in on and (lens.max_shift >= THRESHOLDS["lens_shift_px"] or ca_r or ca_b):
        out = remap_image(out, lens)
        run.clock("lens")
        instances = remap_labels(instances, lens)
        if amodal is not None and len(amodal):
            amodal = remap_masks(np.asarray(amodal, bool), lens)
        run.clock("labels")
        z = run.info["zoom"] = lens.zoom
        run.info["K"] = [[look.fx * z, 0.0, (w - 1) / 2], [0.0, look.fy * z, (h - 1) / 2],
                         [0.0, 0.0, 1.0]]
        run.info["dist"] = [look.k1, look.k2, 0.0, 0.0, 0.0]
        run.ran.append("lens")
    if "vignetting" in on and look.vignetting > 0:
        out = vignette(out, lens, look.vignetting)
        run.ran.append("vignetting")
    run.clock("vignetting")
    return out, instances, amodal


def _tables(out: np.ndarray, run: _Run, noise_tile: np.ndarray | None
            ) -> tuple[Photometric, bool]:
    """The photometric table of a frame (metered on its thumbnail) and whether its noise
    is drawn (its largest sigma over the frame's levels reaches the threshold)."""
    look, on = run.look, run.on
    wb = white_balance_gains(look.wb_red, look.wb_blue, look.wb_tint)
    gain = 1.0
    thumb = thumbnail(out)
    if "photometric" in on and (look.ae_strength > 0 or look.exposure_ev != 0):
        run.info["mean_luminance"] = mean_luminance(thumb, wb)
        gain = exposure_gain(run.info["mean_luminance"], look.ae_target, look.ae_strength,
                             look.exposure_ev)
    run.info["exposure_gain"] = gain
    noisy = bool("noise" in on and noise_tile is not None and (look.noise_a or look.noise_b))
    noise = (look.noise_a, look.noise_b, run.sx, run.sy) if noisy else None
    if "photometric" not in on:
        table = photometric_tables(1.0, np.ones(3), 1.0, 0.0, 1.0, 1.0, 0.0, noise, False)
    else:
        table = photometric_tables(gain, wb, look.highlight_knee, look.flat, look.contrast,
                                   look.gamma, look.black_lift, noise, False)
    # the decision uses the levels the frame has (its metering thumbnail), not all 256
    if noisy and table.sigma is not None:
        run.info["noise_sigma_max"] = sigma_present(table.sigma, thumb)
        noisy = run.info["noise_sigma_max"] >= THRESHOLDS["noise_levels"]
    run.clock("tables")
    return table, noisy


def _photometric(out: np.ndarray, run: _Run, noise_tile: np.ndarray | None) -> np.ndarray:
    """4-5. Exposure, white balance and tone curve in one table, with the noise."""
    table, noisy = _tables(out, run, noise_tile)
    look = run.look
    if noisy and noise_tile is not None and table.sigma is not None:
        window = noise_window(noise_tile, run.height, run.width, look.noise_oy, look.noise_ox)
        out = apply_lut_noise(out, table, table.sigma, window)
        run.ran += ["photometric", "noise"] if "photometric" in run.on else ["noise"]
        run.clock("noise")
    elif "photometric" in run.on and not table.identity:
        out = apply_lut(out, table)
        run.ran.append("photometric")
        run.clock("photometric")
    return out


def _demosaic(out: np.ndarray, run: _Run) -> np.ndarray:
    """6. Demosaicing at the native scale, or its softness reduced to the output's."""
    look = run.look
    if "demosaic" not in run.on or look.demosaic == "none":
        return out
    native = max(run.sx, run.sy) < THRESHOLDS["native_scale"]
    if native:
        out = demosaic(out, look.demosaic)
        bx, by = scaled_blur(look.optics_blur, run.sx, run.sy)
    else:
        bx, by = scaled_blur(math.hypot(look.optics_blur, DEMOSAIC_SIGMA), run.sx, run.sy)
    if max(bx, by) >= THRESHOLDS["blur_sigma"]:
        out = soften(out, bx, by)
        run.info["blur_sigma"] = (bx, by)
    if native or run.info["blur_sigma"]:
        run.ran.append("demosaic")
    run.clock("demosaic")
    return out


def _colour(out: np.ndarray, run: _Run) -> np.ndarray:
    """7. Saturation."""
    if "colour" in run.on and abs(run.look.saturation - 1) >= THRESHOLDS["saturation"]:
        out = apply_colour(out, colour_matrix(run.look.saturation))
        run.ran.append("colour")
    run.clock("colour")
    return out


def _sharpen(out: np.ndarray, run: _Run) -> np.ndarray:
    """8. In-camera sharpening."""
    amount, sig = scaled_sharpen(run.look.sharpen_amount, run.look.sharpen_radius, run.sx,
                                 run.sy)
    run.info["sharpen"] = (amount, sig)
    if "sharpen" in run.on and amount >= THRESHOLDS["sharpen_amount"]:
        out = unsharp(out, amount, sig)
        run.ran.append("sharpen")
    run.clock("sharpen")
    return out


def _compression(out: np.ndarray, run: _Run) -> np.ndarray:
    """9. Block compression at native block size."""
    look = run.look
    if ("compression" in run.on and look.jpeg_quality > 0
            and min(run.sx, run.sy) < THRESHOLDS["compression_scale"]):
        out, cinfo = block_compress(out, look.jpeg_quality, look.deblock, run.sx, run.sy)
        run.info["bpp_jpeg"] = cinfo["bpp"]
        run.info["compression_factor"] = cinfo["factor"]
        run.ran.append("compression")
    run.clock("compression")
    return out


def _site_grade(run: _Run) -> SiteGrade | None:
    """The look's site grade when it runs: switched on, named and not the identity."""
    if "grade" not in run.on or run.look.grade is None:
        return None
    grade = load_grade(run.look.grade)
    return None if grade.identity else grade


def _grade(out: np.ndarray, run: _Run) -> np.ndarray:
    """10. The site grade (:mod:`.grade`), where the look has one."""
    grade = _site_grade(run)
    if grade is not None:
        out = apply_grade(out, grade)
        run.ran.append("grade")
    run.clock("grade")
    return out


def _huge(image: np.ndarray, run: _Run, noise_tile: np.ndarray | None) -> np.ndarray:
    """The point-wise stages of a huge frame, in place, band by band of rows."""
    table, noisy = _tables(image, run, noise_tile)
    look = run.look
    sat = "colour" in run.on and abs(look.saturation - 1) >= THRESHOLDS["saturation"]
    lut = "photometric" in run.on and not table.identity
    grade = _site_grade(run)
    rows = max(1, HUGE_BAND_PIXELS // run.width)
    for y in range(0, run.height, rows):
        band = image[y:y + rows]
        if noisy and noise_tile is not None and table.sigma is not None:
            window = noise_window(noise_tile, band.shape[0], run.width, look.noise_oy + y,
                                  look.noise_ox)
            band[:] = apply_lut_noise(band, table, table.sigma, window)
        elif lut:
            cv2.LUT(band, table.lut, dst=band)
        if sat:
            band[:] = apply_colour(band, colour_matrix(look.saturation))
        if grade is not None:
            band[:] = apply_colour_grade(band, grade)
    run.ran += (["photometric"] if lut or (noisy and "photometric" in run.on) else []) + (
        ["noise"] if noisy else []) + (["colour"] if sat else []) + (
        ["grade"] if grade is not None else [])
    run.clock("huge")
    return image


class _Clock:
    """Adds the seconds since the previous call to ``timings[name]`` (no-op without a
    dict)."""

    def __init__(self, timings: dict | None):
        self.timings = timings
        self.last = time.perf_counter() if timings is not None else 0.0

    def __call__(self, name: str) -> None:
        if self.timings is None:
            return
        now = time.perf_counter()
        self.timings[name] = self.timings.get(name, 0.0) + now - self.last
        self.last = now
