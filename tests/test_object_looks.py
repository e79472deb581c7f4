"""How objects look next to real ones: ambient occlusion in the atlases, shadows as long as
the objects are tall, submerged parts that show the water drawn around them, the footage's
own camera on objects over it, the disturbed water round a swimmer treading water, and the
assets' paint and people aboard."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from sdcomp.assets import sar
from sdcomp.assets.mesh import ColoredMesh
from sdcomp.atlas.occlusion import diffuse_factor, sky_directions, sky_maps, sprite_occlusion
from sdcomp.atlas.raster import render
from sdcomp.render.composite import extruded, over
from sdcomp.render.harmonise import FootageCamera, coverage, footage_camera, harmonise
from sdcomp.render.layers import Layer
from sdcomp.scene.objects import stirring
from sdcomp.scene.scene import Role


def _mesh(parts) -> ColoredMesh:
    """A closed mesh of boxes ((extents, centre) each), one colour."""
    m = trimesh.util.concatenate([trimesh.creation.box(extents=e).apply_translation(c)
                                  for e, c in parts])
    return ColoredMesh(m.vertices, m.faces, np.full((len(m.faces), 3), 200, np.uint8), 0.0,
                       "boxes", closed=True)


# --------------------------------------------------------------------------- occlusion

def test_sky_directions_cover_the_upper_hemisphere_evenly():
    d = sky_directions(48)
    assert d.shape == (48, 3) and np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert (d[:, 2] > 0).all()
    # uniform on the hemisphere: the mean height is 1/2, the mean horizontal vector ~0
    assert d[:, 2].mean() == pytest.approx(0.5, abs=0.01)
    assert np.linalg.norm(d[:, :2].mean(axis=0)) < 0.05


def test_a_wall_hides_the_sky_from_the_floor_beside_it():
    """A plate with a 1.5 m wall standing across it: the plate's points by the wall see
    half the sky (the wall fills the half-sky towards it), points 1.8 m away most of it
    (the wall 40 degrees high: a cosine-weighted loss of about a tenth), the wall's top all
    of it."""
    mesh = _mesh([((4.0, 4.0, 0.1), (0.0, 0.0, 0.0)), ((0.2, 4.0, 1.5), (0.0, 0.0, 0.8))])
    maps = sky_maps(mesh)
    up = np.tile([0.0, 0.0, 1.0], (3, 1))
    pts = np.array([[0.2, 0.0, 0.05], [1.9, 0.0, 0.05], [0.0, 0.0, 1.55]])
    a = maps.occlusion(pts, up)
    assert 0.4 < a[0] < 0.65 and 0.85 < a[1] < 0.97 and a[2] > 0.97
    # a point facing the wall sideways (on the plate, the wall filling its half-sky) sees
    # less than half of the sky it faces
    side = maps.occlusion(np.array([[0.3, 0.0, 0.3]]), np.array([[-1.0, 0.0, 0.0]]))
    assert side[0] < 0.5


def test_sprite_occlusion_is_one_where_empty_and_lower_in_a_well():
    """Seen from above, a box with a well in it: the well's floor is occluded, the rim and
    the empty canvas are not."""
    ring = [((2.0, 0.4, 1.0), (0.0, 0.8, 0.5)), ((2.0, 0.4, 1.0), (0.0, -0.8, 0.5)),
            ((0.4, 1.2, 1.0), (0.8, 0.0, 0.5)), ((0.4, 1.2, 1.0), (-0.8, 0.0, 0.5)),
            ((1.2, 1.2, 0.1), (0.0, 0.0, 0.05))]
    mesh = _mesh(ring)
    size, mpp = 48, 3.0 / 48
    sprite = render(mesh, 0.0, 0.0, size=size, metres_per_pixel=mpp, supersample=2)
    occ = sprite_occlusion(sprite, 0.0, 0.0, mpp, mesh.waterline, sky_maps(mesh))
    assert occ.shape == (size, size) and occ.dtype == np.float32
    assert (occ[~sprite.mask] == 1.0).all() and occ.min() >= 0 and occ.max() <= 1
    c = size // 2
    floor = occ[c - 2:c + 2, c - 2:c + 2].mean()
    rim = occ[c, int(c + 0.8 / mpp)]
    assert floor < 0.6 < rim
    f = diffuse_factor(np.array([0.0, 0.5, 1.0], np.float32))
    assert f[0] == pytest.approx(0.2) and f[2] == pytest.approx(1.0) and f[0] < f[1] < f[2]


# --------------------------------------------------------------------------- shadows

def test_a_taller_object_casts_a_longer_shadow_away_from_the_sun():
    alpha = np.zeros((20, 20), np.float32)
    alpha[8:12, 8:12] = 1.0
    step = (2.0, -1.0)  # frame pixels per metre up: the sun is to the left and below
    flat, dx, dy = extruded(alpha, np.zeros_like(alpha), step)
    assert flat is alpha and (dx, dy) == (0, 0)
    tall, dx, dy = extruded(alpha, alpha * 4.0, step)  # 4 m high: 8 px right, 4 px up
    assert (dx, dy) == (-8, -4) and tall.shape == (28, 36)
    ys, xs = np.nonzero(tall > 0.5)
    # from the footprint (at -dx, -dy) to 8 px right and 4 px up
    assert xs.min() == 8 + 8 and xs.max() == 11 + 8 + 8
    assert ys.max() == 11 + 4 and ys.min() == 8 + 4 - 4
    half = np.where(alpha > 0, np.float32(2.0), np.float32(0.0))
    half[8:10] = 0.0  # the upper half of the footprint stands 2 m, the lower half nothing
    part, *_ = extruded(alpha, half * alpha, step)
    assert (part > 0.5).sum() < (tall > 0.5).sum()


# --------------------------------------------------------------------------- compositing

def _layer(alpha: np.ndarray, weight: np.ndarray, colour_level: float, water) -> Layer:
    colour = (alpha * colour_level)[..., None].repeat(3, axis=2).astype(np.float32)
    h, w = alpha.shape
    return Layer(0, Role.OBJECT, 1, 10.0, (0, 0, w, h), colour, alpha.copy(), weight.copy(),
                 (0.0, 0.0), 0.0, 0.0, water_srgb=water)


def test_water_in_front_of_a_submerged_part_is_the_image_own():
    """Over two backgrounds that differ by 40 levels: a dry pixel of full coverage hides
    the difference; a pixel deep under the water (weight 0.1 of its coverage 1) shows 90 %
    of it, with the modelled water taken out; without a modelled water, none of it."""
    alpha = np.ones((1, 2), np.float32)
    weight = np.array([[1.0, 0.1]], np.float32)
    out = {}
    for level in (80, 120):
        for water in ((100.0, 100.0, 100.0), None):
            img = np.full((1, 2, 3), level, np.uint8)
            over(img, _layer(alpha, weight, 60.0, water), [])
            out[level, water is None] = img[0, :, 0].astype(float)
    dry = out[120, False][0] - out[80, False][0]
    wet = out[120, False][1] - out[80, False][1]
    assert dry == 0 and wet == pytest.approx(36, abs=1)
    assert out[120, True][1] == out[80, True][1] == 60
    # where the background is the modelled water, the layer looks as it did before
    assert out[80, False][1] == pytest.approx(60 + 0.9 * (80 - 100), abs=1)


def test_footage_camera_blurs_and_grains_the_objects_only():
    rng = np.random.default_rng(0)
    photo = np.clip(rng.normal(110, 4, (64, 96, 3)), 0, 255).astype(np.uint8)
    cam = footage_camera(photo, 1.0, 0.8)
    assert cam.blur == pytest.approx(math.sqrt(0.8 ** 2 + 0.35 ** 2 - 0.45 ** 2), abs=1e-6)
    # the photo's own grain, in luma: 4 levels apart in each channel are 4 x 0.67 in luma
    assert 2.3 < cam.noise < 3.1
    assert footage_camera(photo, 2.0, 0.8).blur > cam.blur  # an enlarged crop is softer
    assert footage_camera(photo, 1.0, 0.0).blur == 0.0
    image = np.full((64, 96, 3), 100, np.uint8)
    image[20:40, 30:50] = 240  # a bright object, hard edged
    alpha = np.zeros((64, 96), np.float32)
    alpha[20:40, 30:50] = 1.0
    layer = _layer(alpha, alpha, 240.0, None)
    assert coverage((64, 96), [layer]).sum() == 400
    a = image.copy()
    harmonise(a, [layer], FootageCamera(1.2, 3.0), (1, 2))
    b = image.copy()
    harmonise(b, [layer], FootageCamera(1.2, 3.0), (1, 2))
    assert np.array_equal(a, b)  # deterministic per seed
    assert (a[:10] == 100).all() and (a[:, :20] == 100).all()  # far water untouched
    edge = a[30, 27:33, 0].astype(int)  # the object's edge is no longer a step
    assert 100 < edge[2] < 240 and 100 < edge[4] < 240
    inside = a[24:36, 34:46, 0].astype(float)
    assert 1.5 < inside.std() < 4.5  # grain on the object


def test_footage_is_not_enlarged_where_the_frame_is_large_enough(tmp_path):
    import cv2

    from sdcomp.render.photos import Backgrounds

    frame = np.random.default_rng(1).integers(0, 255, (300, 400, 3), np.uint8)
    cv2.imwrite(str(tmp_path / "f.png"), frame)
    bg = Backgrounds(tmp_path)
    for i in range(30):
        img, mag = bg.pick_scaled((i, 4), 320, 240)
        assert img.shape == (240, 320, 3) and 0.8 - 1e-9 <= mag <= 1.0 + 1e-9
        small, mag = bg.pick_scaled((i, 4), 640, 480)  # a frame smaller than the output
        assert 1.6 - 1e-9 <= mag <= 1.6 / 0.6 + 1e-9


# --------------------------------------------------------------------------- assets

def test_swimmers_treading_water_stir_it_and_others_do_not():
    poses = {v: sar.describe_variant("swimmer", v)["sub_type"] for v in range(20)}
    for v, pose in poses.items():
        s = stirring(f"swimmer-{v:02d}")
        assert s == {"tread": 1.0, "wave": 1.0, "distress": 1.0, "back": 0.4}.get(pose, 0.0)
    assert stirring("clutter:swimmer-00") == 1.0 and stirring("boat-03") == 0.0
    assert stirring("bluerov2") == 0.0


def test_jet_skis_are_mostly_white_with_one_accent():
    """Jet skis seen from above are white or light grey on 17 of 20 in the aerial-maritime
    lake photos (a few blue); one variant in eight is black (Kawasaki, performance)."""
    decks = [sar.describe_variant("jetski", v)["colours"]["deck"] for v in range(8)]
    light = sum(min(d) > 180 for d in decks)
    dark = sum(max(d) < 90 for d in decks)
    assert light >= 6 and dark >= 1
    hulls = [sar.describe_variant("jetski", v)["colours"]["hull"] for v in range(8)]
    assert sum(min(h) > 180 for h in hulls) >= 5
    accents = [sar.describe_variant("jetski", v)["colours"]["trim"] for v in range(8)]
    blue = sum(a[2] > 150 and a[0] < 60 for a in accents)
    red_orange = sum(a[0] > 180 and a[2] < 60 and a[1] < 130 for a in accents)
    assert blue >= 2 and red_orange <= 1, accents  # blue the makers' commonest
    for v in range(8):
        c = sar.describe_variant("jetski", v)["colours"]
        # black or grey saddles: the palette's lightest grey, 136, jittered by up to 4 %
        assert max(c["seat"]) <= 142


def test_decked_boats_carry_people_and_motor_boats_biminis():
    subs = {v: sar.describe_variant("boat", v) for v in range(12)}
    decked = [p for p in subs.values() if p["sub_type"] in ("motorboat", "rib",
                                                             "cabin_cruiser", "sailboat")]
    assert sum(len(p["people"]) for p in decked) >= 10
    assert all(len(p["people"]) >= 1 for p in decked if p["sub_type"] == "rib")
    tops = [(v, p) for v, p in subs.items() if p.get("bimini")]
    assert tops, "no motor boat with a bimini"
    v, p = tops[0]
    mesh = sar.build("boat", v)
    canvas = (mesh.face_colors == np.asarray(p["bimini"], np.uint8)).all(axis=1)
    z = mesh.vertices[np.unique(mesh.faces[canvas])][:, 2] - mesh.waterline
    assert canvas.sum() > 8 and z.min() > 1.2  # a canvas top well above the water
    crewed = next(v for v, p in subs.items() if p["sub_type"] == "motorboat" and p["people"])
    skin = np.asarray(subs[crewed]["people"][0]["skin"], np.uint8)
    assert (sar.build("boat", crewed).face_colors == skin).all(axis=1).any()


# --------------------------------------------------------------------------- sizes

def test_the_zoom_camera_of_seadronessees_1080p_frames():
    """``--preset seadronessee --camera zenmuse-z30 --width 1920 --height 1080``: the named
    camera replaces the preset's 4K one (its field of view and sensor): fx 2987 px at 1920
    wide, the focal length in pixels of the preset's 4K frames, so the boxes keep their
    pixel sizes (SeaDronesSee's 1080p swimmers: 36.7 px at the median, its 4K ones 37.1)."""
    from sdcomp.cli.generate import build_parser, config_from_args

    def model(*flags):
        return config_from_args(build_parser().parse_args(["--preset", "seadronessee",
                                                           *flags])).camera_model()

    four_k = model()
    z30 = model("--camera", "zenmuse-z30", "--width", "1920", "--height", "1080")
    assert (z30.width, z30.height) == (1920, 1080)
    assert z30.fx == pytest.approx(four_k.fx, rel=0.005) == pytest.approx(2987, rel=0.005)
    # a field of view given with the camera still wins
    wide = model("--camera", "zenmuse-z30", "--fov", "60", "--width", "1920", "--height",
                 "1080")
    assert wide.fx < 0.7 * z30.fx
