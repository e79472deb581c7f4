"""The per-image camera look: every parameter of the camera stage (:mod:`sdcomp.render.camera`).

:func:`sdcomp.scene.look_table.sample_look` draws a :class:`CameraLook` for one image from the
table :data:`sdcomp.scene.look_table.PARAMS`, which declares each parameter once (type, unit,
the value meaning "no effect", help) with its range per preset. Presets (:data:`PRESETS`) are
DJI drone cameras plus ``clean`` (every parameter at its identity value: the camera stage then
returns its input unchanged).

Units used throughout:

- *native pixels*: pixels of the camera's recording (video 3840 x 2160, or the photo); the
  output image is that recording resized to ``out_width`` x ``out_height``. Sizes that are
  physical at the native scale (blur radii, motion length, noise) are given in native pixels
  and converted by the stages with the scale factors ``native / out`` (see
  :func:`scale_factors` and docs/water.md).
- *linear*: scene radiance (or sensor signal) relative to the renderer's full scale: the
  renderer's sRGB level 255 is linear 1.0 at the nominal exposure.
- *normalised image coordinates*: ``(u - cx) / fx``, ``(v - cy) / fy`` (tangent of the
  angle off the optical axis) for the lens model.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields

import numpy as np

# ----------------------------------------------------------------------------- presets


@dataclass(frozen=True)
class Preset:
    """A camera: its name, sensor, recording sizes (pixels) and diagonal field of view
    (degrees) of the photo frame; ``video_size`` is the 16:9 recording made from the full
    sensor width (so the horizontal field of view is the photo's)."""

    title: str
    sensor: str
    photo_size: tuple[int, int]
    video_size: tuple[int, int]
    diagonal_fov: float


PRESETS: dict[str, Preset] = {
    "mavic2pro": Preset("DJI Mavic 2 Pro, Hasselblad L1D-20c (28 mm equiv., f/2.8-11)",
                        '1" CMOS 20 MP (2.4 um pixels)', (5472, 3648), (3840, 2160), 77.0),
    "phantom4pro": Preset("DJI Phantom 4 Pro, FC6310 (24 mm equiv., f/2.8-11)",
                          '1" CMOS 20 MP (2.4 um pixels)', (5472, 3648), (3840, 2160), 84.0),
    "zenmuse-x5": Preset("DJI Matrice + Zenmuse X5, DJI MFT 15 mm f/1.7 (30 mm equiv.)",
                         "Micro Four Thirds 16 MP (3.8 um pixels)", (4608, 3456), (3840, 2160),
                         72.0),
    "clean": Preset("no camera: the renderer's image unchanged", "-", (5472, 3648),
                    (3840, 2160), 77.0),
}
RECORDINGS = ("video", "photo")
#: the camera's stages, in the order they run (:mod:`sdcomp.render.camera.pipeline`)
STAGES = ("motion", "lens", "vignetting", "photometric", "noise", "demosaic", "colour",
          "sharpen", "compression", "grade")

# ----------------------------------------------------------------------------- the table


H265_GAIN = 1.5  # H.265 needs about 1/1.5 of H.264's bits at equal quality

#: JPEG bits per pixel (4:2:0, OpenCV/libjpeg) against quality, the median over sdcomp frames
#: at native scale after the camera's noise stage (tools/measure_bpp.py; NOTES.md)
QUALITY_BPP: tuple[tuple[int, float], ...] = (
    (10, 0.128), (20, 0.131), (30, 0.135), (40, 0.144), (50, 0.167), (60, 0.210),
    (70, 0.300), (75, 0.359), (80, 0.461), (85, 0.611), (90, 0.876), (95, 1.431),
    (100, 4.563))


def quality_for_bpp(bpp: float) -> int:
    """The JPEG quality (1..100) whose median bits per pixel on sdcomp frames at native
    scale (:data:`QUALITY_BPP`) is ``bpp``: log-linear interpolation, clamped."""
    q, b = zip(*QUALITY_BPP, strict=True)
    x = math.log(max(bpp, 1e-6))
    return int(round(float(np.interp(x, np.log(b), q))))


def video_bpp(bitrate_mbps: float, fps: float, width: int, height: int) -> float:
    """Bits per pixel of a video stream: bitrate / (fps x pixels per frame)."""
    return bitrate_mbps * 1e6 / (fps * width * height)


# ----------------------------------------------------------------------------- the look


@dataclass(frozen=True)
class CameraLook:
    """Every parameter of the camera stage for one image (see :data:`PARAMS` for units and
    meaning). Plain floats, ints, strings; :meth:`to_dict` is JSON-able. The first group is
    not drawn: the preset, the recording, its native size, the output size and the output
    focal lengths ``fx``, ``fy`` (pixels) of the rendered pinhole image."""

    preset: str
    recording: str
    native_width: int
    native_height: int
    out_width: int
    out_height: int
    fx: float
    fy: float
    k1: float = 0.0
    k2: float = 0.0
    ca_red: float = 0.0
    ca_blue: float = 0.0
    vignetting: float = 0.0
    motion_px: float = 0.0
    motion_angle: float = 0.0
    ae_strength: float = 0.0
    ae_target: float = 0.18
    exposure_ev: float = 0.0
    wb_red: float = 1.0
    wb_blue: float = 1.0
    wb_tint: float = 1.0
    highlight_knee: float = 1.0
    flat: float = 0.0
    contrast: float = 1.0
    gamma: float = 1.0
    black_lift: float = 0.0
    saturation: float = 1.0
    noise_a: float = 0.0
    noise_b: float = 0.0
    noise_oy: int = 0
    noise_ox: int = 0
    optics_blur: float = 0.0
    demosaic: str = "none"
    sharpen_amount: float = 0.0
    sharpen_radius: float = 1.0
    codec: str = "none"
    bitrate_mbps: float = 0.0
    fps: int = 0
    codec_efficiency: float = 0.0
    jpeg_quality: int = 0
    deblock: float = 0.0
    off: tuple[str, ...] = ()  # stages left out, for speed (the user's --camera-off)
    grade: str | None = None  # the site grade file (--grade), the last stage; None: none

    def to_dict(self) -> dict:
        """The look as a dict of plain JSON values (``grade`` only where there is one)."""
        d = asdict(self)
        if d["grade"] is None:
            del d["grade"]
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=False)

    @classmethod
    def from_dict(cls, d: dict) -> CameraLook:
        names = {f.name for f in fields(cls)}
        values = {k: v for k, v in d.items() if k in names}
        values["off"] = tuple(values.get("off", ()))
        return cls(**values)

    @property
    def scale(self) -> tuple[float, float]:
        """(sx, sy): native pixels per output pixel along x and y, at least 1."""
        return scale_factors(self.native_width, self.native_height, self.out_width,
                             self.out_height)

    @property
    def target_bpp(self) -> float:
        """Bits per native pixel of the recording: the video's, or for photos the median
        JPEG bits per pixel at ``jpeg_quality`` (:data:`QUALITY_BPP`); 0 without
        compression."""
        if self.codec in ("h264", "h265") and self.fps > 0:
            return video_bpp(self.bitrate_mbps, self.fps, self.native_width,
                             self.native_height)
        if self.codec == "jpeg" and self.jpeg_quality > 0:
            q, b = zip(*QUALITY_BPP, strict=True)
            return float(np.exp(np.interp(self.jpeg_quality, q, np.log(b))))
        return 0.0


def scale_factors(native_w: int, native_h: int, out_w: int, out_h: int
                  ) -> tuple[float, float]:
    """(sx, sy) = native / output size per axis, clamped at 1 (an output larger than the
    recording is treated as the native scale)."""
    return max(1.0, native_w / out_w), max(1.0, native_h / out_h)


def native_focal(preset: str, recording: str) -> float:
    """Focal length in native pixels of a preset's recording: from the diagonal field of
    view of the photo frame; the 16:9 video uses the full sensor width, resized."""
    p = PRESETS[preset]
    pw, ph = p.photo_size
    f_photo = math.hypot(pw, ph) / 2 / math.tan(math.radians(p.diagonal_fov) / 2)
    if recording == "photo":
        return f_photo
    return f_photo * p.video_size[0] / pw

