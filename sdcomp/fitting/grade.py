"""The site grade of ``sdcomp fit``: after the scene settings, the residual mapping from the
fitted generator's water to the footage's (:mod:`sdcomp.render.camera.grade` applies it).

Fitted on empty-water patches of both at the fit's working size, by what the realism
classifier sees (:func:`realism_accuracy`: its cross-validated accuracy telling the
footage's patches from the graded ones, lower is better): a short coordinate search over
the gains of the luma's and the chroma's variation about the water's colour (starting from
the ratio of the footage's median patch variation to the generated one's) with the frames'
median colour moved to the footage's, then the luma's spectrum and the chroma detail
matched band by band where that helps the classifier (:func:`fit_grade`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from ..render.camera.grade import (
    LUMA,
    SPECTRUM_BANDS,
    SPECTRUM_EDGES,
    SiteGrade,
    apply_colour_grade,
    apply_detail_grade,
    apply_grade,
    identity_grade,
)
from ..report.realism.classifier import cross_validate, patch_features
from ..report.realism.patches import PATCH, to_patches
from ..report.realism.spectrum import patch_power, radial_frequency

PATCHES_PER_FRAME = 24  #: empty-water patches kept per frame (a seeded choice)
DETAIL_GAINS = (0.1, 4.0)  #: the fitted detail gains (spectrum, chroma) are limited to these
DETAIL_ROUNDS = 3  #: rounds of the detail gains' fit
BLOCK = 8  #: px: the colour's variation is measured on the means of blocks of this side
#: factors of the luma variation's ratio tried, in order (a tie keeps the earlier)
ALPHA_STEPS = (1.0, 0.8, 1.25, 0.6)
BETA_STEPS = (0.5, 0.75, 1.0, 1.5, 2.0)  #: chroma variation gains tried
ACCURACY_STEP = 0.005  #: a detail stage (and the grade) must lower the accuracy this much
FOLDS = 5  #: cross-validation folds of the classifier
_L = LUMA.astype(np.float64)
#: (3, 3) projections of an RGB deviation onto its luma (the same in every channel) and onto
#: its chroma (what is left: zero luma); ``M = a LUMA_DIRECTION + b CHROMA_PLANE`` scales them
LUMA_DIRECTION = np.outer(np.ones(3), _L)
CHROMA_PLANE = np.eye(3) - LUMA_DIRECTION


def water_patches(rgb: np.ndarray, keep: np.ndarray | None, rng: np.random.Generator,
                  n: int = PATCHES_PER_FRAME) -> np.ndarray:
    """(k, PATCH, PATCH, 3) uint8: up to ``n`` of the grid patches of ``rgb`` (H, W, 3) uint8
    where ``keep`` ((patches,) bool, None = all) is True, a choice drawn from ``rng``."""
    patches = to_patches(rgb)
    idx = np.arange(len(patches)) if keep is None else np.flatnonzero(keep)
    if idx.size > n:
        idx = np.sort(rng.choice(idx, n, replace=False))
    return np.ascontiguousarray(patches[idx]).reshape(-1, PATCH, PATCH, 3)


def luma_spectrum(patches: np.ndarray) -> np.ndarray:
    """(SPECTRUM_BANDS,) float64: the median over ``patches`` (k, P, P, 3) uint8 of their
    luma's mean windowed power (:func:`~sdcomp.report.realism.spectrum.patch_power`) in each
    band of :data:`~sdcomp.render.camera.grade.SPECTRUM_EDGES` (cycles per pixel)."""
    y = patches.astype(np.float32) @ LUMA
    power = patch_power(y).reshape(len(patches), -1)
    idx = np.digitize(radial_frequency(patches.shape[1]).ravel(), SPECTRUM_EDGES) - 1
    bands = [power[:, idx == b].mean(axis=1) for b in range(SPECTRUM_BANDS)]
    return np.median(np.stack(bands, 1), axis=0)


def chroma_detail(patches: np.ndarray) -> float:
    """The median over ``patches`` (k, P, P, 3) uint8 of the standard deviation of their
    chroma's detail: each channel's difference from the luma minus its sigma 2 px blur."""
    out = []
    for px in patches.astype(np.float32):
        c = px - (px @ LUMA)[..., None]
        d = c - cv2.GaussianBlur(c, (0, 0), 2.0, borderType=cv2.BORDER_REFLECT_101)
        out.append(float(d[6:-6, 6:-6].std()))
    return float(np.median(out))


@dataclass
class GradeFit:
    """A fitted grade and how well the realism classifier tells the footage's water from the
    generated water's before (``before``: the fitted scene) and after it (``after``), its
    cross-validated accuracy (0.5: indistinguishable); ``trials`` (what was tried, its
    accuracy) in order."""

    grade: SiteGrade
    before: float
    after: float
    trials: list[tuple[str, float]] = field(default_factory=list)


def fit_grade(generated: np.ndarray, generated_frames: np.ndarray, real: np.ndarray,
              real_frames: np.ndarray, width: int, notes: str = "") -> GradeFit:
    """The grade taking the generated water ``generated`` (k, P, P, 3) uint8 patches to the
    footage's ``real`` (m, P, P, 3) uint8 patches, both at frames ``width`` px wide (the
    detail's scale); ``generated_frames`` (k,) and ``real_frames`` (m,) int say which frame
    each patch is of (at least 2 frames each).

    Chosen by what the realism classifier sees (:func:`realism_accuracy`, lower is better),
    a coordinate search from the patches' statistics: the colour map scales the luma's and
    the chroma's variation about the water's colour by ``alpha`` and ``beta`` (the ratio
    of the footage's median patch variation to the generated one's, then factors of it)
    and moves the frames' median colour to the footage's (a gain per channel would make the
    channels' detail move together, which real footage's do not); then the luma's spectrum
    (per band the square root of the footage's median power over the graded patches') and
    the chroma detail's ratio, each kept only where the classifier does worse with it.
    Deterministic."""
    if len(generated) == 0 or len(real) == 0:
        raise ValueError("the grade needs water patches of both the footage and the "
                         "generated frames")
    score = _Scorer(real, real_frames, generated, generated_frames)
    mx, cx = _frame_moments(generated, generated_frames)
    my, cy = _frame_moments(real, real_frames)
    alpha0 = _ratio(LUMA_DIRECTION, cy, cx)
    beta0 = _ratio(CHROMA_PLANE, cy, cx)

    def colour(alpha: float, beta: float) -> SiteGrade:
        m = alpha * LUMA_DIRECTION + beta * CHROMA_PLANE
        return SiteGrade(m, my - m @ mx, fitted_width=int(width), notes=notes)

    before = score(None, "the fitted scene")
    best, best_acc, alpha = colour(alpha0, 1.0), math.inf, alpha0
    for a in (alpha0 * f for f in ALPHA_STEPS):
        acc = score(colour(a, 1.0), f"luma variation x {a:.2f}")
        if acc < best_acc:
            best, best_acc, alpha = colour(a, 1.0), acc, a
    for beta in sorted({*BETA_STEPS, round(beta0, 2)} - {1.0}):
        acc = score(colour(alpha, beta), f"chroma variation x {beta:.2f}")
        if acc < best_acc:
            best, best_acc = colour(alpha, beta), acc
    gains = _detail_gains(best, generated, real)
    for what, cand in (("luma spectrum", replace(best, spectrum=gains.spectrum)),
                       ("chroma detail", replace(best, chroma=gains.chroma))):
        acc = score(cand, what)
        best, best_acc = (cand, acc) if acc < best_acc - ACCURACY_STEP else (best, best_acc)
    if best_acc >= before - ACCURACY_STEP:  # the grade does not help: none
        best, best_acc = replace(identity_grade(int(width)), notes=notes), before
    return GradeFit(best, before, best_acc, score.trials)


def realism_accuracy(real_features: np.ndarray, real_frames: np.ndarray,
                     patches: np.ndarray, frames: np.ndarray) -> float:
    """The realism classifier's cross-validated accuracy (logistic regression on the 45
    patch features, folds by frame; :mod:`sdcomp.report.realism.classifier`) telling
    patches of the footage (``real_features`` (m, 45), ``real_frames`` (m,)) from
    ``patches`` (k, P, P, 3) uint8 of the frames ``frames`` (k,)."""
    x = np.concatenate([real_features, patch_features(patches)])
    y = np.r_[np.ones(len(real_features)), np.zeros(len(patches))].astype(np.int64)
    groups = np.r_[np.asarray(real_frames), np.asarray(frames) + int(np.max(real_frames)) + 1]
    return cross_validate(x, y, groups, k=FOLDS).accuracy


class _Scorer:
    """:func:`realism_accuracy` of the generated patches through candidate grades, with a
    record of each trial."""

    def __init__(self, real, real_frames, generated, generated_frames):
        self.real = patch_features(real)
        self.real_frames = real_frames
        self.generated, self.frames = generated, generated_frames
        self.trials: list[tuple[str, float]] = []

    def __call__(self, grade: SiteGrade | None, what: str) -> float:
        p = self.generated if grade is None else np.stack(
            [apply_grade(x, grade, 1.0) for x in self.generated])
        acc = realism_accuracy(self.real, self.real_frames, p, self.frames)
        self.trials.append((what, round(acc, 4)))
        return acc


def _ratio(basis: np.ndarray, cov_to: np.ndarray, cov_from: np.ndarray) -> float:
    """The standard deviation of ``cov_to`` over that of ``cov_from`` in the span of the
    projection ``basis`` (3, 3), limited to 1/3-3."""
    to = float(np.trace(basis @ cov_to @ basis.T))
    frm = float(np.trace(basis @ cov_from @ basis.T))
    return float(np.clip(math.sqrt(max(to, 1e-6) / max(frm, 1e-6)), 1 / 3, 3))


def _detail_gains(grade: SiteGrade, generated: np.ndarray, real: np.ndarray) -> SiteGrade:
    """``grade`` with the detail gains that take ``generated`` (through it) to ``real``: per
    band of the luma's spectrum the square root of the power ratio, the chroma detail's
    ratio, iterated (the bands overlap)."""
    graded = np.stack([apply_colour_grade(p, grade) for p in generated])
    target = np.concatenate([np.sqrt(luma_spectrum(real)), [chroma_detail(real)]])
    def with_gains(gains: np.ndarray) -> SiteGrade:
        g = [round(float(v), 4) for v in gains]
        return replace(grade, spectrum=tuple(g[:-1]), chroma=g[-1])

    gains = np.ones(SPECTRUM_BANDS + 1)
    for _ in range(DETAIL_ROUNDS):
        done = np.stack([apply_detail_grade(p, with_gains(gains), 1.0) for p in graded])
        got = np.concatenate([np.sqrt(luma_spectrum(done)), [chroma_detail(done)]])
        gains = np.clip(gains * target / np.maximum(got, 1e-6), *DETAIL_GAINS)
    return with_gains(gains)


def _frame_moments(patches: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((3,) the mean over frames of each frame's median patch colour, (3, 3) the
    element-wise median of the patches' own covariances of their :data:`BLOCK` px block
    means) of ``patches`` (k, P, P, 3) uint8 of the frames ``frames`` (k,) (RGB levels,
    levels squared). Block means: the colour's variation across the water, not its grain
    (the detail gains' part); medians: a few patches with an object the labels do not mark
    (or with no labels, every boat and wake) must not stretch the water's."""
    k, p = patches.shape[:2]
    n = p // BLOCK
    px = patches[:, :n * BLOCK, :n * BLOCK].astype(np.float64).reshape(
        k, n, BLOCK, n, BLOCK, 3).mean(axis=(2, 4)).reshape(k, n * n, 3)
    mean = px.mean(axis=1)  # (k, 3)
    centred = px - mean[:, None]
    cov = np.einsum("kpi,kpj->kij", centred, centred) / max(px.shape[1] - 1, 1)
    frames = np.asarray(frames)
    per_frame = [np.median(mean[frames == f], axis=0) for f in np.unique(frames)]
    return np.mean(per_frame, axis=0), np.median(cov, axis=0)


