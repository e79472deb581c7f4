"""Per-stage cost of one image, the generator's own steps timed in one process.

    python tools/profile_stages.py [--size WxH ...] [--n 60] [--preset NAME] [--threads N]

For each frame size, renders ``--n`` images of the default config (or a preset) after a
warm-up of 5 (every sprite level and cache made: a long run's steady state; the first
image's cold cost is printed apart), timing each step of
:meth:`sdcomp.pipeline.Generator._render_once` with ``time.perf_counter``: the scene's
draw, the water (its view, then its drawing: textures, shading, foam, glitter, sky), the
objects' layers, compositing, defocus, the label map, the camera (per stage, as
:func:`~sdcomp.render.camera.pipeline.apply_camera` reports them) and the labels' measure.
Prints a markdown table per size: milliseconds per image and share of the whole (the
water's own sections, indented, are parts of its row), then the process's user and system
CPU time and page faults per image (``--threads 1``: as a run's worker renders; the system
time is mostly page faults, which freed frames cost when the heap returns them). The first
profiled image is checked against :meth:`~sdcomp.pipeline.Generator.render`'s (the same
bytes), so the steps timed are the generator's.
"""

from __future__ import annotations

import argparse
import resource
import time
from collections import defaultdict

import cv2
import numpy as np

from sdcomp import Generator, GeneratorConfig
from sdcomp.annotate.masks import label_map, measure
from sdcomp.render.camera.pipeline import apply_camera
from sdcomp.render.composite import composite
from sdcomp.render.compositor import _threads_for
from sdcomp.render.effects import blur
from sdcomp.render.layers import build_layers
from sdcomp.render.lighting import lighting
from sdcomp.render.water import base as water_base
from sdcomp.scene.presets import preset
from sdcomp.scene.sample import sample_scene


def profile(config: GeneratorConfig, n: int, sprites: str | None,
            usage: dict | None = None) -> tuple[dict, float]:
    """(mean seconds per image per step, seconds of the first image) over ``n`` images;
    ``usage``, when given, receives the process's user and system CPU seconds and minor
    page faults per profiled image (``user``, ``system``, ``faults``)."""
    gen = Generator(config, sprites, progress=False)
    gen.warm()
    comp = gen.compositor
    t0 = time.perf_counter()
    gen.render(0)
    cold = time.perf_counter() - t0
    for i in range(1, 5):
        gen.render(i)
    steps: dict[str, float] = defaultdict(float)
    water: dict = {}
    water_base.PROFILE = water
    clock = [0.0]
    before = resource.getrusage(resource.RUSAGE_SELF)

    def tick(name: str) -> None:
        now = time.perf_counter()
        steps[name] += now - clock[0]
        clock[0] = now

    for i in range(5, 5 + n):
        clock[0] = time.perf_counter()
        scene = sample_scene(config, i, gen.model)
        tick("scene: draw the scene")
        model = scene.model
        with _threads_for(model):
            comp.background(model)  # made before the water's clock starts
            water_base.tick()  # the water's sections count from here
            image, light = comp.draw_background(scene)
            tick("water (view and draw)")
            lit = lighting(scene, light)
            layers = build_layers(scene, lit, comp.assets.sprites, foam_onto=image)
            tick("objects: layers, foam")
            composite(image, layers, scene.shadows)
            tick("objects: shadows, composite")
            image = blur(image, None, scene.defocus_blur)
            tick("defocus")
        labels, objs = label_map(scene, layers)
        tick("labels: map")
        timings: dict = {}
        with _threads_for(model):
            tile = comp.noise_tile(model, scene.seeds.noise_tile)
            clock[0] = time.perf_counter()
            image, labels, _, cam = apply_camera(image, labels, scene.look, tile, None,
                                                 timings=timings)
        for k, v in timings.items():
            steps[f"camera: {k}"] += v
        clock[0] = time.perf_counter()
        measure(labels, objs, gen.rule, None, "lens" in cam["stages"], cam.get("zoom", 1.0))
        tick("labels: measure")
        if i == 5:
            first = image
    water_base.PROFILE = None
    after = resource.getrusage(resource.RUSAGE_SELF)
    # checked outside the timed steps (the generator's own render would count in the
    # water's first section and in the CPU time)
    if not np.array_equal(gen.render(5).image, first):
        raise RuntimeError("the profiled steps no longer make the generator's image: "
                           "update them to Generator._render_once")
    if usage is not None:
        usage.update(user=(after.ru_utime - before.ru_utime) / n,
                     system=(after.ru_stime - before.ru_stime) / n,
                     faults=(after.ru_minflt - before.ru_minflt) / n)
    out = {k: v / n for k, v in steps.items()}
    parts: dict[str, float] = defaultdict(float)
    for k, v in water.items():  # the water's own sections, their sub-steps summed
        parts[WATER_PARTS.get(k.split(".")[0], k)] += v / n
    out.update({f"  water: {k}": v for k, v in parts.items()})
    return out, cold


#: the water's profile sections (:data:`sdcomp.render.water.base.PROFILE`) by prefix
WATER_PARTS = {"frame": "view: frame geometry", "exposure": "view: exposure",
               "sky_terms": "view: sky", "srgb_terms": "shading",
               "g": "glitter", "glitter": "glitter", "st": "sea terms (coarse light)",
               "sea_terms": "sea terms (coarse light)", "sh": "shading", "shade": "shading",
               "r": "wave layers (textures)", "textures": "wave layers (textures)"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", nargs="+", default=["416x416", "1920x1080"])
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--preset", default=None)
    ap.add_argument("--sprites", default=None)
    ap.add_argument("--threads", type=int, default=None,
                    help="OpenCV threads (a run's workers use 1; default: OpenCV's own, "
                         "which the generator lowers to 1 for frames up to 512x512)")
    args = ap.parse_args()
    if args.threads is not None:
        cv2.setNumThreads(args.threads)
    for size in args.size:
        w, h = (int(x) for x in size.split("x"))
        base = preset(args.preset) if args.preset else {}
        config = GeneratorConfig.from_mapping({**base, "width": w, "height": h})
        usage: dict = {}
        steps, cold = profile(config, args.n, args.sprites, usage)
        total = sum(v for k, v in steps.items() if not k.startswith("  "))
        print(f"\n### {w}x{h}{' --preset ' + args.preset if args.preset else ''}: "
              f"{1000 * total:.1f} ms per image ({args.n} images, warm; the first image "
              f"{1000 * cold:.0f} ms)\n")
        print("| step | ms per image | share |\n|---|---|---|")
        for k, v in sorted(steps.items(), key=lambda kv: (kv[0].startswith("  "), -kv[1])):
            print(f"| {k.strip()} | {1000 * v:.2f} | {100 * v / total:.0f} % |")
        print(f"\nCPU an image: user {1000 * usage['user']:.1f} ms, system "
              f"{1000 * usage['system']:.1f} ms; {usage['faults']:.0f} page faults")


if __name__ == "__main__":
    main()
