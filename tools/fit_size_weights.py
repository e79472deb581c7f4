"""Fit the ``seadronessee`` preset's ``size_weight`` tables (sdcomp/scene/presets.py,
``SDS_SIZE_WEIGHTS``); run from the repository root: ``python tools/fit_size_weights.py``.

Each object of the preset draws a box size from its class's quantiles (``SDS_SIZES``) and is
placed on the image row where it shows that size; a size that the view cannot show (a boat
far smaller than it can look under a low drone) is drawn again. So the sizes shown lean to
those that most views can show. This script draws scenes only (no pixels: about 17 ms each),
records the size each placed object of interest was drawn for (the box it shows is within
the placement's slack of it, 1.15x), and multiplies the weight of each pair of neighbouring
quantile intervals by how rarely the sizes placed fall in it (damped, bounded), a few
rounds, until the sizes placed follow the quantiles. It prints the ratios placed /
SeaDronesSee at p10 ... p90 per round, a check with another seed, then the table.
"""
from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sdcomp.scene import sample  # noqa: E402
from sdcomp.scene.config import GeneratorConfig  # noqa: E402
from sdcomp.scene.objects import draw_size  # noqa: E402
from sdcomp.scene.presets import (  # noqa: E402
    SDS_SIZE_WEIGHTS,
    SDS_SIZES,
    SDS_WEIGHT_GROUP,
    preset,
)
from sdcomp.scene.scene import Role  # noqa: E402

_PLACE = sample._place

GROUP = SDS_WEIGHT_GROUP  # neighbouring intervals that share one weight (as the preset)
DAMP = 0.7  # the update's power: weight *= (placed share / due share) ** -DAMP
BOUNDS = (0.1, 10.0)  # the weights' range, relative to their mean


def config(weights: dict[str, list[float]], seed: int) -> GeneratorConfig:
    """The preset at 1920 x 1080 (sizes over the focal length do not depend on it) with
    the interval weights ``weights`` per class."""
    spec = preset("seadronessee")
    objects = [{**o, "size_weight": weights.get(o["category"])} for o in spec["objects"]]
    return GeneratorConfig.from_mapping({**spec, "objects": objects, "width": 1920,
                                         "height": 1080, "seed": seed}, source="fit")


def drawn(args: tuple[dict[str, list[float]], int, int, int]) -> list[tuple[int, float]]:
    """(category id, box size over fx drawn for it) of each object of interest placed in
    scenes ``lo`` ... ``hi - 1``: the last size drawn before its placement was found (the
    generator's own draw, recorded by wrapping it)."""
    weights, seed, lo, hi = args
    cfg = config(weights, seed)
    model = cfg.camera_model()
    last: list[float] = []
    out: list[tuple[int, float]] = []

    def draw(*a: object) -> float:
        last.append(draw_size(*a))  # type: ignore[arg-type]
        return last[-1]

    def place(*a: object, **k: object) -> object:
        last.clear()
        p = _PLACE(*a, **k)
        if p is not None and p.role is Role.OBJECT and last:
            out.append((p.category_id, last[-1]))
        return p

    sample.draw_size, sample._place = draw, place  # type: ignore[assignment]
    for i in range(lo, hi):
        sample.sample_scene(cfg, i, model)
    return out


def simulate(weights: dict[str, list[float]], n: int, seed: int, workers: int
             ) -> np.ndarray:
    """(M, 2) (category id, size) over ``n`` scenes, in ``workers`` processes."""
    cuts = np.linspace(0, n, 4 * workers + 1).astype(int)
    with ProcessPoolExecutor(workers) as pool:
        parts = pool.map(drawn, [(weights, seed, int(a), int(b))
                                 for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
        return np.array([r for part in parts for r in part])


def shares(sizes: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per group of :data:`GROUP` intervals of the quantiles ``q``: the share of ``sizes``
    in it over its due share (1: as the quantiles say)."""
    u = np.interp(sizes, q, np.linspace(0.0, 1.0, len(q)))
    groups = (len(q) - 1) // GROUP
    return np.histogram(u, bins=groups, range=(0.0, 1.0))[0] / max(len(u), 1) * groups


def report(names: list[str], rec: np.ndarray) -> None:
    for k, name in enumerate(names):
        s = rec[rec[:, 0] == k + 1, 1]
        q = np.asarray(SDS_SIZES[name])
        due = np.interp([0.1, 0.3, 0.5, 0.7, 0.9], np.linspace(0, 1, len(q)), q)
        print(f"  {name:24s} {len(s):6d} placed/real at p10 ... p90",
              np.round(np.quantile(s, [0.1, 0.3, 0.5, 0.7, 0.9]) / due, 2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=6000, help="scenes per round")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    names = [o["category"] for o in preset("seadronessee")["objects"]]
    # the classes the preset weights (the others are drawn evenly: see SDS_SIZE_WEIGHTS)
    weights = {n: [1.0] * (len(SDS_SIZES[n]) - 1) for n in SDS_SIZE_WEIGHTS}
    for r in range(args.rounds):
        rec = simulate(weights, args.scenes, 0, args.workers)
        print(f"round {r}")
        report(names, rec)
        for k, name in enumerate(names):
            if name not in weights:
                continue
            g = shares(rec[rec[:, 0] == k + 1, 1], np.asarray(SDS_SIZES[name]))
            w = np.asarray(weights[name]) * np.repeat(np.maximum(g, 0.05) ** -DAMP, GROUP)
            w = np.clip(w / w.mean(), *BOUNDS)
            weights[name] = [round(float(x), 2) for x in w / w.mean()]
    print("check (another seed)")
    report(names, simulate(weights, args.scenes, 1, args.workers))
    print("SDS_SIZE_WEIGHTS = {")
    for name in weights:  # one weight per group of intervals, as the preset holds them
        print(f"    {name!r}: {tuple(weights[name][::GROUP])},")
    print("}")


if __name__ == "__main__":
    main()
