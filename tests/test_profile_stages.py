"""tools/profile_stages.py: the per-stage profile times the generator's own steps."""

from __future__ import annotations

from sdcomp import GeneratorConfig

from .tools import load_tool


def test_profile_times_every_step_of_the_generators_image(sprites_dir):
    tool = load_tool("profile_stages")
    # the tool checks its first image against Generator.render's (it raises otherwise)
    usage: dict = {}
    steps, cold = tool.profile(GeneratorConfig(width=96, height=64), 2, sprites_dir, usage)
    for step in ("scene: draw the scene", "water (view and draw)", "objects: layers, foam",
                 "labels: map", "labels: measure", "camera: photometric"):
        assert steps[step] > 0, step
    assert any(k.startswith("  water: ") for k in steps) and cold > 0
    assert usage["user"] > 0 and usage["system"] >= 0 and usage["faults"] >= 0


def test_profile_of_a_frame_wider_than_the_drawn_water(sprites_dir):
    """Frames over BACKGROUND_MAX have their water drawn smaller and magnified, as the
    compositor does: the profiled image is still the generator's (the tool raises
    otherwise; it failed in the foam rings or the byte check before)."""
    from sdcomp.render.compositor import BACKGROUND_MAX

    tool = load_tool("profile_stages")
    steps, _ = tool.profile(GeneratorConfig(width=BACKGROUND_MAX + 104, height=40), 1,
                            sprites_dir)
    assert steps["water (view and draw)"] > 0
