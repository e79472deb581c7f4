"""The camera look's parameters, each declared once with its range per preset, and the draw
of one image's :class:`~sdcomp.scene.look.CameraLook` (:func:`sample_look`).

A :class:`LookParam` has a kind, unit, identity value (no effect: the ``clean`` preset's),
help text, and a :class:`Range` per preset (key ``*``: every camera preset without its own).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from .look import (
    H265_GAIN,
    PRESETS,
    RECORDINGS,
    CameraLook,
    native_focal,
    quality_for_bpp,
    video_bpp,
)
from .params import Param


@dataclass(frozen=True)
class Range:
    """How a parameter is drawn for one preset.

    ``dist``: ``uniform`` on [lo, hi], ``log`` (log-uniform, lo > 0), ``tri`` (triangular
    with its peak at ``mode``) or ``choice`` (one of ``choices``, probabilities ``weights``
    or equal). ``p_off``: probability that the parameter takes its identity value (the
    effect is off in this image). ``step``: drawn values are rounded to multiples of it
    (lens parameters: so cached remap maps are reused)."""

    lo: float = 0.0
    hi: float = 0.0
    dist: str = "uniform"
    mode: float | None = None
    p_off: float = 0.0
    step: float = 0.0
    choices: tuple = ()
    weights: tuple = ()


def fixed(value) -> Range:
    """A range that always gives ``value``."""
    if isinstance(value, str):
        return Range(dist="choice", choices=(value,))
    return Range(value, value)


@dataclass(frozen=True)
class LookParam:
    """One parameter of :class:`CameraLook`: ``kind`` (float, int or choice), ``unit``,
    ``identity`` (the value with no effect: the ``clean`` preset's), ``help``, and its
    ``ranges`` per preset (key ``*``: every camera preset without its own entry)."""

    kind: str
    unit: str
    identity: object
    help: str
    ranges: dict[str, Range] = field(default_factory=dict)

    def range_for(self, preset: str) -> Range:
        if preset == "clean":
            return fixed(self.identity)
        return self.ranges.get(preset, self.ranges["*"])


P = LookParam


R = Range


#: every sampled parameter, declared once, in the order drawn (see NOTES.md for the reasons
#: behind the ranges). Values at the identity switch the stage off.
PARAMS: dict[str, LookParam] = {
    # ---- lens: Brown-Conrady radial distortion, lateral CA, vignetting
    "k1": P("float", "", 0.0,
            "radial distortion r^2 coefficient (negative: barrel), normalised coordinates",
            {"*": R(-0.03, -0.01, step=0.01),
             "phantom4pro": R(-0.04, -0.02, step=0.01),
             "zenmuse-x5": R(-0.06, -0.02, step=0.01)}),
    "k2": P("float", "", 0.0, "radial distortion r^4 coefficient",
            {"*": R(0.0, 0.01, step=0.01)}),
    "ca_red": P("float", "", 0.0,
                "lateral chromatic aberration: red image scale - 1 (relative to green)",
                {"*": R(0.0, 6e-4, step=2e-4), "zenmuse-x5": R(2e-4, 1e-3, step=2e-4)}),
    "ca_blue": P("float", "", 0.0, "lateral chromatic aberration: blue image scale - 1",
                 {"*": R(-6e-4, 0.0, step=2e-4), "zenmuse-x5": R(-1e-3, -2e-4, step=2e-4)}),
    "vignetting": P("float", "", 0.0,
                    "vignetting strength s: linear gain 1 - s (1 - cos^4 theta), theta the "
                    "field angle (residual after in-camera correction)",
                    {"*": R(0.05, 0.45, step=0.05), "zenmuse-x5": R(0.1, 0.6, step=0.05)}),
    # ---- motion blur (flight direction), native pixels
    "motion_px": P("float", "native px", 0.0,
                   "motion blur length (ground speed x shutter time / GSD); 0: none",
                   {"*": R(1.0, 30.0, "log", p_off=0.5)}),
    "motion_angle": P("float", "degrees", 0.0,
                      "motion blur direction in the image, from +x towards +y (rows down)",
                      {"*": R(0.0, 180.0)}),
    # ---- photometric: exposure, white balance, tone curve, colour
    "ae_strength": P("float", "", 0.0,
                     "auto exposure: 1 scales the metered mean luminance to ae_target, 0 "
                     "keeps the renderer's nominal exposure (gain (target/mean)^strength)",
                     {"*": R(0.3, 1.0)}),
    "ae_target": P("float", "linear", 0.18, "auto exposure target: mean linear luminance",
                   {"*": R(0.10, 0.32, "log")}),
    "exposure_ev": P("float", "stops", 0.0,
                     "exposure bias on top of auto exposure (compensation, metering error)",
                     {"*": R(-1.3, 1.3, "tri", mode=0.0)}),
    "wb_red": P("float", "", 1.0, "white balance gain of red (linear; colour cast)",
                {"*": R(0.75, 1.33, "tri", mode=1.0)}),
    "wb_blue": P("float", "", 1.0, "white balance gain of blue (linear)",
                 {"*": R(0.75, 1.33, "tri", mode=1.0)}),
    "wb_tint": P("float", "", 1.0, "green gain (green-magenta tint, linear)",
                 {"*": R(0.93, 1.07, "tri", mode=1.0)}),
    "highlight_knee": P("float", "linear", 1.0,
                        "tone curve shoulder: linear values above it are compressed "
                        "smoothly towards white (1: hard clip at 1)",
                        {"*": R(0.6, 1.0)}),
    "flat": P("float", "", 0.0,
              "flat (log-like, D-Cinelike-style) profile mix: 0 the sRGB-like curve, 1 "
              "0.08 + 0.92 log(1 + 35 x) / log(141) (lifted black, dull white, headroom)",
              {"*": R(0.2, 1.0, p_off=0.7)}),
    "contrast": P("float", "", 1.0,
                  "S-curve about the encoded mid value 0.5: p(V) / (p(V) + p(1 - V)), p ~ V^c "
                  "with a finite slope at 0 (stages.soft_pow)",
                  {"*": R(0.75, 1.5, "tri", mode=1.15)}),
    "gamma": P("float", "", 1.0,
               "encoded value power ~V^gamma (>1 darker mid-tones; stages.soft_pow)",
               {"*": R(0.75, 1.35, "tri", mode=1.0)}),
    "black_lift": P("float", "", 0.0, "encoded black level lift b: b + (1 - b) V (haze, flat)",
                    {"*": R(0.0, 0.06, p_off=0.6)}),
    "saturation": P("float", "", 1.0, "saturation about Rec.709 luma of the encoded values",
                    {"*": R(0.55, 1.35, "tri", mode=1.0)}),
    # ---- sensor noise (native scale, linear units of the output signal)
    "noise_a": P("float", "linear", 0.0,
                 "shot noise: variance a x of a linear signal x (about 1 / full-well e- "
                 "x ISO gain)",
                 {"*": R(4e-5, 6e-4, "log"), "zenmuse-x5": R(2.5e-5, 4e-4, "log")}),
    "noise_b": P("float", "linear^2", 0.0, "read noise variance (black level noise)",
                 {"*": R(1e-7, 2e-6, "log"), "zenmuse-x5": R(6e-8, 1.2e-6, "log")}),
    "noise_oy": P("int", "px", 0, "row offset of the window into the noise tile",
                  {"*": R(0, 2**31 - 1)}),
    "noise_ox": P("int", "px", 0, "column offset of the window into the noise tile",
                  {"*": R(0, 2**31 - 1)}),
    # ---- optics softness, demosaicing, sharpening
    "optics_blur": P("float", "native px", 0.0,
                     "Gaussian sigma of lens + anti-aliasing softness before demosaicing",
                     {"*": R(0.3, 0.7)}),
    "demosaic": P("choice", "", "none",
                  "demosaicing at the native scale: OpenCV bilinear, edge-aware (EA) or VNG",
                  {"*": R(dist="choice", choices=("bilinear", "ea"))}),
    "sharpen_amount": P("float", "", 0.0, "in-camera unsharp mask amount (halo strength)",
                        {"*": R(0.3, 1.2)}),
    "sharpen_radius": P("float", "native px", 1.0, "unsharp mask Gaussian sigma",
                        {"*": R(0.7, 1.6)}),
    # ---- compression
    "codec": P("choice", "", "none", "recording codec (photo: jpeg)",
               {"*": R(dist="choice", choices=("h264", "h265")),
                "zenmuse-x5": fixed("h264")}),
    "bitrate_mbps": P("float", "Mbit/s", 0.0, "video bitrate (average)",
                      {"*": R(70.0, 100.0), "zenmuse-x5": R(40.0, 60.0)}),
    "fps": P("int", "1/s", 0, "video frame rate",
             {"*": R(dist="choice", choices=(24, 25, 30)),
              "phantom4pro": R(dist="choice", choices=(24, 25, 30, 48, 50, 60))}),
    "codec_efficiency": P("float", "", 0.0,
                          "JPEG bits needed per video-codec bit at equal quality "
                          "(inter prediction, better transforms); drawn per codec",
                          {"*": R(1.5, 3.0)}),
    "jpeg_quality": P("int", "", 0,
                      "JPEG quality of the compression proxy (photo: drawn; video: from the "
                      "bits per pixel, see quality_for_bpp); 0: no compression",
                      {"*": R(88, 96)}),
    "deblock": P("float", "", 0.0,
                 "in-loop deblocking strength (H.264/H.265 smoothing across 8 px block "
                 "edges; 0 for photos)", {"*": R(0.3, 0.8)}),
}


def _draw(spec: LookParam, rng_: Range, rng: np.random.Generator):
    """One value of ``spec`` from ``rng_``; always consumes two uniforms (so adding or
    changing a range does not shift the draws of the parameters after it)."""
    u_off, u = rng.random(2)
    if rng_.dist == "choice":
        ch = rng_.choices
        w = np.asarray(rng_.weights or [1.0] * len(ch), float)
        k = int(np.searchsorted(np.cumsum(w / w.sum()), u, side="right"))
        return ch[min(k, len(ch) - 1)]
    if u_off < rng_.p_off:
        return spec.identity
    lo, hi = float(rng_.lo), float(rng_.hi)
    if rng_.dist == "log":
        v = math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo)))
    elif rng_.dist == "tri":
        m = lo if rng_.mode is None else float(rng_.mode)
        c = (m - lo) / (hi - lo) if hi > lo else 0.5
        v = lo + math.sqrt(u * c) * (hi - lo) if u < c else hi - math.sqrt(
            (1 - u) * (1 - c)) * (hi - lo)
    else:
        v = lo + u * (hi - lo)
    if rng_.step > 0:
        v = round(round(v / rng_.step) * rng_.step, 10)
    if spec.kind == "int":
        return int(min(math.floor(lo + u * (hi - lo + 1)), hi))
    return float(v)


def sample_look(preset: str, rng: np.random.Generator, out_w: int, out_h: int, *,
                recording: str = "video", fx: float | None = None,
                fy: float | None = None, motion: float | None = None,
                overrides: Mapping[str, Param | None] | None = None) -> CameraLook:
    """Draw the camera look of one image.

    Args:
        preset: a key of :data:`PRESETS` (``clean``: every effect off).
        rng: the image's random generator (consumed: 2 uniforms per parameter).
        out_w, out_h: output (rendered) image size, pixels.
        recording: ``video`` (native 3840 x 2160, H.264/H.265 at the preset's bitrate) or
            ``photo`` (native photo size, JPEG).
        fx, fy: focal lengths of the rendered image, output pixels (the renderer's camera);
            default: the preset's field of view with its recording resized to the output.
        motion: probability of motion blur (default: the preset's).
        overrides: parameters drawn from the user's :class:`Param` (a value, a uniform
            range or a list) instead of the preset's range, whatever the preset (None:
            the preset's); the same uniforms are consumed.

    Returns:
        A :class:`CameraLook`; ``jpeg_quality`` of a video is derived from its bits per
        pixel (``bitrate / (fps x native pixels)`` x ``codec_efficiency`` (x 1.5 for H.265)
        through :func:`quality_for_bpp`).
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown camera preset {preset!r}; use one of {', '.join(PRESETS)}")
    if recording not in RECORDINGS:
        raise ValueError(f"recording {recording!r}: use video or photo")
    p = PRESETS[preset]
    nw, nh = p.video_size if recording == "video" else p.photo_size
    f_native = native_focal(preset, recording)
    fx = float(fx) if fx is not None else f_native * out_w / nw
    fy = float(fy) if fy is not None else f_native * out_h / nh
    ranges = {name: spec.range_for(preset) for name, spec in PARAMS.items()}
    if motion is not None and preset != "clean":
        ranges["motion_px"] = replace(ranges["motion_px"], p_off=1.0 - float(motion))
    for name, param in (overrides or {}).items():
        if param is not None:
            ranges[name] = (Range(dist="choice", choices=param.choices) if param.choices
                            else Range(param.lo, param.hi))
    values = {name: _draw(spec, ranges[name], rng) for name, spec in PARAMS.items()}
    if preset != "clean":
        if recording == "photo":
            values.update(codec="jpeg", bitrate_mbps=0.0, fps=0, codec_efficiency=0.0,
                          deblock=0.0, motion_px=values["motion_px"] * 0.5)
        else:
            eff = values["codec_efficiency"] * (H265_GAIN if values["codec"] == "h265" else 1)
            values["codec_efficiency"] = round(eff, 6)
            bpp = video_bpp(values["bitrate_mbps"], values["fps"], nw, nh)
            values["jpeg_quality"] = quality_for_bpp(bpp * eff)
    return CameraLook(preset=preset, recording=recording, native_width=nw, native_height=nh,
                      out_width=int(out_w), out_height=int(out_h), fx=fx, fy=fy, **values)


def clean_look(out_w: int, out_h: int, fx: float = 1.0, fy: float = 1.0) -> CameraLook:
    """The identity look (no effect) of an ``out_w`` x ``out_h`` image."""
    p = PRESETS["clean"]
    return CameraLook("clean", "video", p.video_size[0], p.video_size[1], out_w, out_h, fx, fy)


def param_table() -> list[dict]:
    """The parameter table as rows (name, kind, unit, identity, help, range per preset):
    for NOTES.md and ``--help``-style listings."""
    rows = []
    for name, spec in PARAMS.items():
        row = {"name": name, "kind": spec.kind, "unit": spec.unit,
               "identity": spec.identity, "help": spec.help}
        for preset in PRESETS:
            if preset != "clean":
                row[preset] = _describe(spec.range_for(preset))
        rows.append(row)
    return rows


def _describe(r: Range) -> str:
    if r.dist == "choice":
        return "{" + ", ".join(str(c) for c in r.choices) + "}"
    if r.lo == r.hi:
        return f"{r.lo:g}"
    s = f"{r.lo:g}..{r.hi:g}"
    if r.dist == "log":
        s += " log"
    elif r.dist == "tri":
        s += f" tri@{r.mode:g}"
    if r.step:
        s += f" step {r.step:g}"
    if r.p_off:
        s += f", off {r.p_off:.0%}"
    return s
