"""The site grade: the camera's last stage, a fitted mapping from generated frames to the look
of the user's footage (``sdcomp fit`` learns it, :mod:`sdcomp.fitting.grade`).

A grade is (in this order, on the whole frame: the water and the objects on it, as a real
camera's rendition and the air over the site act on both):

1. **colour**: an affine map of the sRGB levels, ``x -> M x + b`` (3 x 3 ``M``, 3 ``b``):
   the linear map that takes the generated water's colour variation within a frame, as a
   Gaussian, to the footage's (its covariance: the texture's amplitude and how the channels
   move together), and the generated frames' mean colour to the footage's. The spread
   between frames (one site's water, sky and light from frame to frame) is the scene
   settings' job: a map that is the same for every frame cannot widen it, and one fitted to
   the pooled pixels of all frames would stretch every frame's contrast instead;
2. **detail**: the luma's power spectrum reshaped by a zero-phase filter whose gain at
   each of :data:`SPECTRUM_BANDS` log-spaced frequencies (``spectrum``, at the fitted
   frames' scale: a frame ``s = width / fitted_width`` times as wide sees them at ``1 / s``
   the frequency) is the square root of the footage's power over the generated water's
   (interpolated in log frequency, 1 at zero: the colour keeps the mean), and the chroma's
   detail scaled by ``chroma`` (each channel's difference from the luma minus its blur of
   sigma ``2 s``: colour grain, which a video codec's subsampled chroma smooths).

No randomness: the same frame always gets the same grade. Stored as a small JSON file beside
the fitted config (``grade = "FILE"`` in it), read once per process (:func:`load_grade`).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ...errors import UserError
from ...util.colour import LUMA_601
from ...util.files import atomic_write_bytes

FORMAT = "sdcomp-grade-1"  #: the ``format`` field of a grade file
GAIN_RANGE = (0.0, 8.0)  #: detail gains outside this are refused
MIN_GAIN_STEP = 0.03  #: detail gains within this of 1 are not applied
LUMA = LUMA_601  #: Rec. 601 luma weights of the stored image's R, G, B (float32)
SPECTRUM_BANDS = 8  #: frequency bands of the spectrum's gains
#: (SPECTRUM_BANDS + 1,) cycles per fitted pixel: the bands' edges (those of the realism
#: classifier's spectrum features on 64 px patches, sdcomp.report.realism.classifier)
SPECTRUM_EDGES = np.geomspace(1 / 64, 0.5, SPECTRUM_BANDS + 1)
SPECTRUM_CENTRES = np.sqrt(SPECTRUM_EDGES[:-1] * SPECTRUM_EDGES[1:])


@dataclass(frozen=True)
class SiteGrade:
    """A fitted grade (see the module docstring).

    ``matrix`` (3, 3) float64 and ``offset`` (3,) float64 act on sRGB levels 0-255 (RGB
    order); ``spectrum`` (:data:`SPECTRUM_BANDS`,) the luma's gains at
    :data:`SPECTRUM_CENTRES`; ``chroma`` the chroma detail's gain; ``fitted_width`` the frame
    width (px) they were measured at; ``notes`` free text on what it was fitted to (for the
    report)."""

    matrix: np.ndarray
    offset: np.ndarray
    spectrum: tuple[float, ...] = (1.0,) * SPECTRUM_BANDS
    chroma: float = 1.0
    fitted_width: int = 512
    notes: str = ""

    def to_json(self) -> str:
        """The grade as JSON text (the file :func:`save_grade` writes)."""
        return json.dumps({
            "format": FORMAT, "notes": self.notes,
            "matrix": np.round(self.matrix, 6).tolist(),
            "offset": np.round(self.offset, 4).tolist(),
            "detail": {"spectrum": [round(float(g), 4) for g in self.spectrum],
                       "chroma": round(self.chroma, 4),
                       "fitted_width": int(self.fitted_width)}}, indent=1)

    @classmethod
    def from_json(cls, text: str, name: str = "grade") -> SiteGrade:
        """The grade of JSON ``text`` (a :meth:`to_json`); UserError naming ``name`` and the
        bad field otherwise."""
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise UserError(f"{name}: not a grade file (not JSON: {e})") from None
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise UserError(f"{name}: not a grade file (no \"format\": \"{FORMAT}\"); make one "
                            f"with sdcomp fit")
        try:
            matrix = np.array(d["matrix"], np.float64)
            offset = np.array(d["offset"], np.float64)
            detail = d.get("detail", {})
            spectrum = tuple(float(g) for g in detail.get("spectrum", (1.0,) * SPECTRUM_BANDS))
            chroma = float(detail.get("chroma", 1.0))
            width = int(detail.get("fitted_width", 512))
        except (KeyError, TypeError, ValueError) as e:
            raise UserError(f"{name}: a grade field is missing or not numbers ({e}); make "
                            f"the file again with sdcomp fit") from None
        checks = ((matrix.shape == (3, 3), "matrix must be 3 x 3"),
                  (offset.shape == (3,), "offset must be 3 numbers"),
                  (bool(np.all(np.isfinite(matrix)) and np.all(np.isfinite(offset))),
                   "matrix and offset must be finite"),
                  (len(spectrum) == SPECTRUM_BANDS,
                   f"detail spectrum must be {SPECTRUM_BANDS} gains"),
                  (all(GAIN_RANGE[0] <= g <= GAIN_RANGE[1] for g in (*spectrum, chroma)),
                   f"detail gains must be {GAIN_RANGE[0]:g}-{GAIN_RANGE[1]:g}"),
                  (width >= 1, "detail fitted_width must be a positive number of pixels"))
        for ok, what in checks:
            if not ok:
                raise UserError(f"{name}: {what}")
        return cls(matrix, offset, spectrum, chroma, width, str(d.get("notes", "")))

    @property
    def identity(self) -> bool:
        """True when the grade changes nothing."""
        return (np.allclose(self.matrix, np.eye(3)) and np.allclose(self.offset, 0)
                and max(abs(g - 1) for g in (*self.spectrum, self.chroma)) < MIN_GAIN_STEP)


def identity_grade(width: int = 512) -> SiteGrade:
    """The grade that changes nothing."""
    return SiteGrade(np.eye(3), np.zeros(3), fitted_width=width)


def apply_colour_grade(image: np.ndarray, grade: SiteGrade) -> np.ndarray:
    """(H, W, 3) uint8 RGB ``image`` through the grade's affine map (a new array)."""
    m = np.concatenate([grade.matrix, grade.offset[:, None]], 1).astype(np.float32)
    return cv2.transform(image, m)  # uint8 in, uint8 out (rounded, saturated)


