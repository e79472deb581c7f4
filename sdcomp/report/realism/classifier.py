"""Real-vs-synthetic patch classifier: its cross-validated accuracy is the realism number
(0.5 = the two sets cannot be told apart from these features; 1.0 = always can).

- Features (:func:`patch_features`): 45 numbers per 64 x 64 RGB patch: colour means and stds
  in RGB, HSV and CIELAB, luminance, high-pass std and |high-pass| percentiles, glint / bright /
  dark fractions, 8 log power-spectrum bins, gradient statistics and orientation coherence.
- Model: L2-regularised logistic regression fitted by Newton's method (IRLS) in numpy, on
  features standardised with the training fold's mean and std, classes weighted equally.
- Evaluation (:func:`cross_validate`): classes balanced first (the larger set subsampled to
  the smaller's patch count), k folds split BY IMAGE (all patches of an image are in one fold),
  accuracy over the out-of-fold predictions, with a Wilson 95 % interval on the patch count and
  a cluster-bootstrap 95 % interval over images (patches of one image are correlated, so the
  second is the honest one), and the most discriminative features (largest standardised
  weights of a fit on all the data).
- Optional (:func:`cross_validate_cnn`, only if torch imports): a tiny CNN on the raw patches
  with the same folds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from .patches import LUMA
from .spectrum import log_edges, patch_power, radial_frequency

SPEC_BINS = 8


def feature_names() -> list[str]:
    """The names of the columns of :func:`patch_features`, in order."""
    names = [f"{c}_{s}" for c in ("R", "G", "B") for s in ("mean", "std")]
    names += ["hsv_S_mean", "hsv_S_std", "hsv_V_mean", "hsv_V_std", "hue_cos", "hue_sin"]
    names += [f"lab_{c}_{s}" for c in ("L", "a", "b") for s in ("mean", "std")]
    names += ["Y_mean", "Y_std", "hp_std", "hp_abs_p50", "hp_abs_p90", "hp_abs_p99",
              "hp_kurtosis", "glint_frac", "bright_frac", "dark_frac"]
    names += [f"logpow_{i}" for i in range(SPEC_BINS)]
    names += ["grad_mean", "grad_std", "grad_p90", "grad_coherence", "chroma_hp_std",
              "RG_corr_hp", "Y_p01", "Y_p99", "sat_p90"]
    return names


def box_blur_stack(a: np.ndarray, k: int = 9) -> np.ndarray:
    """(n, s, s) float32 k x k box blur of each of (n, s, s) patches with reflect-101 borders
    (``cv2.blur(p, (k, k), borderType=cv2.BORDER_REFLECT_101)`` per patch, vectorised)."""
    r = k // 2
    p = np.pad(np.asarray(a, np.float64), ((0, 0), (r, r), (r, r)), mode="reflect")
    c = np.cumsum(np.cumsum(p, axis=1), axis=2)
    c = np.pad(c, ((0, 0), (1, 0), (1, 0)))
    s = c[:, k:, k:] - c[:, :-k, k:] - c[:, k:, :-k] + c[:, :-k, :-k]
    return (s / (k * k)).astype(np.float32)


def _mean_std(a: np.ndarray) -> list[np.ndarray]:
    """[mean, std] over axis 1 of an (n, m) array."""
    return [a.mean(axis=1), a.std(axis=1)]


def patch_features(rgb: np.ndarray, hp: np.ndarray | None = None) -> np.ndarray:
    """(n, 45) float64 features of (n, s, s, 3) uint8 RGB patches.

    ``hp``: (n, s, s) float32 high-pass of the luminance cut from the whole image (as in
    :mod:`.patches`); computed per patch when None (slightly different at borders)."""
    rgb = np.ascontiguousarray(rgb, np.uint8)
    n, s = rgb.shape[0], rgb.shape[1]
    if n == 0:
        return np.zeros((0, len(feature_names())))
    flat = rgb.reshape(n, s * s, 3).astype(np.float32)
    tall = rgb.reshape(n * s, s, 3)  # one image of stacked patches for colour conversions
    hsv = cv2.cvtColor(tall, cv2.COLOR_RGB2HSV).reshape(n, s * s, 3).astype(np.float32)
    lab = cv2.cvtColor(tall, cv2.COLOR_RGB2LAB).reshape(n, s * s, 3).astype(np.float32)
    y = flat @ LUMA
    if hp is None:
        hp = y.reshape(n, s, s) - box_blur_stack(y.reshape(n, s, s))
    hp = np.asarray(hp, np.float32).reshape(n, s * s)
    mx, mn = flat.max(axis=2), flat.min(axis=2)
    sat = np.divide(mx - mn, mx, out=np.zeros_like(mx), where=mx > 0)
    cols: list[np.ndarray] = []
    for c in range(3):
        cols += _mean_std(flat[..., c])
    hue = hsv[..., 0] * np.float32(np.pi / 90.0)  # OpenCV hue 0..179 -> radians
    wsum = np.maximum(sat.sum(axis=1), 1e-6)
    cols += _mean_std(sat) + _mean_std(hsv[..., 2])
    cols += [(np.cos(hue) * sat).sum(axis=1) / wsum, (np.sin(hue) * sat).sum(axis=1) / wsum]
    for c in range(3):
        cols += _mean_std(lab[..., c])
    var = hp.var(axis=1)
    ahp = np.percentile(np.abs(hp), (50, 90, 99), axis=1)
    cols += _mean_std(y) + [np.sqrt(var), ahp[0], ahp[1], ahp[2],
                            (hp.astype(np.float64) ** 4).mean(axis=1) / np.maximum(var, 1e-6) ** 2]
    cols += [(y >= 230).mean(axis=1), (y >= 200).mean(axis=1), (y < 20).mean(axis=1)]
    power = patch_power(y.reshape(n, s, s))
    edges = log_edges(1.0 / s, 0.5, SPEC_BINS)
    idx = np.digitize(radial_frequency(s).ravel(), edges) - 1
    ok = (idx >= 0) & (idx < SPEC_BINS)
    onehot = np.zeros((s * s, SPEC_BINS))
    onehot[np.flatnonzero(ok), idx[ok]] = 1.0
    binned = power.reshape(n, s * s) @ onehot / np.maximum(onehot.sum(axis=0), 1)
    cols += list(np.log10(binned + 1e-3).T)
    yy = y.reshape(n, s, s)
    gx = (yy[:, :-1, 1:] - yy[:, :-1, :-1]).reshape(n, -1)
    gy = (yy[:, 1:, :-1] - yy[:, :-1, :-1]).reshape(n, -1)
    g = np.hypot(gx, gy)
    jxx, jyy, jxy = (gx * gx).mean(axis=1), (gy * gy).mean(axis=1), (gx * gy).mean(axis=1)
    coherence = np.sqrt((jxx - jyy) ** 2 + 4 * jxy ** 2) / np.maximum(jxx + jyy, 1e-6)
    cols += _mean_std(g) + [np.percentile(g, 90, axis=1), coherence]
    rg = (flat[..., 0] - flat[..., 1]).reshape(n, s, s)
    rg_hp = (rg - box_blur_stack(rg)).reshape(n, -1)
    corr = ((rg_hp - rg_hp.mean(1, keepdims=True)) * (hp - hp.mean(1, keepdims=True))).mean(1)
    corr = corr / np.maximum(rg_hp.std(axis=1) * hp.std(axis=1), 1e-6)
    ypc = np.percentile(y, (1, 99), axis=1)
    cols += [rg_hp.std(axis=1), corr, ypc[0], ypc[1], np.percentile(sat, 90, axis=1)]
    return np.stack([np.asarray(c, np.float64) for c in cols], axis=1)


# --------------------------------------------------------------------------- the model

@dataclass
class LogisticModel:
    """Standardisation (``mean``, ``std`` (d,)) and weights ``w`` (d,) and ``b`` of
    p(class 1 | x) = sigmoid(((x - mean) / std) . w + b)."""

    mean: np.ndarray
    std: np.ndarray
    w: np.ndarray
    b: float

    def decision(self, x: np.ndarray) -> np.ndarray:
        """(n,) float64 logits of (n, d) raw features."""
        return ((x - self.mean) / self.std) @ self.w + self.b

    def predict(self, x: np.ndarray) -> np.ndarray:
        """(n,) int64 predicted class (0 or 1)."""
        return (self.decision(x) > 0).astype(np.int64)


def fit_logistic(x: np.ndarray, y: np.ndarray, l2: float = 1.0,
                 sample_weight: np.ndarray | None = None, iters: int = 50) -> LogisticModel:
    """L2-regularised logistic regression by Newton's method (IRLS).

    Args:
        x: (n, d) float features (standardised here with their own mean/std).
        y: (n,) 0/1 labels.
        l2: penalty l2 / 2 * |w|^2 on the weights (not the bias), added to the weighted
            log-loss sum.
        sample_weight: (n,) weights; None = balanced classes (each class weighs n / 2).
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    mean = x.mean(axis=0)
    std = x.std(axis=0)
    std = np.where(std > 1e-12, std, 1.0)
    z = np.hstack([(x - mean) / std, np.ones((len(x), 1))])
    if sample_weight is None:
        n1 = max(y.sum(), 1.0)
        n0 = max(len(y) - y.sum(), 1.0)
        sample_weight = np.where(y > 0.5, len(y) / (2 * n1), len(y) / (2 * n0))
    sw = np.asarray(sample_weight, np.float64)
    d = z.shape[1]
    reg = np.full(d, float(l2))
    reg[-1] = 1e-8
    beta = np.zeros(d)
    for _ in range(iters):
        p = 1.0 / (1.0 + np.exp(-np.clip(z @ beta, -35, 35)))
        grad = z.T @ (sw * (p - y)) + reg * beta
        hess = (z * (sw * p * (1 - p))[:, None]).T @ z + np.diag(reg)
        step = np.linalg.solve(hess, grad)
        beta -= step
        if np.max(np.abs(step)) < 1e-8:
            break
    return LogisticModel(mean, std, beta[:-1], float(beta[-1]))


