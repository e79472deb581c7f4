"""The compositor's annotations: pixel size (GSD), occlusion, water, frame edges, masks.

Constructed scenes (nadir camera, no camera effects, no clutter) check the geometry and the
mask rule of :mod:`sdcomp.render` and :mod:`sdcomp.annotate` against numbers worked out by
hand; sampled scenes
check that bbox and area always derive from the instance map, and that rendering is
deterministic.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest
import trimesh

from sdcomp.annotate import MASK_THRESHOLD, AnnotationRule
from sdcomp.assets.export import export_mesh
from sdcomp.assets.library import MeshSpec
from sdcomp.assets.mesh import ColoredMesh
from sdcomp.pipeline import Generator
from sdcomp.render import effects
from sdcomp.render.ground import perspective_sample
from sdcomp.scene import objects
from sdcomp.scene.camera import CameraPose
from sdcomp.scene.config import GeneratorConfig, ObjectSpec
from sdcomp.scene.look_table import clean_look
from sdcomp.scene.sample import object_asset
from sdcomp.scene.scene import Placement, Role
from sdcomp.scene.water import WaterParams, constituents

from .conftest import box_mesh

BOX = (2.0, 1.0, 0.3)  # metres: length (body x), beam (body y), height
PYRAMID = (1.5, 0.6)  # metres: square base side, height
WATERLINE_FRACTION = 0.25  # a mesh file floats with a quarter of its height under water
#: the test's turbidity -> (water type, place in its range): clear ocean, a middling lake
#: (about 0.6 of an object's image left 0.2 m down, a third 0.5 m down), murky river water
WATERS = {0.0: ("ocean", 0.0), 0.5: ("lake", 0.5), 1.0: ("turbid", 1.0)}
BOX_MODEL, PYRAMID_MODEL = 0, 1
W, H = 2000, 1500


# --------------------------------------------------------------------------- fixtures

def _pyramid_mesh(base: float, height: float) -> ColoredMesh:
    pts = np.array([[-base / 2, -base / 2, 0], [base / 2, -base / 2, 0],
                    [base / 2, base / 2, 0], [-base / 2, base / 2, 0], [0, 0, height]])
    faces = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 2, 1], [0, 3, 2]])
    assert trimesh.Trimesh(pts, faces).is_volume  # closed, normals outwards
    cols = np.tile(np.array((230, 200, 40), np.uint8), (len(faces), 1))
    return ColoredMesh(pts, faces, cols, 0.0, "tc_pyramid", closed=True)


@pytest.fixture(scope="module")
def shapes(tmp_path_factory, sprites_dir) -> Generator:
    """2000 x 1500 images of a box (model 0) and a square pyramid (model 1) from PLY files."""
    d = tmp_path_factory.mktemp("compositor_meshes")
    box = export_mesh(box_mesh(size=BOX, colour=(200, 60, 40), name="tc_box"),
                      d / "tc_box.ply")
    pyr = export_mesh(_pyramid_mesh(*PYRAMID), d / "tc_pyramid.ply")
    cfg = GeneratorConfig(width=W, height=H, clutter=0, shadows=False, count=1,
                          objects=(ObjectSpec(str(box)), ObjectSpec(str(pyr))))
    return Generator(cfg, sprites_dir)


ROV_CONFIG = GeneratorConfig(seed=11, clutter=0, count="3-8", altitude="8-16",
                             draft="0-1.5", turbidity="0-1", amodal=True)


@pytest.fixture(scope="module")
def rov(sprites_dir) -> Generator:
    """Sampled 416 x 416 BlueROV2 scenes: several objects, some deep, any turbidity."""
    return Generator(ROV_CONFIG, sprites_dir)


# --------------------------------------------------------------------------- helpers

def _obj(model: int, x: float = 0.0, y: float = 0.0, heading: float = 0.0,
         draft: float = 0.0, roll: float = 0.0, pitch: float = 0.0) -> Placement:
    """Object ``model`` (its index in the config's objects; the asset key is filled in by
    :func:`_scene`)."""
    return Placement(Role.OBJECT, "", model + 1, x, y, heading, roll, pitch, draft)


def _water(turbidity: float) -> WaterParams:
    """Deep, uniform water of the test's ``turbidity`` (:data:`WATERS`) under a clear sky
    and a high sun, a light breeze."""
    kind, t = WATERS[turbidity]
    chl, cdom, tsm = constituents(kind, t)
    return WaterParams(name=kind, water_type=kind, chl=chl, cdom=cdom, tsm=tsm, turbidity=t,
                       patchiness=0.0, wind=3.0, sky="clear", sun_elevation=70.0,
                       sun_azimuth=30.0, seed=1)


def _scene(gen: Generator, placements, altitude: float = 20.0, turbidity: float = 0.0):
    """Image 0's scene with a nadir camera (heading 0), the given objects, a high sun, a
    clean camera (no lens, no noise: the pinhole image)."""
    placements = [replace(p, asset=object_asset(gen.config, p.category_id - 1))
                  for p in placements]
    m = gen.model
    return replace(gen.scene(0), placements=tuple(placements),
                   camera=CameraPose(altitude, 90.0, 0.0), water=_water(turbidity),
                   look=clean_look(m.width, m.height, m.fx, m.fy), defocus_blur=None,
                   shore=None, hills=None)


def _render(gen: Generator, placements, **kw):
    return _annotated(gen, _scene(gen, placements, **kw))


def _annotated(gen: Generator, scene):
    """``scene`` rendered and annotated with amodal masks."""
    return gen.render_scene(scene, AnnotationRule(gen.config.min_visible_px, amodal=True))


def _find(frame, placement: int):
    """(instance, visible mask) of the object placed ``placement``-th (None if dropped)."""
    for inst in frame.objects:
        if inst.placement == placement:
            return inst, frame.instances == inst.instance_id
    return None, None


def _visible(frame) -> np.ndarray:
    """(H, W) bool: every visible pixel of an object of interest, labelled or ignored."""
    ignore = frame.ignore if frame.ignore is not None else np.zeros_like(frame.instances, bool)
    return (frame.instances > 0) | ignore


def _check_annotations(frame, min_visible_px: int = 1) -> None:
    """ids 1..N; area, bbox from the instance map; visible inside amodal; ignored objects'
    pixels are the ignore mask, apart from the labels; drop count."""
    n = len(frame.objects)
    assert [o.instance_id for o in frame.objects] == list(range(1, n + 1))
    assert frame.instances.dtype == np.uint16
    assert frame.instances.shape == frame.image.shape[:2]
    assert set(np.unique(frame.instances).tolist()) <= set(range(n + 1))
    for o in frame.objects:
        m = frame.instances == o.instance_id
        assert o.area == int(m.sum()) >= min_visible_px
        ys, xs = np.nonzero(m)
        assert o.bbox == (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
        pl = frame.scene.placements[o.placement]
        assert pl.role is Role.OBJECT and o.category_id == pl.category_id
        if o.amodal is not None:
            assert o.amodal.shape == m.shape and o.amodal_area == int(o.amodal.sum())
            assert not (m & ~o.amodal).any(), "visible pixels outside the amodal mask"
    placed = sum(p.role is Role.OBJECT for p in frame.scene.placements)
    assert frame.dropped == placed - n - len(frame.ignored)
    if frame.ignore is None:
        assert frame.ignored == []
        return
    assert frame.ignore.shape == frame.instances.shape and frame.ignore.dtype == bool
    assert not (frame.ignore & (frame.instances > 0)).any()
    assert sum(o.area for o in frame.ignored) >= int(frame.ignore.sum()) > 0
    for o in frame.ignored:
        x, y, w, h = o.bbox
        assert o.instance_id == 0 and frame.ignore[y:y + h, x:x + w].sum() >= o.area
        assert frame.scene.placements[o.placement].role is Role.OBJECT


# --------------------------------------------------------------------------- 1. GSD

@pytest.mark.parametrize("altitude", [20.0, 40.0])
@pytest.mark.parametrize("heading", [0.0, 90.0])
def test_box_pixel_size_matches_gsd(shapes, altitude, heading):
    """Nadir, camera heading 0: image columns run along world -y, rows along world -x. A box
    at heading 0 spans beam * fx / altitude columns and length * fy / altitude rows."""
    model = shapes.model
    frame = _render(shapes, [_obj(BOX_MODEL, heading=heading)], altitude=altitude)
    _check_annotations(frame)
    assert frame.gsd == pytest.approx(altitude / model.fx, rel=1e-12)
    (inst,) = frame.objects
    along_cols, along_rows = (BOX[1], BOX[0]) if heading == 0 else (BOX[0], BOX[1])
    want_w, want_h = along_cols * model.fx / altitude, along_rows * model.fy / altitude
    x, y, w, h = inst.bbox
    assert abs(w - want_w) <= 0.02 * want_w, (w, want_w)
    assert abs(h - want_h) <= 0.02 * want_h, (h, want_h)
    # centred on the principal point, to a pixel
    assert abs(x + w / 2 - W / 2) <= 1.0 and abs(y + h / 2 - H / 2) <= 1.0
    # a box seen from above fills its bbox
    assert inst.area >= 0.9 * w * h


def test_bluerov2_pixel_size_at_10m(sprites_dir):
    cfg = GeneratorConfig(width=1000, height=750, clutter=0, shadows=False, count=1)
    gen = Generator(cfg, sprites_dir)
    length, beam = MeshSpec("bluerov2").load().extents[:2]  # about 0.46 m x 0.41 m
    frame = _render(gen, [_obj(0)], altitude=10.0)
    _check_annotations(frame)
    assert frame.gsd == pytest.approx(10.0 / gen.model.fx, rel=1e-12)
    (inst,) = frame.objects
    want_w, want_h = beam * gen.model.fx / 10.0, length * gen.model.fy / 10.0
    _, _, w, h = inst.bbox
    assert abs(w - want_w) <= 2 + 0.02 * want_w, (w, want_w)
    assert abs(h - want_h) <= 2 + 0.02 * want_h, (h, want_h)


@pytest.mark.parametrize("heading", [33.0, 90.0, 200.0])
def test_mask_turns_with_camera_heading(shapes, heading):
    """Turning the camera and the object by the same angle leaves the image of the object
    unchanged (nadir, object on the optical axis)."""
    ref = _render(shapes, [_obj(BOX_MODEL)])
    scene = _scene(shapes, [_obj(BOX_MODEL, heading=heading)])
    turned = _annotated(shapes, replace(scene, camera=CameraPose(20.0, 90.0, heading)))
    _check_annotations(turned)
    (a,), (b,) = ref.objects, turned.objects
    differ = (ref.instances > 0) != (turned.instances > 0)
    assert differ.sum() <= 0.01 * a.area
    assert abs(a.bbox[2] - b.bbox[2]) <= 1 and abs(a.bbox[3] - b.bbox[3]) <= 1


def test_oblique_gsd_at_image_centre(shapes):
    """Camera pitched 50 degrees down: an object where the optical axis meets the sea spans
    its size / frame.gsd across, with frame.gsd = slant distance / fx. (Object heading 180:
    seen from body azimuth 0, 40 degrees off nadir, a pose the atlas stores exactly.)"""
    alt, pitch = 20.0, 50.0
    scene = _scene(shapes, [_obj(BOX_MODEL, x=alt / math.tan(math.radians(pitch)),
                                 heading=180.0)])
    frame = shapes.render_scene(replace(scene, camera=CameraPose(alt, pitch, 0.0)))
    _check_annotations(frame)
    gsd = alt / math.sin(math.radians(pitch)) / shapes.model.fx
    assert frame.gsd == pytest.approx(gsd, rel=1e-9)
    (inst,) = frame.objects
    x, y, w, h = inst.bbox
    want = BOX[1] / gsd  # the beam lies across the view
    assert abs(w - want) <= 1 + 0.02 * want, (w, want)
    assert abs(x + w / 2 - W / 2) <= 1.5 and y < H / 2 < y + h


# --------------------------------------------------------------------------- 2. occlusion

@pytest.mark.parametrize("turbidity,draft", [(0.0, 1.0), (0.5, 0.4)], ids=["clear", "dim"])
def test_floating_object_hides_submerged_one(shapes, turbidity, draft):
    """A: a box deep under water (clear: ~0.8 m under clear water, weight ~0.8; dim: ~0.2 m
    under middling water, weight ~0.65, still seen whole). B: a floating box over part of it."""
    deep = _obj(BOX_MODEL, draft=draft)
    floating = _obj(BOX_MODEL, x=0.7, y=0.25, heading=65.0)
    both = _render(shapes, [deep, floating], turbidity=turbidity)
    alone = _render(shapes, [deep], turbidity=turbidity)
    _check_annotations(both)
    _check_annotations(alone)
    a_inst, a = _find(both, 0)
    b_inst, b = _find(both, 1)
    a_alone_inst, a_alone = _find(alone, 0)
    assert a_inst is not None and b_inst is not None and a_alone_inst is not None
    b_full = b_inst.amodal
    assert (a_alone & b_full).sum() > 1000 and (a_alone & ~b_full).sum() > 1000  # partial
    # the deep object is seen whole in clear water when alone
    assert a_alone_inst.area > 0.95 * a_alone_inst.amodal_area
    # nothing hides the floating object: its mask is its amodal mask
    assert np.array_equal(b, b_full)
    # A has no pixel in the interior of B; A's area shrinks; amodal A is unchanged
    kernel = np.ones((3, 3), np.uint8)
    interior = cv2.erode(b_full.astype(np.uint8), kernel).astype(bool)
    assert not (a & interior).any()
    assert a_inst.area < a_alone_inst.area
    assert np.array_equal(a_inst.amodal, a_alone_inst.amodal)
    # away from B's 1-px border, A's mask is A alone minus B's coverage
    band = cv2.dilate(b_full.astype(np.uint8), kernel).astype(bool) & ~interior
    assert np.array_equal(a[~band], (a_alone & ~b_full)[~band])
    assert not (a & b).any()
    assert not (a & ~a_alone).any(), "an object in front added pixels to A's mask"
    # B's soft edge (coverage under 0.5, just outside its amodal mask) also takes its share
    # of A's weight: a dim A loses most of the pixels there
    ring = band & ~b_full
    kept, before = (a & ring).sum(), (a_alone & ring).sum()
    assert before > 50
    if turbidity > 0:
        assert kept < 0.75 * before, (kept, before)


def test_occlusion_order_follows_depth_not_placement_order(shapes):
    """The floating object listed first still hides the deep one listed second."""
    frame = _render(shapes, [_obj(BOX_MODEL, x=0.7, y=0.25, heading=65.0),
                             _obj(BOX_MODEL, draft=1.0)])
    _check_annotations(frame)
    front, f = _find(frame, 0)
    back, _ = _find(frame, 1)
    assert front is not None and back is not None
    assert np.array_equal(f, front.amodal)
    assert back.area < back.amodal_area * 0.9


# --------------------------------------------------------------------------- 3. water

def test_half_submerged_clear_vs_turbid(shapes):
    """A square pyramid with the sea at half its height: the outer three quarters of its top
    view are under water, up to 0.3 m deep."""
    half = (0.5 - WATERLINE_FRACTION) * PYRAMID[1]  # draft putting half its height under
    pl = [_obj(PYRAMID_MODEL, draft=half)]
    clear = _render(shapes, pl, altitude=10.0, turbidity=0.0)
    murky = _render(shapes, pl, altitude=10.0, turbidity=1.0)
    for f in (clear, murky):
        _check_annotations(f)
    c_inst, c = _find(clear, 0)
    m_inst, m = _find(murky, 0)
    assert c_inst is not None and m_inst is not None
    assert np.array_equal(c_inst.amodal, m_inst.amodal)
    assert c_inst.area / c_inst.amodal_area > 0.9
    assert m_inst.area / m_inst.amodal_area < 0.8
    assert not (m & ~c).any(), "turbid-water mask not inside the clear-water mask"
    assert c_inst.category_id == PYRAMID_MODEL + 1


@pytest.mark.parametrize("model", [BOX_MODEL, PYRAMID_MODEL])
def test_fully_submerged_dropped_only_in_turbid_water(shapes, model):
    pl = [_obj(model, draft=2.0)]
    clear = _render(shapes, pl, altitude=10.0, turbidity=0.0)
    murky = _render(shapes, pl, altitude=10.0, turbidity=1.0)
    _check_annotations(clear)
    _check_annotations(murky)
    assert clear.dropped == 0 and len(clear.objects) == 1
    assert clear.objects[0].area > 0.5 * clear.objects[0].amodal_area
    assert murky.dropped == 1 and murky.objects == []
    assert not murky.instances.any()


def test_tilted_box_low_end_hidden_by_turbid_water(shapes):
    """A 2 m box pitched 30 degrees about its waterline centre: the top face runs from
    0.225 cos 30 + sin 30 = 0.70 m above the sea to 0.31 m below it, so murky water hides
    about a quarter of the box from above (as it hides the pyramid's submerged skirt)."""
    tilted = _obj(BOX_MODEL, pitch=30.0)
    clear = _render(shapes, [tilted], altitude=10.0, turbidity=0.0)
    murky = _render(shapes, [tilted], altitude=10.0, turbidity=1.0)
    (c,), (m,) = clear.objects, murky.objects
    assert c.area > 0.95 * c.amodal_area
    assert m.area < 0.9 * m.amodal_area, (m.area, m.amodal_area)


# --------------------------------------------------------------------------- 4. frame edge

EDGES = {  # placement offset (x, y) in half-frames; nadir, heading 0: u = W/2 - y fx / z
    "left": (0.0, 1.0), "right": (0.0, -1.0), "top": (1.0, 0.0), "bottom": (-1.0, 0.0)}


@pytest.mark.parametrize("edge", list(EDGES))
def test_object_cut_by_frame_edge(shapes, edge):
    model, alt = shapes.model, 10.0
    # the box's centre is a quarter of its height above its waterline, above the sea
    z = alt - (0.5 - WATERLINE_FRACTION) * BOX[2]
    ex, ey = EDGES[edge]
    cut = _render(shapes, [_obj(BOX_MODEL, x=ex * H / 2 * z / model.fy,
                                y=ey * W / 2 * z / model.fx)], altitude=alt)
    whole = _render(shapes, [_obj(BOX_MODEL)], altitude=alt)
    _check_annotations(cut)
    (c,), (f,) = cut.objects, whole.objects
    x, y, w, h = c.bbox
    assert 0 <= x and 0 <= y and x + w <= W and y + h <= H
    touches = {"left": x == 0, "right": x + w == W, "top": y == 0, "bottom": y + h == H}
    assert touches[edge], c.bbox
    assert 0.3 < c.area / f.area < 0.7
    # the amodal mask is clipped to the frame too, and touches the same edge
    assert c.amodal.shape == (H, W)
    assert 0.3 < c.amodal_area / f.amodal_area < 0.7
    border = {"left": c.amodal[:, 0], "right": c.amodal[:, -1], "top": c.amodal[0],
              "bottom": c.amodal[-1]}
    assert border[edge].any()


def test_object_outside_frame_is_dropped(shapes):
    model = shapes.model
    frame = _render(shapes, [_obj(BOX_MODEL), _obj(BOX_MODEL, y=W * 20.0 / model.fx)])
    _check_annotations(frame)
    assert frame.dropped == 1 and [o.placement for o in frame.objects] == [0]


# --------------------------------------------------------------------------- 5. sampled

INDICES = range(6)


@pytest.fixture(scope="module")
def rov_frames(rov):
    return {i: rov.render(i) for i in INDICES}


@pytest.mark.parametrize("i", INDICES)
def test_sampled_annotations_derive_from_masks(rov, rov_frames, i):
    frame = rov_frames[i]
    _check_annotations(frame, ROV_CONFIG.min_visible_px)
    assert frame.image.shape == (416, 416, 3) and frame.image.dtype == np.uint8
    # one object per pixel at most (the rule's threshold is a half): the areas add up to
    # the labelled pixels, none of them left over from a dropped object
    assert MASK_THRESHOLD == 0.5
    assert sum(o.area for o in frame.objects) == int((frame.instances > 0).sum())


def test_sampled_frames_have_several_and_occluded_objects(rov_frames):
    """The sampled scenes are not trivial: several objects, some partly hidden."""
    n = sum(len(f.objects) for f in rov_frames.values())
    hidden = sum(o.area < o.amodal_area for f in rov_frames.values() for o in f.objects)
    assert n >= 2 * len(INDICES) and hidden >= 1


def test_min_visible_px(rov, rov_frames, sprites_dir):
    # a limit equal to an object's area: that object is kept (fewer pixels than the limit
    # are not labelled but ignored: their pixels become the ignore mask), smaller ones go
    areas = sorted(o.area for f in rov_frames.values() for o in f.objects)
    limit = areas[len(areas) // 2]
    gen = Generator(replace(ROV_CONFIG, min_visible_px=limit), sprites_dir)
    none = Generator(replace(ROV_CONFIG, min_visible_px=10**8), sprites_dir)
    kept_any = dropped_any = False
    for i in INDICES:
        base = rov_frames[i]
        f = gen.render(i)
        _check_annotations(f, limit)
        assert np.array_equal(f.image, base.image)
        # the same objects as the default limit, less those under the new limit
        want = [(o.placement, o.area, o.bbox) for o in base.objects if o.area >= limit]
        assert [(o.placement, o.area, o.bbox) for o in f.objects] == want
        small = [(o.placement, o.area, o.bbox) for o in base.objects if o.area < limit]
        assert small == [(o.placement, o.area, o.bbox) for o in f.ignored
                         if o.placement in {p for p, _, _ in small}]
        assert np.array_equal(_visible(f), _visible(base))  # every visible pixel accounted
        for o in f.objects:  # pixels kept as they were, ids renumbered
            old = next(b for b in base.objects if b.placement == o.placement)
            assert np.array_equal(f.instances == o.instance_id,
                                  base.instances == old.instance_id)
        kept_any |= any(o.area == limit for o in f.objects)
        dropped_any |= len(want) < len(base.objects)
        empty = none.render(i)
        placed = sum(p.role is Role.OBJECT for p in empty.scene.placements)
        assert empty.objects == [] and empty.dropped + len(empty.ignored) == placed > 0
        assert not empty.instances.any()
        assert np.array_equal(_visible(empty), _visible(base))
    assert kept_any and dropped_any


def test_sampled_oblique_frames_annotations_derive_from_masks(sprites_dir):
    """Oblique views with a horizon, hills and a shore: the same invariants."""
    cfg = replace(ROV_CONFIG, seed=5, pitch="20-60", shore=1.0, hills=1.0, width=320,
                  height=240)
    gen = Generator(cfg, sprites_dir)
    n = 0
    for i in range(4):
        frame = gen.render(i)
        _check_annotations(frame, cfg.min_visible_px)
        assert frame.scene.camera.pitch < 90
        p = math.radians(frame.scene.camera.pitch)
        assert frame.gsd == pytest.approx(frame.scene.camera.altitude / math.sin(p)
                                          / gen.model.fx / frame.camera["zoom"])
        n += len(frame.objects)
    assert n >= 2


# --------------------------------------------------------------------------- 6. determinism

def test_render_is_deterministic(rov, rov_frames, sprites_dir):
    again = rov.render(2)
    other = Generator(ROV_CONFIG, sprites_dir).render(2)
    base = rov_frames[2]
    for f in (again, other):
        assert np.array_equal(f.image, base.image)
        assert np.array_equal(f.instances, base.instances)
        assert [(o.placement, o.area, o.bbox) for o in f.objects] == [
            (o.placement, o.area, o.bbox) for o in base.objects]
    assert not np.array_equal(rov_frames[3].image, base.image)
    assert not np.array_equal(rov_frames[3].instances, base.instances)


# --------------------------------------------------------------------------- 7. Sample API

def test_sample_arrays_annotations_and_metadata(rov, rov_frames):
    i = 5  # six objects, some partly hidden
    s = rov.sample(i)
    frame = rov_frames[i]
    n = len(s.annotations)
    assert n == len(frame.objects) > 0
    assert np.array_equal(s.image, frame.image) and np.array_equal(s.instances, frame.instances)
    masks = s.masks
    assert masks.shape == (n, 416, 416) and masks.dtype == bool
    for k in range(n):
        assert np.array_equal(masks[k], s.instances == k + 1)
    assert masks.sum(axis=0).max() <= 1
    pose_keys = {"heading_deg", "roll_deg", "pitch_deg", "draft_m", "x_m", "y_m"}
    for k, (a, o) in enumerate(zip(s.annotations, frame.objects, strict=True)):
        assert a["instance_id"] == k + 1
        assert a["category_id"] == o.category_id == 1 and a["category"] == "bluerov2"
        assert a["bbox"] == list(o.bbox) and a["area"] == o.area == int(masks[k].sum())
        assert set(a["pose"]) == pose_keys
        pl = frame.scene.placements[o.placement]
        assert a["pose"]["draft_m"] == round(pl.draft, 4)
        assert a["pose"]["x_m"] == round(pl.x, 3) and a["pose"]["y_m"] == round(pl.y, 3)
    meta, sc = s.meta, frame.scene
    for key in ("height_above_takeoff(meter)", "gimbal_pitch(degrees)",
                "gimbal_heading(degrees)", "gsd(m/px)", "water_color", "water_rgb",
                "turbidity", "attenuation(1/m)", "sun_elevation(degrees)",
                "sun_azimuth(degrees)", "objects_placed", "objects_dropped"):
        assert key in meta, key
    assert meta["height_above_takeoff(meter)"] == round(sc.camera.altitude, 4)
    assert meta["gimbal_pitch(degrees)"] == round(sc.camera.pitch, 4)
    # DJI's convention: clockwise from north (+y), -180 to 180
    assert meta["gimbal_heading(degrees)"] == round((90 - sc.camera.heading + 180) % 360 - 180, 4)
    # the sun's azimuth in the same convention: the difference is the view's angle from it
    assert meta["sun_azimuth(degrees)"] == round((90 - sc.water.sun_azimuth + 180) % 360 - 180,
                                                 3)
    assert meta["gsd(m/px)"] == pytest.approx(
        sc.camera.altitude / rov.model.fx / frame.camera["zoom"], abs=1e-6)
    assert meta["turbidity"] == round(sc.water.turbidity, 4)
    assert meta["water_color"] in ("brown", "blue", "green")
    assert meta["camera_look"] == sc.look.preset and meta["camera_stages"] == list(
        frame.camera["stages"])
    assert meta["objects_placed"] - meta["objects_dropped"] - meta["objects_ignored"] == n
    assert meta["objects_truncated"] == sum(o.truncated for o in frame.objects) <= n


# --------------------------------------------------------------------------- 8. huge frames

def test_huge_frame_blur_is_done_on_a_reduced_copy_in_place(monkeypatch, rov):
    monkeypatch.setattr(effects, "BLUR_EXACT_MAX", 100)
    monkeypatch.setattr(effects, "BLUR_WORK_SIZE", 50)
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (150, 200, 3), dtype=np.uint8)  # white noise: all detail
    out = effects.blur(image.copy(), (24.0, 30.0), None)
    assert out.shape == image.shape and out.dtype == np.uint8
    # blurred: the pixel-to-pixel detail is gone, the mean brightness stays
    assert np.abs(np.diff(out.astype(np.int16), axis=1)).mean() < 0.2 * np.abs(
        np.diff(image.astype(np.int16), axis=1)).mean()
    assert abs(float(out.mean()) - float(image.mean())) < 2.0
    target = image.copy()
    assert effects.blur(target, None, 8.0) is target


def test_rgb_to_bgr_in_place_by_bands():
    from sdcomp.run.record import rgb_to_bgr_in_place

    image = np.random.default_rng(1).integers(0, 256, (37, 11, 3), dtype=np.uint8)
    want = image[..., ::-1].copy()
    assert rgb_to_bgr_in_place(image, band_bytes=100) is image  # 3 rows per band
    assert np.array_equal(image, want)


@pytest.mark.parametrize("n", [17, 31])
def test_long_motion_blur_is_a_line_mean(n):
    """From LINE_TAPS_MIN taps on, motion blur sums shifted frames: along the rows or the
    columns it is a centred box mean with reflected borders (as cv2.blur computes it), a
    flat image stays flat, and along a diagonal it stays close to the dense line kernel."""
    assert n >= effects.LINE_TAPS_MIN
    rng = np.random.default_rng(n)
    image = rng.integers(0, 256, (60, 90, 3), dtype=np.uint8)
    for angle, size in ((0.0, (n, 1)), (90.0, (1, n)), (180.0, (n, 1))):
        want = cv2.blur(image, size, borderType=cv2.BORDER_REFLECT)
        got = effects.motion_blur(image, float(n), angle)
        assert got.shape == image.shape and got.dtype == np.uint8
        assert np.abs(got.astype(int) - want).max() <= 1  # rounding only
    flat = np.full((40, 50, 3), 77, np.uint8)
    assert (effects.motion_blur(flat, float(n), 33.0) == 77).all()
    smooth = cv2.resize(image[:20, :30], (300, 200), interpolation=cv2.INTER_CUBIC)
    dense = cv2.filter2D(smooth, -1, effects.motion_kernel(float(n), 33.0),
                         borderType=cv2.BORDER_REFLECT)
    got = effects.motion_blur(smooth, float(n), 33.0)
    change = np.abs(dense.astype(int) - smooth).mean()
    assert np.abs(got.astype(int) - dense).mean() < 0.3 * change  # taps up to ~2 px apart


def test_small_frames_render_on_one_opencv_thread(rov, monkeypatch):
    """A 416 px frame is drawn with OpenCV on one thread and the process's count comes
    back afterwards, also when rendering fails; the pixels do not depend on it."""
    seen = []
    real = rov.compositor._render
    before = cv2.getNumThreads()
    try:
        cv2.setNumThreads(2)

        def spy(scene):
            seen.append(cv2.getNumThreads())
            return real(scene)

        monkeypatch.setattr(rov.compositor, "_render", spy)
        a = rov.compositor.render(rov.scene(3))
        assert seen == [1] and cv2.getNumThreads() == 2
        monkeypatch.setattr(rov.compositor, "_render", lambda *_: 1 / 0)
        with pytest.raises(ZeroDivisionError):
            rov.compositor.render(rov.scene(3))
        assert cv2.getNumThreads() == 2
        monkeypatch.setattr(rov.compositor, "_render", real)
        cv2.setNumThreads(1)
        b = rov.compositor.render(rov.scene(3))
        assert np.array_equal(a.image, b.image)
        assert [lay.weight.tobytes() for lay in a.layers] == [
            lay.weight.tobytes() for lay in b.layers]
    finally:
        cv2.setNumThreads(before)


def test_line_mean_in_bands_equals_one_band(monkeypatch):
    """Bands of rows (with the rows they share reflected only at the frame's edges) give
    the same pixels as one band for the whole frame."""
    image = np.random.default_rng(5).integers(0, 256, (300, 70, 3), dtype=np.uint8)
    whole = effects.line_mean(image, 17, 63.0)
    monkeypatch.setattr(effects, "LINE_BAND_BYTES", 1)  # bands of 8 n rows: 3 here
    assert np.array_equal(effects.line_mean(image, 17, 63.0), whole)
    assert np.array_equal(effects.line_mean(image[..., 0], 17, 63.0), whole[..., 0])


# --------------------------------------------------------------------------- 9. sprite levels

def test_sprite_levels_are_box_filters_of_the_atlas(rov):
    """Level L of a pose (made by halving level L - 1) is the atlas's premultiplied
    channels averaged over 2**L x 2**L blocks, whatever order the levels are asked in."""
    src = rov.compositor.assets.sprites["bluerov2"]
    base = src.base(5).astype(np.float64)
    for level in (3, 1, 2, 5):
        n = src.size >> level
        block = base.reshape(n, 1 << level, n, 1 << level, 8).mean(axis=(1, 3))
        np.testing.assert_allclose(src.level(5, level), block, atol=1e-5)


def test_warm_prepares_everything_a_416_frame_uses(sprites_dir):
    """After Generator.warm(), rendering default 416 px images (objects and clutter) adds
    nothing to the sprite caches and builds no mesh to measure (every object's footprint
    and visible hull are known), so forked workers share what the parent prepared; the
    pixels are the same as without it."""
    config = GeneratorConfig(seed=3)
    warm = Generator(config, sprites_dir)
    warm.warm()
    sources = list(warm.compositor.assets.sprites.values())
    assert len(sources) > 1

    def entries() -> int:
        return sum(s.cached() for s in sources)

    before, measured = entries(), objects._sizes.cache_info()
    assert measured.currsize >= len(sources) - 1  # all but foam
    images = [warm.render(i) for i in range(40)]
    assert entries() == before
    assert objects._sizes.cache_info().misses == measured.misses
    cold = Generator(config, sprites_dir)
    for i, a in enumerate(images):
        b = cold.render(i)
        assert np.array_equal(a.image, b.image) and np.array_equal(a.instances, b.instances)


# --------------------------------------------------------------------------- oblique textures

def test_texture_rows_are_the_texture_at_each_ground_point(rov):
    """Texture.sample_rows (one ground line per row) equals sampling every point
    (x0 + scale_i u_j, y0 + y_i) by itself, wrapped into the tile's period, to within a
    level (the sampling position is rounded to 1/32 texel either way)."""
    tile = rov.compositor.assets.textures.land
    rng = np.random.default_rng(4)
    scale = rng.uniform(2.0, 40.0, 50)
    u = np.linspace(-0.7, 0.7, 90)
    y_rows = rng.uniform(-300.0, 300.0, 50)
    x0, y0, pitch_m = 123.4, -56.7, 0.3
    rows = tile.sample_rows(x0, y0, scale, u, y_rows, pitch_m)
    k = int(math.floor(math.log2(pitch_m / tile.pitch)))
    per, px = tile.period >> k, tile.pitch * 2 ** k
    x = (x0 + scale[:, None] * u[None, :]) / px % per
    y = np.broadcast_to((y0 + y_rows[:, None]) / px % per, x.shape)
    want = cv2.remap(tile.levels[k][:per, :per], x.astype(np.float32), y.astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    assert rows.shape == want.shape == (50, 90, 3)
    assert np.abs(rows.astype(int) - want).max() <= 1


def test_oblique_view_rows_above_the_horizon_and_far_away_are_the_mean(rov):
    """Looking 15 degrees down, rows above the horizon and rows whose pixels span many
    texels are the tile's mean colour; near rows carry the texture."""
    tile = rov.compositor.assets.textures.land
    out = perspective_sample(rov.model, 20.0, 15.0, tile, 3.0, 7.0)
    mean = np.clip(tile.mean + 0.5, 0, 255).astype(np.uint8)
    horizon = rov.model.height / 2 - rov.model.fy * math.tan(math.radians(15.0))
    assert 50 < horizon < 150
    assert (out[:int(horizon)] == mean).all()
    assert (out[int(horizon) + 1:int(horizon) + 4] == mean).all()  # far: faded
    assert out[-20:].std(axis=(0, 1)).min() > 2  # near: texture