def apply_detail_grade(image: np.ndarray, grade: SiteGrade, scale: float | None = None
                       ) -> np.ndarray:
    """(H, W, 3) uint8 ``image`` with its luma's spectrum and its chroma's detail reshaped
    by the grade's gains, ``scale`` the image's pixels per fitted pixel (default: its width
    over the fitted width); ``image`` itself when every gain is within
    :data:`MIN_GAIN_STEP` of 1. The luma filter runs as one DFT of the frame padded by
    reflection (no wrap-around at its borders)."""
    gains = tuple(float(g) for g in grade.spectrum)
    spectral = max(abs(g - 1) for g in gains) >= MIN_GAIN_STEP
    gc = grade.chroma - 1.0
    if not spectral and abs(gc) < MIN_GAIN_STEP:
        return image
    s = scale if scale is not None else max(image.shape[1] / max(grade.fitted_width, 1), 0.3)
    x = image.astype(np.float32)
    y = x @ LUMA
    out = x
    if spectral:
        out = x + (filter_luma(y, gains, s) - y)[..., None]
    if abs(gc) >= MIN_GAIN_STEP:
        c = x - y[..., None]  # each channel's difference from the luma
        out = out + np.float32(gc) * (c - cv2.GaussianBlur(c, (0, 0), 2.0 * s))
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def filter_luma(y: np.ndarray, gains: tuple[float, ...], scale: float) -> np.ndarray:
    """(H, W) float32 luma ``y`` through the zero-phase filter of :func:`response`."""
    h, w = y.shape
    pad = int(min(max(8, round(32 * scale)), h - 1, w - 1))
    big = cv2.copyMakeBorder(y, pad, pad, pad, pad, cv2.BORDER_REFLECT_101)
    ph, pw = cv2.getOptimalDFTSize(big.shape[0]), cv2.getOptimalDFTSize(big.shape[1])
    big = cv2.copyMakeBorder(big, 0, ph - big.shape[0], 0, pw - big.shape[1],
                             cv2.BORDER_REFLECT_101)
    spec = cv2.dft(big, flags=cv2.DFT_COMPLEX_OUTPUT)
    spec *= response(ph, pw, gains, round(scale, 6))[..., None]
    back = cv2.idft(spec, flags=cv2.DFT_SCALE | cv2.DFT_REAL_OUTPUT)
    return back[pad:pad + h, pad:pad + w]


@functools.lru_cache(maxsize=4)
def response(h: int, w: int, gains: tuple[float, ...], scale: float) -> np.ndarray:
    """(h, w) float32 gain of an h x w DFT's samples: :data:`SPECTRUM_CENTRES` (cycles per
    fitted pixel, ``scale`` image pixels each) get ``gains``, interpolated in log frequency
    between them, 1 at zero frequency (tapering below the lowest centre), the highest gain
    beyond the highest."""
    f = np.hypot(np.fft.fftfreq(h)[:, None], np.fft.fftfreq(w)[None, :]) * scale
    logf = np.log(np.maximum(f, 1e-6))
    knots = np.log(np.concatenate([[SPECTRUM_CENTRES[0] / 4], SPECTRUM_CENTRES]))
    values = np.log(np.maximum(np.concatenate([[1.0], gains]), 1e-3))
    return np.exp(np.interp(logf, knots, values)).astype(np.float32)


def apply_grade(image: np.ndarray, grade: SiteGrade, scale: float | None = None
                ) -> np.ndarray:
    """(H, W, 3) uint8 RGB ``image`` through ``grade``: colour, then detail (``scale`` as
    :func:`apply_detail_grade`; a new array)."""
    out = apply_colour_grade(image, grade)
    return apply_detail_grade(out, grade, scale)


def save_grade(grade: SiteGrade, path: str | Path) -> None:
    """Write ``grade`` to ``path`` as JSON, atomically."""
    atomic_write_bytes(path, (grade.to_json() + "\n").encode())


def load_grade(path: str | Path) -> SiteGrade:
    """The grade in the file at ``path`` (read once per process while the file is
    unchanged); UserError naming the file when it cannot be used."""
    p = Path(path)
    try:
        stat = p.stat()
    except OSError:
        raise UserError(f"grade {p}: no such file (the config's grade = ...: a file sdcomp fit "
                        f"wrote beside it)") from None
    return _load(str(p), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=8)
def _load(path: str, mtime_ns: int, size: int) -> SiteGrade:
    """:func:`load_grade` of a file at one modification time and size (the cache key)."""
    del mtime_ns, size
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise UserError(f"grade {path}: cannot be read ({e})") from None
    return SiteGrade.from_json(text, f"grade {path}")
