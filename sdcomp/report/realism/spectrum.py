"""Radially averaged power spectrum of the luminance of 64 x 64 patches.

Per patch: its mean is removed, a 2-D Hann window applied, and the power is
``|FFT2(window * (Y - mean))|^2 / sum(window^2)`` (8-bit levels squared per frequency sample:
white noise of variance s^2 gives s^2 at every frequency, so the curve is flat). The 2-D power
is averaged over patches, then over the frequency samples inside log-spaced radial bins, in
cycles per pixel (0.5 = Nyquist; the DC sample and the corners beyond 0.5 are left out) and,
where each image's GSD is known, in cycles per metre (each image's frequencies divided by its
metres per pixel before binning).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

PATCH = 64
PX_BINS = 10  #: log bins in cycles/pixel between 1/64 and 0.5
METRE_BINS = 14


@dataclass
class Spectrum:
    """A radially averaged spectrum: ``centres`` (k,) bin centres (geometric) in ``unit``
    ("cycles/px" or "cycles/m"), ``power`` (k,) mean power (levels^2; NaN where a bin is
    empty), ``samples`` (k,) number of (patch, frequency) samples averaged."""

    centres: np.ndarray
    power: np.ndarray
    samples: np.ndarray
    unit: str


def hann2d(n: int = PATCH) -> np.ndarray:
    """(n, n) float64 separable periodic Hann window."""
    w = np.hanning(n + 1)[:-1]
    return np.outer(w, w)


def radial_frequency(n: int = PATCH) -> np.ndarray:
    """(n, n) float64 radial frequency, cycles per pixel, of the samples of an n x n FFT."""
    f = np.fft.fftfreq(n)
    return np.hypot(f[:, None], f[None, :])


def patch_power(y: np.ndarray) -> np.ndarray:
    """(n, s, s) float64 windowed power spectra of (n, s, s) luminance patches (any real dtype,
    8-bit levels); see the module docstring for the normalisation."""
    y = np.asarray(y, np.float64)
    if y.ndim != 3 or y.shape[1] != y.shape[2]:
        raise ValueError(f"expected (n, s, s) patches, got {y.shape}")
    win = hann2d(y.shape[1])
    d = (y - y.mean(axis=(1, 2), keepdims=True)) * win
    return np.abs(np.fft.fft2(d)) ** 2 / np.sum(win ** 2)


def log_edges(lo: float, hi: float, bins: int) -> np.ndarray:
    """(bins + 1,) log-spaced edges slightly wider than [lo, hi]."""
    return np.geomspace(lo * 0.999, hi * 1.001, bins + 1)


def radial_average(power: np.ndarray, freq: np.ndarray, edges: np.ndarray,
                   weight: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(sum of weight * power, sum of weight) per bin of (s, s) ``power`` at (s, s) ``freq``
    for ``edges`` (k + 1,); samples outside the edges are dropped. Both (k,) float64."""
    idx = np.digitize(freq.ravel(), edges) - 1
    ok = (idx >= 0) & (idx < len(edges) - 1)
    k = len(edges) - 1
    sums = np.bincount(idx[ok], weights=power.ravel()[ok] * weight, minlength=k)
    counts = np.bincount(idx[ok], minlength=k).astype(np.float64) * weight
    return sums, counts


