"""Measuring one image set: per-patch statistics of its empty-water patches, classifier
features and luminance spectra (:func:`analyse_set`), and the histogram figure."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np

from . import classifier as clf
from .painted import shrink_valid
from .patches import (
    METRICS,
    concat_stats,
    empty_water,
    image_maps,
    maps_patch_stats,
    summarise,
    to_patches,
)
from .sources import FrameSet, load_frame
from .spectrum import SpectrumAccumulator
from .targets import MEDIAN_TARGETS, REAL_REFERENCE

FEATURE_PATCHES_PER_IMAGE = 48  #: at most this many empty-water patches per image to classify
CNN_PATCHES_PER_IMAGE = 24
UNITS = {"saturation": "0-1", "luminance": "0-255", "highpass_std": "8-bit levels",
         "glint_fraction": "0-1"}


@dataclass
class SetAnalysis:
    """Everything measured on one set.

    ``stats`` {metric: (m,) float64} over all its empty-water patches; ``features`` (k, 45)
    float64 and ``groups`` (k,) int64 image index of (at most FEATURE_PATCHES_PER_IMAGE per
    image of) those patches; ``patches`` (k', 64, 64, 3) uint8 for the CNN or None;
    ``spectrum`` the luminance power spectra; counts and timings."""

    frames: FrameSet
    stats: dict
    features: np.ndarray
    groups: np.ndarray
    patches: np.ndarray | None
    patch_groups: np.ndarray | None
    spectrum: SpectrumAccumulator
    images_read: int = 0
    unreadable: int = 0
    patches_total: int = 0
    patches_empty: int = 0
    valid_how: Counter = field(default_factory=Counter)
    seconds: float = 0.0
    rescaled: int = 0

    def summary(self) -> dict:
        return summarise(self.stats)


def _rescale(rgb, instances, valid, boxes, factor: float):
    """Resample a frame and its masks/boxes by ``factor`` (new pixels per old pixel)."""
    h, w = rgb.shape[:2]
    size = (max(1, round(w * factor)), max(1, round(h * factor)))
    interp = cv2.INTER_AREA if factor < 1 else cv2.INTER_CUBIC
    rgb = cv2.resize(rgb, size, interpolation=interp)
    if instances is not None:
        instances = cv2.resize(instances, size, interpolation=cv2.INTER_NEAREST)
    if valid is not None:  # invalid wherever any pixel it covers is (painted edges)
        valid = shrink_valid(valid, *size)
    if boxes is not None:
        boxes = [[v * factor for v in b[:4]] for b in boxes]
    return rgb, instances, valid, boxes


def analyse_set(frames: FrameSet, seed: int = 0, cnn: bool = False,
                rescale_to: float | None = None, log=None) -> SetAnalysis:
    """Measure every frame of a set: per-patch statistics of its empty-water patches, the
    classifier features of up to :data:`FEATURE_PATCHES_PER_IMAGE` of them per image, their
    luminance spectra; ``rescale_to`` (m/px): first resample frames of known GSD to it."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    parts, feats, groups, cnn_p, cnn_g = [], [], [], [], []
    acc = SpectrumAccumulator()
    out = SetAnalysis(frames, {}, np.zeros((0, 45)), np.zeros(0, np.int64), None, None, acc)
    for n, frame in enumerate(frames.frames):
        loaded = load_frame(frame)
        if loaded is None:
            out.unreadable += 1
            continue
        rgb, inst, valid, boxes = loaded.rgb, loaded.instances, loaded.valid, frame.boxes
        gsd = frame.gsd
        if rescale_to and gsd and abs(gsd / rescale_to - 1) > 1e-3:
            rgb, inst, valid, boxes = _rescale(rgb, inst, valid, boxes, gsd / rescale_to)
            gsd = rescale_to
            out.rescaled += 1
        out.images_read += 1
        out.valid_how[loaded.valid_how] += 1
        keep = empty_water(rgb.shape[:2], inst, boxes, valid)
        out.patches_total += keep.size
        out.patches_empty += int(keep.sum())
        maps = image_maps(rgb)
        parts.append(maps_patch_stats(maps, keep))
        idx = np.flatnonzero(keep)
        if idx.size == 0:
            continue
        sub = np.sort(rng.choice(idx, min(idx.size, FEATURE_PATCHES_PER_IMAGE), replace=False))
        rgb_p = to_patches(rgb)
        feats.append(clf.patch_features(rgb_p[sub], to_patches(maps.hp)[sub]))
        groups.append(np.full(sub.size, frame.group, np.int64))
        acc.add(to_patches(maps.y)[sub], gsd)
        if cnn:
            c = sub[:CNN_PATCHES_PER_IMAGE]
            cnn_p.append(rgb_p[c])
            cnn_g.append(np.full(c.size, frame.group, np.int64))
        if log and (n + 1) % 100 == 0:
            log(f"  {frames.kind}: {n + 1}/{len(frames.frames)} images")
    out.stats = concat_stats(parts)
    if feats:
        out.features, out.groups = np.concatenate(feats), np.concatenate(groups)
    if cnn and cnn_p:
        out.patches, out.patch_groups = np.concatenate(cnn_p), np.concatenate(cnn_g)
    out.seconds = time.perf_counter() - t0
    return out


# --------------------------------------------------------------------------- figures

def plot_histograms(path, generated: SetAnalysis, real: SetAnalysis | None = None) -> None:
    """PNG of the four per-patch metrics: generated vs real histograms (densities) with the
    medians, the target bands and the reference real medians marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for ax, m in zip(axes.ravel(), METRICS, strict=True):
        sets = [("generated", generated.stats[m], "tab:blue")]
        if real is not None and real.stats[m].size:
            sets.append(("real", real.stats[m], "tab:orange"))
        allv = np.concatenate([v for _, v, _ in sets]) if sets else np.zeros(1)
        if allv.size == 0:
            ax.text(0.5, 0.5, "no empty-water patches", ha="center", transform=ax.transAxes)
            continue
        hi = float(np.percentile(allv, 99.5)) if m != "luminance" else 255.0
        lo = 0.0
        if m == "glint_fraction":
            hi = max(hi, 0.01)
        bins = np.linspace(lo, max(hi, lo + 1e-6), 50)
        for name, v, colour in sets:
            if v.size:
                ax.hist(np.clip(v, lo, bins[-1]), bins=bins, density=True, alpha=0.5,
                        color=colour, label=f"{name} (median {np.median(v):.3g}, n={v.size})")
                ax.axvline(float(np.median(v)), color=colour, lw=1.5)
        if m in MEDIAN_TARGETS:
            a, b = MEDIAN_TARGETS[m]
            ax.axvspan(a, b, color="tab:green", alpha=0.12, label="target for the median")
        ax.axvline(REAL_REFERENCE[m]["median"], color="k", ls="--", lw=1,
                   label="reference real median")
        if m == "glint_fraction":
            ax.set_yscale("log")
        ax.set_xlabel(f"{m} ({UNITS[m]})" + ("" if m == "luminance" else
                                              "; last bin: all above the 99.5th percentile"))
        ax.set_ylabel("density")
        ax.legend(fontsize=7)
    fig.suptitle("Per-patch statistics of empty-water 64x64 patches", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
