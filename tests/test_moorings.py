"""Moored boats and jet skis (``--moored``): a dock alongside, often a canopied lift on the
other side, the object at rest; the moorings are clutter (never annotated) and change
nothing else of a scene."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sdcomp.errors import UserError
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.moorings import ASSETS, HALF_SIZE, clear, half_beam
from sdcomp.scene.objects import CLUTTER_PREFIX, footprint_radius, keel_depth
from sdcomp.scene.sample import sample_scene
from sdcomp.scene.scene import Role

LAKE = {"camera": "custom", "fov": 20.4, "sensor_px": [800, 600], "width": 800,
        "height": 600, "altitude": "105-120", "pitch": 90, "count": "1-4", "water": "lake",
        "objects": [{"mesh": "boat", "weight": 0.3}, {"mesh": "jetski", "weight": 0.7}]}


def _config(**kw) -> GeneratorConfig:
    return GeneratorConfig.from_mapping({**LAKE, **kw})


def _body(obj, p) -> tuple[float, float]:
    """(along, across) metres of placement ``p``'s centre in ``obj``'s body frame."""
    h = math.radians(obj.heading)
    dx, dy = p.x - obj.x, p.y - obj.y
    return dx * math.cos(h) + dy * math.sin(h), -dx * math.sin(h) + dy * math.cos(h)


def test_clear_tells_a_disc_inside_beside_and_off_a_corner():
    half = (4.0, 0.6)
    assert not clear(0.0, 0.0, 0.0, half, [(3.0, 0.0, 0.1)])  # on the walkway
    assert not clear(0.0, 0.0, 0.0, half, [(0.0, 1.0, 0.5)])  # reaching over its side
    assert clear(0.0, 0.0, 0.0, half, [(0.0, 1.2, 0.5)])  # beside it
    assert clear(0.0, 0.0, 0.0, half, [(4.5, 1.1, 0.6)])  # off the corner (0.71 m away)
    assert not clear(0.0, 0.0, 90.0, half, [(0.0, 3.0, 0.5)])  # turned: along y now


def test_unmoored_scenes_are_those_of_before():
    """``moored`` 0 draws nothing more: the scene equals the one drawn with the moorings'
    stream never used, and a moored run keeps every placement's asset and, but for the
    jet skis moved beside another (its heading, within 3.5 m), its place and heading, the
    other clutter included, only adding moorings after them."""
    plain, moored = _config(), _config(moored=1.0)
    moved = 0
    for i in range(40):
        a, b = sample_scene(plain, i), sample_scene(moored, i)
        n = len(a.placements)
        assert [p.asset for p in a.placements] == [p.asset for p in b.placements[:n]]
        for p, q in zip(a.placements, b.placements[:n], strict=True):
            if (p.x, p.y, p.heading) != (q.x, q.y, q.heading):
                moved += 1
                assert "jetski" in q.asset and any(
                    o is not q and _same(o, q) and math.hypot(o.x - q.x, o.y - q.y) < 3.5
                    for o in b.placements[:n])
        assert all(p.role is Role.CLUTTER and p.asset in ASSETS for p in b.placements[n:])
        assert replace(a, placements=()) == replace(b, placements=())
    assert moved > 0


def _same(a, b) -> bool:
    return abs(math.remainder(a.heading - b.heading, 360.0)) < 1e-9


def _docked(o, has_port: bool, moorings) -> list[float]:
    """The across offsets (metres, ``o``'s body frame) of the docks that hold ``o``."""
    beam = max(half_beam(o.asset), HALF_SIZE["port"][1] if has_port else 0.0)
    return [across for m, along, across in ((m, *_body(o, m)) for m in moorings
                                            if _same(m, o))
            if m.asset.endswith("dock")
            and beam + 0.1 + HALF_SIZE["dock"][1] - 1e-6 <= abs(across)
            <= beam + 0.5 + HALF_SIZE["dock"][1] + 1e-6 and abs(along) <= 2.0]


def test_every_boat_and_jet_ski_is_moored_beside_a_dock():
    """With ``moored`` 1 each boat and jet ski (unless its dock would cover another
    object) lies at rest and level beside a dock parallel to it, or beside a jet ski that
    does: across it by its half beam (or its port's), a gap of 0.1-0.5 m and the dock's
    half width, within 2 m of its middle along it; canopies on the other side, on about
    60 % of them; about half the jet skis on a drive-on port under them, held out of the
    water (keel above it); some jet skis side by side (the image's next one moved
    alongside a moored one)."""
    config = _config(moored=1.0, count="1-3", clutter=0)
    objects = docks = canopies = jetskis = ported = paired = 0
    for i in range(60):
        scene = sample_scene(config, i)
        objs = [p for p in scene.placements if p.role is Role.OBJECT]
        moorings = [p for p in scene.placements if p.asset in ASSETS]
        for obj in objs:
            objects += 1
            assert obj.speed == 0.0 and obj.roll == 0.0 and obj.pitch == 0.0
            near = [(m, *_body(obj, m)) for m in moorings if _same(m, obj)]
            port = [m for m, along, across in near if m.asset.endswith("port")
                    and math.hypot(along, across) < 1e-6]
            mates = [o for o in objs if o is not obj and _same(o, obj)
                     and math.hypot(*_body(obj, o)) < 3.5]
            if "jetski" in obj.asset:
                jetskis += 1
                ported += bool(port)
                paired += bool(mates)
                if port:  # raised onto the port's rollers
                    assert obj.draft == pytest.approx(-(keel_depth(obj.asset) + 0.08))
            else:
                assert not port and not mates

            side = _docked(obj, bool(port), moorings) or [
                a for o in mates for a in _docked(o, bool(port), moorings)]
            docks += bool(side)
            canopies += any(m.asset.endswith("canopy") and side
                            and np.sign(across) != np.sign(side[0])
                            for m, _, across in near)
    assert objects > 80 and jetskis > 40
    assert docks >= 0.8 * objects
    assert 0.4 * docks <= canopies <= 0.8 * docks
    assert 0.3 * jetskis <= ported <= 0.7 * jetskis
    assert paired >= 0.15 * jetskis


def test_moorings_keep_off_the_other_objects():
    """No mooring's rectangle covers the disc of an object it does not hold, nor of any
    clutter: crowded scenes of moored objects leave some without a dock instead."""
    config = _config(moored=1.0, count="6-10", clutter=3.0)
    checked = 0
    for i in range(40):
        placements = sample_scene(config, i).placements
        moorings = [p for p in placements if p.asset in ASSETS]
        others = [p for p in placements if p.asset not in ASSETS
                  and not p.asset.endswith("foam")]
        for m in moorings:
            kind = m.asset.removeprefix(CLUTTER_PREFIX)
            holders = [p for p in others if p.role is Role.OBJECT and _same(p, m)]
            assert 1 <= len(holders) <= 2
            # the disc of an object it holds is a rough circle about a long body: the
            # mooring lies inside it, beside the body (the test above)
            discs = [(p.x, p.y, footprint_radius(p.asset) * 0.999) for p in others
                     if not any(p is h for h in holders)]
            assert clear(m.x, m.y, m.heading, HALF_SIZE[kind], discs)
            checked += 1
    assert checked > 100


def test_moored_is_checked_and_kept_in_config_files():
    assert GeneratorConfig().moored == 0.0
    again = GeneratorConfig.from_mapping(dict(_config(moored=0.5).to_dict()))
    assert again.moored == 0.5
    for bad in (-0.1, 1.5, "often"):
        with pytest.raises(UserError, match="moored"):
            _config(moored=bad)


def test_moored_images_draw_docks_that_are_not_labelled(sprites_dir):
    """The moorings are drawn (bright deck and canopy pixels beside the object, none of
    them in its mask) and the labels are those of the objects alone."""
    from sdcomp import Generator

    config = _config(moored=1.0, count="1", clutter=0, look="clean", motion_blur=0,
                     defocus_blur=0, width=400, height=300, sensor_px=[400, 300],
                     objects=[{"mesh": "jetski"}], sun_elevation="50-60", wind="1-2")
    plain = replace(config, moored=0.0)
    gen, gen0 = Generator(config, sprites_dir), Generator(plain, sprites_dir)
    changed = 0
    for i in range(4):
        f, f0 = gen.render(i), gen0.render(i)
        assert len(f.objects) == len(f0.objects) == 1
        diff = np.abs(f.image.astype(int) - f0.image.astype(int)).max(axis=2) > 30
        mask = f.instances > 0
        changed += int(diff.sum() > 2000)
        # what changed is the moorings, outside the object's mask (in it: its tilt and
        # wake, which a moored object has not, and the shadows cast on it)
        assert (diff & ~mask).sum() >= 5 * (diff & mask).sum()
        assert int(mask.sum()) == pytest.approx(int((f0.instances > 0).sum()), rel=0.2)
    assert changed >= 3


def test_overlap_of_turned_rectangles():
    from sdcomp.scene.moorings import overlap

    dock = (0.0, 0.0, 0.0, (4.0, 0.6))
    assert overlap(dock, (0.0, 1.0, 0.0, (1.0, 0.5)))
    assert not overlap(dock, (0.0, 1.2, 0.0, (1.0, 0.5)))
    assert overlap(dock, (4.5, 0.0, 45.0, (1.0, 0.2)))  # a turned end over its end
    assert not overlap(dock, (5.5, 1.5, 45.0, (1.0, 0.2)))  # beyond its corner


def test_shadows_on_sunlit_water_are_darker_and_bluer(sprites_dir):
    """A shadow takes the direct sun's share of the water's light channel by channel: the
    sun is warmer than the sky that still lights the shadow, so in the shadows of docks,
    canopies and boats the water loses more of its red than of its blue (real shadows on
    lake water are blue-grey beside the sunlit olive)."""
    from sdcomp import Generator

    config = _config(moored=1.0, count="2", clutter=0, look="clean", motion_blur=0,
                     defocus_blur=0, width=400, height=300, sensor_px=[400, 300],
                     sun_elevation="40-50", sky="clear", water="turbid", turbidity="0.8-0.9",
                     wind="1-2", objects=[{"mesh": "boat"}])
    lit, dark = Generator(replace(config, shadows=False), sprites_dir), Generator(config,
                                                                                 sprites_dir)
    ratios = []
    for i in range(3):
        a, b = lit.render(i), dark.render(i)
        sa, sb = a.image.astype(float), b.image.astype(float)
        shade = (sb.sum(axis=2) < 0.8 * sa.sum(axis=2)) & (a.instances == 0)
        if shade.sum() < 200:
            continue
        kept = (sb[shade] + 1) / (sa[shade] + 1)  # (n, 3) share of each channel kept
        ratios.append(np.median(kept, axis=0))
    assert len(ratios) >= 2
    for r, g, b in ratios:
        assert r < g < b and b - r > 0.05, (r, g, b)


def test_mooring_atlases_only_for_runs_that_moor():
    """The docks', canopies' and ports' atlases are built for runs that can moor something
    (boats or jet skis among the objects, ``moored`` above 0), never for others."""
    from sdcomp.pipeline import _sprite_jobs

    def moorings(config):
        return {key for key, _, _ in _sprite_jobs(config)} & set(ASSETS)

    assert moorings(_config(moored=0.5)) == set(ASSETS)
    assert moorings(_config(moored=0.0)) == set()
    assert moorings(GeneratorConfig(moored=1.0)) == set()  # the BlueROV2: nothing moors


def test_docks_near_a_shore_run_out_from_it():
    """With a shore in the image, a moored object within 25 m of the coast lies beside a
    dock rooted on it: the dock along the coast's normal, its land end on the land and its
    other end on the water, the object bow to the land, all of it on the water and its
    centre still in view; objects the shore cannot take keep their open-water docks."""
    from sdcomp.assets import clutter
    from sdcomp.scene.moorings import ROOT, half_length, in_view
    from sdcomp.scene.scene import on_land
    config = _config(moored=1.0, shore=1.0, count="1-3", clutter=0)
    rooted = docks = 0
    for i in range(60):
        scene = sample_scene(config, i)
        shore = scene.shore
        assert shore is not None
        objs = [p for p in scene.placements if p.role is Role.OBJECT]
        for m in (p for p in scene.placements if p.asset.endswith("dock")):
            docks += 1
            if not _same(m, replace(m, heading=shore.angle)):
                continue
            rooted += 1
            h = math.radians(m.heading)
            end = clutter.DOCK_LENGTH / 2
            land_end = (m.x + end * math.cos(h), m.y + end * math.sin(h))
            sea_end = (m.x - end * math.cos(h), m.y - end * math.sin(h))
            assert on_land(shore, *land_end) and not on_land(shore, *sea_end)
            # its root: ROOT metres past the coast at its place along it, give or take the
            # coast's wiggle over the dock's offset from its object
            a = math.radians(shore.angle)
            along = -land_end[0] * math.sin(a) + land_end[1] * math.cos(a)
            across = land_end[0] * math.cos(a) + land_end[1] * math.sin(a)
            assert across - (shore.distance + shore.wiggle(along)) == pytest.approx(
                ROOT, abs=0.6)
            obj = min((o for o in objs if _same(o, m)), key=lambda o: abs(_body(o, m)[1]))
            for sign in (1, -1):
                x = obj.x + sign * half_length(obj.asset) * math.cos(h)
                y = obj.y + sign * half_length(obj.asset) * math.sin(h)
                assert not on_land(shore, x, y)
            assert in_view(scene.model, scene.camera, obj.x, obj.y)
    assert docks > 60 and 0.3 * docks <= rooted <= docks