@dataclass
class SpectrumAccumulator:
    """Collects the mean 2-D power of each image's patches; bins them at the end.

    ``add(y_patches, gsd)`` per image, then :meth:`per_pixel` / :meth:`per_metre`."""

    size: int = PATCH
    images: list = field(default_factory=list)  # (mean (s, s) power, patch count, gsd | None)

    def add(self, y_patches: np.ndarray, gsd: float | None = None) -> None:
        """Add one image's (n, s, s) luminance patches (n may be 0) and its GSD (m/px)."""
        if len(y_patches) == 0:
            return
        self.images.append((patch_power(y_patches).mean(axis=0), len(y_patches), gsd))

    @property
    def patches(self) -> int:
        return sum(n for _, n, _ in self.images)

    def per_pixel(self, bins: int = PX_BINS) -> Spectrum:
        """The spectrum in cycles/pixel, every patch weighted equally."""
        edges = log_edges(1.0 / self.size, 0.5, bins)
        freq = radial_frequency(self.size)
        return self._binned(edges, [(p, n, freq) for p, n, _ in self.images], "cycles/px")

    def gsd_range(self) -> tuple[float, float] | None:
        g = [gsd for _, _, gsd in self.images if gsd]
        return (min(g), max(g)) if g else None

    def per_metre(self, edges: np.ndarray | None = None, bins: int = METRE_BINS
                  ) -> Spectrum | None:
        """The spectrum in cycles/metre over the images with a known GSD (None if none);
        ``edges`` default: from the lowest to the highest frequency they sample."""
        rng = self.gsd_range()
        if rng is None:
            return None
        if edges is None:
            edges = log_edges(1.0 / self.size / rng[1], 0.5 / rng[0], bins)
        freq = radial_frequency(self.size)
        items = [(p, n, freq / gsd) for p, n, gsd in self.images if gsd]
        return self._binned(edges, items, "cycles/m")

    @staticmethod
    def _binned(edges: np.ndarray, items: list, unit: str) -> Spectrum:
        k = len(edges) - 1
        sums, counts = np.zeros(k), np.zeros(k)
        for power, n, freq in items:
            s, c = radial_average(power, freq, edges, float(n))
            sums += s
            counts += c
        power = np.divide(sums, counts, out=np.full(k, np.nan), where=counts > 0)
        return Spectrum(np.sqrt(edges[:-1] * edges[1:]), power, counts, unit)


def metre_edges(*accs: SpectrumAccumulator, bins: int = METRE_BINS) -> np.ndarray | None:
    """Common cycles/metre edges covering every accumulator's images (None if no GSD)."""
    ranges = [r for r in (a.gsd_range() for a in accs) if r is not None]
    if not ranges:
        return None
    size = accs[0].size
    lo, hi = min(r[0] for r in ranges), max(r[1] for r in ranges)
    return log_edges(1.0 / size / hi, 0.5 / lo, bins)


def plot_spectra(path, generated: SpectrumAccumulator, real: SpectrumAccumulator | None = None,
                 title: str = "") -> None:
    """Write a PNG: log-log radially averaged power, generated vs real, in cycles/pixel and
    (when GSDs are known) cycles/metre."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    sets = [("generated", generated, "tab:blue")]
    if real is not None and real.patches:
        sets.append(("real", real, "tab:orange"))
    edges = metre_edges(*(a for _, a, _ in sets))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, acc, colour in sets:
        sp = acc.per_pixel()
        axes[0].loglog(sp.centres, sp.power, "o-", color=colour,
                       label=f"{name} ({acc.patches} patches)")
        spm = acc.per_metre(edges) if edges is not None else None
        if spm is not None:
            n_img = sum(1 for _, _, g in acc.images if g)
            axes[1].loglog(spm.centres, spm.power, "o-", color=colour,
                           label=f"{name} ({n_img} images with GSD)")
    axes[0].set_xticks([0.02, 0.05, 0.1, 0.2, 0.5], ["0.02", "0.05", "0.1", "0.2", "0.5"])
    axes[0].set_xlabel("spatial frequency, cycles/pixel")
    axes[1].set_xlabel("spatial frequency, cycles/metre")
    for ax in axes:
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_ylabel("power, 8-bit levels$^2$ per sample")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    if edges is None:
        axes[1].text(0.5, 0.5, "GSD unknown: no cycles/metre spectrum", ha="center",
                     va="center", transform=axes[1].transAxes)
    fig.suptitle(title or "Luminance power spectrum of empty-water 64x64 patches "
                 "(mean removed, Hann window)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
