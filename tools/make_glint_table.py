"""Build sdcomp/render/water/data/glint_table.npy (run from the repository root:
``python tools/make_glint_table.py``): quantiles of the glint of one pixel, in sparkle
quanta: S = sum of K sparkle intensities, K ~ Poisson(lam), intensities Pareto(alpha = 1.5)
with mean 1 (compound Poisson). Row r: ln(lam) = -9 + r / 4 (65 rows); column c: the value
exceeded with probability 10**(-6 c / 255) (256 columns). Monte Carlo (1e6 draws) where the
probability is resolved, the single-big-jump tail ``lam_eff (x_m / (s - mean))**alpha`` of
subexponential sums beyond."""
from pathlib import Path

import numpy as np

TABLE = Path(__file__).resolve().parent.parent / "sdcomp/render/water/data/glint_table.npy"

ALPHA = 1.5
XM = (ALPHA - 1) / ALPHA
ROWS, COLS, DECADES = 65, 256, 6.0
N = 1_000_000


def table(seed: int = 0) -> np.ndarray:
    """The (65, 256) float32 table (see the module docstring), a function of ``seed``."""
    rng = np.random.default_rng(seed)
    p = 10.0 ** (-DECADES * np.arange(COLS) / (COLS - 1))  # exceedance probabilities
    out = np.zeros((ROWS, COLS), np.float64)
    for r in range(ROWS):
        lam = float(np.exp(-9 + r / 4))
        k = rng.poisson(lam, N)
        tot = np.zeros(N)
        kmax = int(k.max())
        if lam <= 60:
            for j in range(kmax):  # add the j-th sparkle to every draw that has one
                sel = k > j
                tot[sel] += XM * (1 - rng.random(int(sel.sum()))) ** (-1 / ALPHA)
        else:  # many sparkles: the bulk is normal around lam; tails from the big jump
            tot = lam + np.sqrt(lam) * rng.standard_normal(N) * 1.7
        srt = np.sort(tot)
        lam_eff = 1 - np.exp(-lam)
        for c in range(COLS):
            if p[c] >= 20.0 / N:
                out[r, c] = srt[min(N - 1, int((1 - p[c]) * N))]
            elif p[c] < lam_eff:
                base = lam if lam > 1 else 0.0
                out[r, c] = base + XM * (lam_eff / p[c]) ** (1 / ALPHA)
        out[r] = np.maximum.accumulate(out[r])
    return out.astype(np.float32)


if __name__ == "__main__":
    t = table()
    np.save(TABLE, t)
    print(t.shape, t[[0, 16, 36, 48, 64]][:, [0, 64, 128, 192, 255]])