# --------------------------------------------------------------------------- evaluation

def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k / n (95 % for z = 1.96)."""
    if n <= 0:
        return (0.0, 1.0)
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (max(0.0, c - half), min(1.0, c + half))


def group_folds(groups: np.ndarray, y: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    """(n,) int fold of each sample: whole groups (images) go to one fold; the groups of each
    class are shuffled and dealt round-robin so every fold holds both classes.

    ``groups`` must identify an image uniquely across classes (e.g. class * 10**6 + image)."""
    rng = np.random.default_rng(seed)
    fold = np.zeros(len(groups), np.int64)
    for cls in np.unique(y):
        g = np.unique(groups[y == cls])
        rng.shuffle(g)
        fold_of = {int(gi): i % k for i, gi in enumerate(g)}
        sel = y == cls
        fold[sel] = [fold_of[int(gi)] for gi in groups[sel]]
    return fold


def balance(y: np.ndarray, seed: int = 0) -> np.ndarray:
    """(m,) int64 indices keeping every sample of the smaller class and an equal-size random
    subset of the larger (sorted)."""
    rng = np.random.default_rng(seed)
    i0, i1 = np.flatnonzero(y == 0), np.flatnonzero(y == 1)
    m = min(len(i0), len(i1))
    keep = [rng.choice(i, m, replace=False) if len(i) > m else i for i in (i0, i1)]
    return np.sort(np.concatenate(keep))


def image_bootstrap(correct: np.ndarray, groups: np.ndarray, reps: int = 2000, seed: int = 0
                    ) -> tuple[float, float]:
    """95 % percentile interval of the accuracy when whole images are resampled with
    replacement (``correct`` (n,) bool per patch, ``groups`` (n,) image id)."""
    ug, inv = np.unique(groups, return_inverse=True)
    tot = np.bincount(inv).astype(np.float64)
    cor = np.bincount(inv, weights=correct.astype(np.float64))
    rng = np.random.default_rng(seed)
    draw = rng.integers(0, len(ug), size=(reps, len(ug)))
    acc = cor[draw].sum(axis=1) / tot[draw].sum(axis=1)
    lo, hi = np.percentile(acc, (2.5, 97.5))
    return float(lo), float(hi)


@dataclass
class CVResult:
    """Cross-validated accuracy of a classifier (see the module docstring).

    ``ci_binomial``: Wilson 95 % on the patch count; ``ci_images``: image bootstrap 95 %;
    ``top_features``: (name, standardised weight) largest |weight| first, weight > 0 meaning
    "higher in class 1" (the real set in :mod:`.report`); ``kept`` (m,) int64 the rows of
    the inputs that were scored (after balancing) and ``scores`` (m,) float64 their
    out-of-fold logits (> 0: class 1), not in :meth:`to_dict`."""

    accuracy: float
    correct: int
    n_test: int
    ci_binomial: tuple[float, float]
    ci_images: tuple[float, float]
    fold_accuracy: list
    n_patches: tuple[int, int]
    n_images: tuple[int, int]
    k: int
    model: str = "logistic"
    top_features: list = field(default_factory=list)
    kept: np.ndarray | None = None
    scores: np.ndarray | None = None

    def to_dict(self) -> dict:
        return {"model": self.model, "accuracy": self.accuracy, "correct": self.correct,
                "n_test": self.n_test, "ci95_binomial": list(self.ci_binomial),
                "ci95_images": list(self.ci_images), "fold_accuracy": self.fold_accuracy,
                "patches_per_class": list(self.n_patches),
                "images_per_class": list(self.n_images), "folds": self.k,
                "top_features": [[n, w] for n, w in self.top_features]}


def _prepare(y, groups, k, seed):
    y = np.asarray(y, np.int64)
    groups = np.asarray(groups, np.int64)
    keep = balance(y, seed)
    n_img = tuple(len(np.unique(groups[keep][y[keep] == c])) for c in (0, 1))
    k = int(max(2, min(k, min(n_img))))
    if min(n_img) < 2:
        raise ValueError(f"cross-validation needs at least 2 images per class, got {n_img}")
    folds = group_folds(groups[keep], y[keep], k, seed)
    return keep, y[keep], groups[keep], folds, n_img, k


def _result(pred, y, groups, folds, k, n_img, model, seed, keep=None, scores=None
            ) -> CVResult:
    correct = pred == y
    fold_acc = [float(correct[folds == f].mean()) for f in range(k) if np.any(folds == f)]
    c, n = int(correct.sum()), len(correct)
    return CVResult(c / n, c, n, wilson_interval(c, n), image_bootstrap(correct, groups,
                                                                        seed=seed),
                    fold_acc, (int((y == 0).sum()), int((y == 1).sum())), n_img, k, model,
                    kept=keep, scores=scores)


def cross_validate(x: np.ndarray, y: np.ndarray, groups: np.ndarray, k: int = 5,
                   l2: float = 1.0, seed: int = 0, names: list | None = None,
                   top: int = 8) -> CVResult:
    """k-fold (by image) cross-validated accuracy of the logistic classifier.

    Args:
        x: (n, d) features; y: (n,) 0/1 class; groups: (n,) int image id, unique across both
            classes. k is lowered to the number of images of the smaller class when needed.
    ValueError when a class has fewer than 2 images."""
    x = np.asarray(x, np.float64)
    keep, yk, gk, folds, n_img, k = _prepare(y, groups, k, seed)
    xk = x[keep]
    scores = np.zeros(len(yk))
    for f in range(k):
        test = folds == f
        if test.any() and (~test).any():
            scores[test] = fit_logistic(xk[~test], yk[~test], l2).decision(xk[test])
    pred = (scores > 0).astype(np.int64)
    res = _result(pred, yk, gk, folds, k, n_img, "logistic", seed, keep, scores)
    full = fit_logistic(xk, yk, l2)
    names = names or feature_names()
    order = np.argsort(-np.abs(full.w))[:top]
    res.top_features = [(names[i] if i < len(names) else f"f{i}", float(full.w[i]))
                        for i in order]
    return res


def torch_available() -> bool:
    try:
        import torch  # noqa: F401
    except Exception:  # any import failure: no CNN
        return False
    return True


def cross_validate_cnn(patches: np.ndarray, y: np.ndarray, groups: np.ndarray, k: int = 5,
                       epochs: int = 6, seed: int = 0, min_steps: int = 150,
                       threads: int | None = None, channels: tuple[int, ...] = (16, 32, 32),
                       augment: bool = False) -> CVResult:
    """The same folds with a tiny CNN (a stride-2 3 x 3 convolution and ReLU per entry of
    ``channels``, global average pooling, one linear output) trained with Adam (2e-3,
    batches of 128) on (n, s, s, 3) uint8 patches for ``epochs`` epochs but at least
    ``min_steps`` steps per fold, on ``threads`` CPU threads (None: torch's default);
    ``augment``: each batch flipped and turned by a random multiple of 90 degrees. Needs
    torch (ImportError otherwise)."""
    import torch
    from torch import nn

    if threads:
        torch.set_num_threads(int(threads))
    torch.manual_seed(seed)
    keep, yk, gk, folds, n_img, k = _prepare(y, groups, k, seed)
    data = torch.from_numpy(np.ascontiguousarray(patches[keep])).permute(0, 3, 1, 2)
    target = torch.from_numpy(yk.astype(np.float32))
    scores = np.zeros(len(yk))

    def net() -> nn.Module:
        layers: list[nn.Module] = []
        prev = 3
        for c in channels:
            layers += [nn.Conv2d(prev, c, 3, 2, 1), nn.ReLU()]
            prev = c
        return nn.Sequential(*layers, nn.AdaptiveAvgPool2d(1), nn.Flatten(),
                             nn.Linear(prev, 1))

    def _norm(t):
        return (t.float() - 128.0) / 64.0

    for f in range(k):
        test = torch.from_numpy(folds == f)
        if not test.any() or test.all():
            continue
        model = net()
        opt = torch.optim.Adam(model.parameters(), 2e-3)
        train_idx = torch.nonzero(~test).ravel()
        gen = torch.Generator().manual_seed(seed + f)
        per_epoch = max(1, math.ceil(len(train_idx) / 128))
        for _ in range(max(epochs, math.ceil(min_steps / per_epoch))):
            perm = train_idx[torch.randperm(len(train_idx), generator=gen)]
            for b in range(0, len(perm), 128):
                idx = perm[b:b + 128]
                batch = data[idx]
                if augment:
                    turns = int(torch.randint(4, (1,), generator=gen))
                    batch = torch.rot90(batch, turns, (2, 3))
                    if int(torch.randint(2, (1,), generator=gen)):
                        batch = torch.flip(batch, (3,))
                logits = model(_norm(batch)).squeeze(1)
                loss = nn.functional.binary_cross_entropy_with_logits(logits, target[idx])
                opt.zero_grad()
                loss.backward()
                opt.step()
        with torch.no_grad():
            test_idx = torch.nonzero(test).ravel()
            out = torch.cat([model(_norm(data[test_idx[b:b + 512]])).squeeze(1)
                             for b in range(0, len(test_idx), 512)])
        scores[test_idx.numpy()] = out.numpy().astype(np.float64)
    pred = (scores > 0).astype(np.int64)
    return _result(pred, yk, gk, folds, k, n_img, "cnn", seed, keep, scores)
