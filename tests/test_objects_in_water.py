"""Floating objects in the water: their light, the waterline, what the water does to the parts
below it, the contact foam, and the annotation rules that go with them (truncation at the
frame's edge, labels moved by the camera's lens).

The physics pieces are checked against their formulas (Lambert, Fresnel, Beer-Lambert through
the water column of Lee et al. 1999); the rest on rendered frames.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sdcomp.annotate import AnnotationRule
from sdcomp.pipeline import Generator
from sdcomp.render.foam import contact_foam, ring_strength
from sdcomp.render.lighting import lambert
from sdcomp.render.submerge import (
    LUMA,
    WaterColumn,
    apparent_depth,
    refract,
    submerge,
    water_columns,
    waterline_level,
)
from sdcomp.render.water.optics import N_WATER, fresnel, refracted_cos
from sdcomp.scene.camera import CameraPose
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.look_table import clean_look
from sdcomp.scene.sample import object_asset
from sdcomp.scene.scene import Placement, Role
from sdcomp.scene.water import WaterParams, constituents
from sdcomp.util.colour import srgb_to_linear

# --------------------------------------------------------------------------- light


def test_lambert_matches_the_hemisphere_formula():
    """A surface facing up sees the sun at cos(zenith) and the whole sky; facing down, the
    sea's upwelling light only; tilted 90 degrees, half of each; never the sun from behind."""
    albedo = np.full((1, 4, 3), 0.5, np.float32)
    normal = np.array([[[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0]]], np.float32)
    sun_dir = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    sun, sky, up = (np.array(v, np.float32) for v in ((2.0, 2.0, 2.0), (0.4, 0.5, 0.6),
                                                      (0.05, 0.06, 0.07)))
    out = lambert(albedo, normal, sun_dir, np.array([0.0, 0.0, 1.0]), sun, sky, up)
    k = 0.5 / math.pi
    np.testing.assert_allclose(out[0, 0], k * (sun * math.cos(0.5) + sky), rtol=1e-5)
    np.testing.assert_allclose(out[0, 1], k * up, rtol=1e-5)
    np.testing.assert_allclose(out[0, 2], k * (sun * math.sin(0.5) + (sky + up) / 2),
                               rtol=1e-5)
    np.testing.assert_allclose(out[0, 3], k * (sky + up) / 2, rtol=1e-5)


# --------------------------------------------------------------------------- the water column

def _light(gen: Generator, water: WaterParams):
    from sdcomp.render.water.surface import view_water

    return view_water(gen.model, CameraPose(20.0, 90.0, 0.0), water,
                      gen.compositor.assets.textures.water).light


@pytest.fixture(scope="module")
def gen(sprites_dir) -> Generator:
    return Generator(GeneratorConfig(seed=2, clutter=0, count=1), sprites_dir)


def _water(kind: str, t: float, **kw) -> WaterParams:
    chl, cdom, tsm = constituents(kind, t)
    return WaterParams(name=kind, water_type=kind, chl=chl, cdom=cdom, tsm=tsm, turbidity=t,
                       patchiness=0.0, sky="clear", sun_elevation=60.0, seed=3, **kw)


def test_water_columns_follow_lee_and_fresnel(gen):
    """Straight down: R = ((n - 1) / (n + 1))**2, the surface passes (1 - R) / n**2 of the
    radiance upwards, k_obj = K_d + 1.04 (1 + 5.4 u)**0.5 (a + b_b), k_col = K_d + 1.03
    (1 + 2.4 u)**0.5 (a + b_b); at 60 degrees from the vertical the paths lengthen by
    1 / cos(theta_w) and the reflectance is Fresnel's."""
    light = _light(gen, _water("coastal", 0.5))
    a, bb = light.absorption.astype(np.float64), light.backscatter.astype(np.float64)
    kd = light.diffuse_attenuation.astype(np.float64)
    u = bb / (a + bb)
    slant = np.array([math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))])
    down, oblique = water_columns(light, np.array([[0, 0, 1.0], slant]),
                                  np.full((2, 3), 0.01), np.ones((2, 3)), 0.0)
    r0 = ((N_WATER - 1) / (N_WATER + 1)) ** 2
    assert down.transmission == pytest.approx((1 - r0) / N_WATER ** 2, rel=1e-3)
    np.testing.assert_allclose(down.k_obj, kd + 1.04 * np.sqrt(1 + 5.4 * u) * (a + bb),
                               rtol=1e-5)
    np.testing.assert_allclose(down.k_col, kd + 1.03 * np.sqrt(1 + 2.4 * u) * (a + bb),
                               rtol=1e-5)
    cos_w = float(refracted_cos(0.5))
    np.testing.assert_allclose(oblique.k_obj - kd, (down.k_obj - kd) / cos_w, rtol=1e-5)
    r60 = float(fresnel(0.5))
    assert oblique.transmission == pytest.approx((1 - r60) / N_WATER ** 2, rel=1e-4)
    assert r60 > 2 * r0  # grazing views reflect more of the sky
    assert (oblique.reflection > down.reflection).all()
    # the refracted sun: Snell's law
    s = light.sun
    sin_i = math.hypot(s[0], s[1])
    assert math.hypot(*down.sun_dir[:2]) == pytest.approx(sin_i / N_WATER, rel=1e-6)


def _column(k: float, k_img: float | None = None) -> WaterColumn:
    return WaterColumn(np.full(3, k, np.float32), np.full(3, k, np.float32),
                       np.full(3, k if k_img is None else k_img, np.float32),
                       np.array([0.02, 0.03, 0.04], np.float32),
                       np.array([0.01, 0.01, 0.01], np.float32), 0.54,
                       np.array([0, 0, 1.0]), np.ones(3, np.float32))


def test_submerged_light_is_beer_lambert_through_the_column():
    """A pixel d metres down: T (below) exp(-k d) + deep (1 - exp(-k_col d)) + R L_sky; its
    mask weight is exp(-k d) (luminance-weighted); above the water it is the surface's own
    light with its full weight; far down, only the water is seen."""
    n = 8
    above = np.full((n, n, 3), 0.3, np.float32)
    below = np.full((n, n, 3), 0.2, np.float32)
    alpha = np.ones((n, n), np.float32)
    depth = np.tile(np.array([-0.5, 0.0, 0.05, 0.1, 0.3, 0.6, 1.0, 8.0], np.float32), (n, 1))
    col = _column(1.5)
    out, weight = submerge(above, below, alpha, depth, col, pitch_m=0.01, blur_per_metre=0.0)
    np.testing.assert_allclose(out[:, 0], 0.3, rtol=1e-6)
    assert weight[0, 0] == 1.0
    for j in range(3, 8):
        d = float(depth[0, j])
        t = math.exp(-1.5 * d)
        want = 0.54 * 0.2 * t + np.array([0.02, 0.03, 0.04]) * (1 - t) + 0.01
        np.testing.assert_allclose(out[0, j], want, rtol=1e-4)
        assert weight[0, j] == pytest.approx(t * float(LUMA.sum()), rel=1e-4)
    assert weight[0, 7] < 1e-4  # 8 m down: nothing of the object is left
    # the waterline is soft over one pixel: at depth 0 the colour is half the dry surface's,
    # half the wet one's (nothing attenuated yet: the weight is whole)
    wet = 0.54 * 0.2 + 0.01
    np.testing.assert_allclose(out[0, 1], 0.5 * 0.3 + 0.5 * wet, rtol=1e-4)
    assert weight[0, 1] == pytest.approx(1.0)


def test_scattered_light_veils_the_image_and_keeps_its_brightness():
    """In water that scatters (beam attenuation above the diffuse one), a submerged uniform
    body is as bright as the diffuse attenuation says (the scattered light still arrives),
    its detail fades with the image's attenuation, and the mask weight is the image's
    share ``exp(-k_img d)``; a thin submerged limb loses the scattered light that spreads
    beyond it."""
    n = 64
    yy, xx = np.mgrid[0:n, 0:n]
    checker = ((yy // 2 + xx // 2) % 2).astype(np.float32)[..., None] * np.ones(3, np.float32)
    flat = np.full((n, n, 3), 0.5, np.float32)
    depth = np.full((n, n), 0.5, np.float32)
    alpha = np.ones((n, n), np.float32)
    col = _column(0.5, k_img=4.0)
    out, weight = submerge(flat, flat, alpha, depth, col, pitch_m=0.05, blur_per_metre=0.0)
    t_obj, t_img, t_col = math.exp(-0.25), math.exp(-2.0), math.exp(-0.25)
    want = 0.54 * 0.5 * t_obj + np.array([0.02, 0.03, 0.04]) * (1 - t_col) + 0.01
    np.testing.assert_allclose(out[n // 2, n // 2], want, rtol=1e-3)
    assert weight[n // 2, n // 2] == pytest.approx(t_img * float(LUMA.sum()), rel=1e-4)
    clear, _ = submerge(checker, checker, alpha, depth, _column(0.5), pitch_m=0.05,
                        blur_per_metre=0.0)
    murky, _ = submerge(checker, checker, alpha, depth, col, pitch_m=0.05, blur_per_metre=0.0)
    inner = (slice(16, 48), slice(16, 48), 1)
    assert murky[inner].std() < 0.25 * clear[inner].std()
    assert murky[inner].mean() == pytest.approx(clear[inner].mean(), rel=0.02)
    limb = np.zeros((n, n), np.float32)
    limb[:, 31:33] = 1.0  # 2 px (10 cm) wide
    thin, _ = submerge(flat, flat, limb, depth, col, pitch_m=0.05, blur_per_metre=0.0)
    assert thin[n // 2, 31, 1] < 0.6 * out[n // 2, n // 2, 1]


def test_a_deep_limbs_shadow_fills_in_at_its_own_depth():
    """The water's light comes back into a submerged part's shadow by small-angle scattering
    spread over its own depth, not the whole body's: a thin dark limb hanging a metre under
    a broad body just awash leaves next to no shadow, while the body keeps its own."""
    n = 160
    alpha = np.zeros((n, n), np.float32)
    depth = np.full((n, n), 0.02, np.float32)
    alpha[10:60, 40:120] = 1.0  # a broad body 2 cm down (0.5 x 0.8 m at 1 cm a pixel)
    alpha[60:150, 79:81] = 1.0  # a 2 cm limb hanging from it down to a metre
    depth[60:150] = np.linspace(0.1, 1.0, 90, dtype=np.float32)[:, None]
    dark = np.zeros((n, n, 3), np.float32)
    col = _column(0.5, k_img=4.0)
    out, _ = submerge(dark, dark, alpha, depth, col, pitch_m=0.01, blur_per_metre=0.0)
    water = col.deep + col.reflection  # open water: the whole column's light
    shortfall = (water - out)[..., 1] / col.deep[1]  # of the light from under the surface
    assert shortfall[35, 80] > 0.9  # the body: a shadow
    assert shortfall[145, 80] < 0.1  # the limb a metre down: next to none
    assert shortfall[70, 80] > 2 * shortfall[145, 80]  # deeper, fainter


def test_submerged_parts_blur_with_depth():
    """Deep parts lose their detail (a checkerboard's contrast drops), the parts just under
    the surface keep it."""
    n = 64
    yy, xx = np.mgrid[0:n, 0:n]
    checker = ((yy // 2 + xx // 2) % 2).astype(np.float32)[..., None] * np.ones(3, np.float32)
    depth = np.where(xx < n // 2, 0.02, 1.0).astype(np.float32)
    out, _ = submerge(checker, checker, np.ones((n, n), np.float32), depth, _column(0.1),
                      pitch_m=0.01, blur_per_metre=0.05)
    shallow = out[8:56, 4:28, 1].std()
    deep = out[8:56, 36:60, 1].std()
    assert deep < 0.3 * shallow


def test_apparent_depth_is_snells_law():
    """A point under a flat surface looks shallower by tan(theta_w) / tan(theta): 1 / n
    straight down, less the more obliquely it is seen (a ray traced through the surface)."""
    assert apparent_depth(1.0) == pytest.approx(1.0 / N_WATER, rel=1e-3)
    for deg in (20.0, 45.0, 60.0, 75.0):
        t = math.radians(deg)
        t_w = math.asin(math.sin(t) / N_WATER)
        # the refracted ray from a point 1 m down reaches the surface tan(t_w) away; a
        # point k m down in air is seen there when k tan(t) = tan(t_w)
        assert apparent_depth(math.cos(t)) == pytest.approx(math.tan(t_w) / math.tan(t),
                                                              rel=1e-6)
    assert apparent_depth(math.cos(math.radians(45))) == pytest.approx(0.63, abs=0.01)
    assert apparent_depth(math.cos(math.radians(20))) > apparent_depth(math.cos(math.radians(60)))


def _column_stack(n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """A vertical bar (columns 28-35) from row 8 to 55: above the water down to row 20,
    then 1 cm deeper per row (stack channels: colour 3, coverage, weight)."""
    stack = np.zeros((n, n, 5), np.float32)
    stack[8:56, 28:36, :3] = 100.0
    stack[8:56, 28:36, 3] = 1.0
    stack[8:56, 28:36, 4] = 1.0
    rows = np.arange(n, dtype=np.float32)[:, None]
    depth = np.broadcast_to((rows - 20.0) * 0.01, (n, n)).astype(np.float32)
    return stack, depth


def test_refraction_lifts_submerged_parts_towards_the_surface():
    """Seen 45 degrees off the vertical (the world's up along the sprite's up at sin 45),
    a bar hanging 0.35 m under the surface shows (1 - k) shorter below the waterline; the
    part above the water does not move; straight down nothing moves."""
    stack, depth = _column_stack()
    pitch = 0.01 * math.sin(math.radians(45))  # a vertical bar: 1 cm deeper per row
    up = np.array([0.0, math.sin(math.radians(45)), math.cos(math.radians(45))])
    out = refract(stack, depth, up, pitch)
    cover = out[:, 28:36, 3].mean(axis=1)
    k = apparent_depth(math.cos(math.radians(45)))
    below = float(cover[20:].sum())  # rows of the submerged part that still show the bar
    assert below == pytest.approx(1 + 35 * k, abs=1.0)  # 35 rows of depth, k as long
    np.testing.assert_array_equal(out[8:20], stack[8:20])  # dry: unchanged
    assert float(out[..., 3].max()) <= 1.0 + 1e-5
    assert refract(stack, depth, np.array([0.0, 0.0, 1.0]), pitch) is stack
    dry = np.where(depth > 0, -0.1, depth).astype(np.float32)
    assert refract(stack, dry, up, pitch) is stack


def test_refraction_draws_the_submerged_body_shorter_seen_obliquely(gen, monkeypatch):
    """The BlueROV2 awash, seen 45 degrees off the vertical: with the surface's refraction
    its submerged frame covers fewer pixels than drawn as if through air (it lies
    shallower), the same straight down."""
    from sdcomp.render import layers as layers_mod
    from sdcomp.render.lighting import lighting

    water = _water("coastal", 0.3)
    light = _light(gen, water)
    sprites = gen.compositor.assets.sprites

    def covered(pitch: float) -> float:
        # the camera 12 m up looks along +x: the ROV where the view's centre meets the sea
        x = 12.0 / math.tan(math.radians(pitch))
        s = _scene(gen, [_rov(x=x, draft=0.1)], water, pitch=pitch)
        return float(layers_mod.build_layers(s, lighting(s, light), sprites)[0].alpha.sum())

    refracted = {p: covered(p) for p in (45.0, 90.0)}
    monkeypatch.setattr(layers_mod, "refract", lambda stack, *a: stack)
    in_air = {p: covered(p) for p in (45.0, 90.0)}
    assert refracted[45.0] < 0.95 * in_air[45.0]
    assert refracted[90.0] == pytest.approx(in_air[90.0], rel=0.01)


def test_waterline_ripples_have_the_asked_height_and_are_repeatable():
    z = waterline_level((200, 200), 0.01, 0.02, 0.6, (1, 2))
    assert z.dtype == np.float32 and z.shape == (200, 200)
    assert 0.01 < float(z.std()) < 0.03
    assert np.array_equal(z, waterline_level((200, 200), 0.01, 0.02, 0.6, (1, 2)))
    assert not np.array_equal(z, waterline_level((200, 200), 0.01, 0.02, 0.6, (1, 3)))
    assert not waterline_level((5, 5), 0.01, 0.0, 0.6, (1, 2)).any()


# --------------------------------------------------------------------------- foam

def test_contact_foam_rings_the_waterline():
    n = 40
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy - n / 2 + 0.5, xx - n / 2 + 0.5)
    alpha = (r < 10).astype(np.float32)
    depth = np.where(r < 7, -0.3, 0.0).astype(np.float32)  # a dome: dry top, wet rim
    pad, cover = contact_foam(alpha, depth, 0.01, 0.4, (5,))
    assert cover.shape == (n + 2 * pad,) * 2 and 0 < cover.max() <= 0.4 + 1e-6
    rr = np.hypot(*(np.mgrid[0:n + 2 * pad, 0:n + 2 * pad] - (n + 2 * pad) / 2 + 0.5))
    ring = (rr > 10) & (rr < 10 + 0.12 / 0.01)
    assert cover[ring].mean() > 5 * cover[rr > 30].mean() + 1e-3  # around the hull
    # an object standing clear of the water, one wholly under it, or a band under a pixel
    # wide: no foam
    assert contact_foam(alpha, np.full((n, n), -0.8, np.float32), 0.01, 0.4, (5,)) is None
    assert contact_foam(alpha, np.full((n, n), 0.3, np.float32), 0.01, 0.4, (5,)) is None
    assert contact_foam(alpha, depth, 0.5, 0.4, (5,)) is None
    assert ring_strength(0.0) < ring_strength(8.0) <= 0.5


def test_contact_foam_needs_a_body_that_stands_against_the_waves():
    """A head above the water rides the short waves (no froth); a hull a couple of metres
    across makes the full ring; in between, more with size."""
    from sdcomp.render.foam import RING_FULL_M, RING_SMALL_M, ring_share

    assert ring_share(0.25) == 0.0 == ring_share(RING_SMALL_M)
    assert ring_share(RING_FULL_M) == 1.0 == ring_share(6.0)
    sizes = np.linspace(RING_SMALL_M, RING_FULL_M, 7)
    assert np.all(np.diff([ring_share(float(m)) for m in sizes]) > 0)


# --------------------------------------------------------------------------- frames

def test_contact_foam_spares_the_outline_of_submerged_parts():
    """A swimmer-like body: a dry head on a long limb that lies 0.3 m under the water. The
    foam rings the head where it meets the water, not the limb's submerged outline."""
    n = 120
    yy, xx = np.mgrid[0:n, 0:n]
    head = np.hypot(yy - 20, xx - 60) < 10
    limb = (np.abs(xx - 60) < 5) & (yy > 20) & (yy < 110)
    alpha = (head | limb).astype(np.float32)
    depth = np.where(head, -0.1, 0.3).astype(np.float32)
    pad, cover = contact_foam(alpha, depth, 0.01, 0.4, (5,))
    y, x = np.mgrid[0:n + 2 * pad, 0:n + 2 * pad] - pad
    around_head = (np.hypot(y - 20, x - 60) > 11) & (np.hypot(y - 20, x - 60) < 20) & (y < 20)
    beside_limb = (np.abs(np.abs(x - 60) - 9) < 3) & (y > 60) & (y < 100)
    assert cover[around_head].mean() > 0.01
    assert cover[beside_limb].max() == 0.0


def test_a_body_moving_through_the_water_splashes(gen, monkeypatch):
    """A body under way breaks the surface at its waterline whatever its size (a swimmer's
    kicks and strokes): none at rest, more with speed up to SPLASH_SPEED; drawn, the
    BlueROV2's waterline whitens when it moves (its wake left out), its mask the same."""
    from sdcomp.render import layers as layers_mod
    from sdcomp.render.composite import composite
    from sdcomp.render.foam import SPLASH_PEAK, SPLASH_SPEED, splash_strength
    from sdcomp.render.lighting import lighting

    assert splash_strength(0.0) == 0.0 == splash_strength(-1.0)
    assert splash_strength(SPLASH_SPEED) == SPLASH_PEAK == splash_strength(5.0)
    assert 0 < splash_strength(0.3) < splash_strength(0.6) < SPLASH_PEAK
    monkeypatch.setattr(layers_mod, "wake_foam", lambda *a: None)
    water = _water("coastal", 0.3, wind=1.0)
    light = _light(gen, water)
    sprites = gen.compositor.assets.sprites

    def draw(speed):
        s = _scene(gen, [replace(_rov(), speed=speed)], water)
        image = np.full((gen.model.height, gen.model.width, 3), 60, np.uint8)
        layers = layers_mod.build_layers(s, lighting(s, light), sprites, foam_onto=image)
        composite(image, layers, False)
        return image.astype(int), layers[0]

    still, a = draw(0.0)
    moving, b = draw(1.0)
    assert np.array_equal(a.weight, b.weight)
    brighter = (moving - still).sum(axis=2)
    assert (brighter >= 0).all() and np.count_nonzero(brighter > 30) > 20


def test_foam_never_changes_the_masks(gen):
    """The foam rings are drawn on the background under every object: building the layers
    with or without them gives the same object weights (so the same masks), and the
    background changes only where a ring lies."""
    from sdcomp.render.composite import composite
    from sdcomp.render.layers import build_layers
    from sdcomp.render.lighting import lighting

    s = _scene(gen, [_rov(), _rov(x=0.6, y=0.4, draft=0.15)], _water("coastal", 0.3, wind=7.0))
    light = _light(gen, s.water)
    sprites = gen.compositor.assets.sprites
    base = np.full((gen.model.height, gen.model.width, 3), 60, np.uint8)
    foamed = base.copy()
    with_foam = build_layers(s, lighting(s, light), sprites, foam_onto=foamed)
    without = build_layers(s, lighting(s, light), sprites)
    assert np.count_nonzero((foamed > base).any(axis=2)) > 50  # white foam on dark water
    composite(foamed, with_foam, False)
    composite(base.copy(), without, False)
    assert len(with_foam) == len(without) == 2
    for a, b in zip(with_foam, without, strict=True):
        assert a.colour.size == 0 and b.colour.size == 0  # released once drawn
        assert np.array_equal(a.weight, b.weight) and np.array_equal(a.alpha, b.alpha)


# --------------------------------------------------------------------------- wakes

def test_wake_strength_grows_with_speed_and_arms_need_way():
    from sdcomp.render.wake import ARM_SPEED, SPEED_MIN, wake_strength

    assert wake_strength(0.0) == (0.0, 0.0) and wake_strength(SPEED_MIN / 2) == (0.0, 0.0)
    speeds = [0.5, 1.0, 2.0, 4.0, 8.0, 12.0]
    cores = [wake_strength(v)[0] for v in speeds]
    assert all(a <= b for a, b in zip(cores, cores[1:], strict=False)) and cores[0] > 0
    assert wake_strength(ARM_SPEED * 0.9)[1] == 0.0 < wake_strength(ARM_SPEED * 1.5)[1]


def _wake(speed: float, length: float = 5.0, beam: float = 2.0, res: float = 0.1):
    """(cover, u (w,), v (h,)) of a hull's wake: metres behind its centre and across."""
    from sdcomp.render.wake import wake_cover

    cover, u0, v0, r = wake_cover(length, beam, speed, res, (1,))
    assert r == pytest.approx(res) and cover.dtype == np.float32
    assert cover.min() >= 0.0 and cover.max() <= 1.0
    h, w = cover.shape
    return cover, np.arange(w) * r - u0, np.arange(h) * r - v0


def test_wake_lies_behind_with_kelvin_arms_at_19_5_degrees():
    """A 5 m boat at 3 m/s (displacing: Froude number 0.43): the turbulent wake is behind
    it, nothing ahead; across the wake behind, the brightest water beside the core (the
    arms) lies where the Kelvin wedge's half-angle asin(1/3) puts it from the bow."""
    from sdcomp.render.wake import KELVIN_HALF_ANGLE, wake_cover

    length, beam = 5.0, 2.0
    cover, u, v = _wake(3.0)
    ahead = cover[:, u < -length / 2 - 0.5]
    behind = cover[np.abs(v) < beam / 2][:, (u > length) & (u < 2 * length)]
    assert ahead.max() < 0.02 and behind.mean() > 0.1
    assert KELVIN_HALF_ANGLE == pytest.approx(19.47, abs=0.01)
    for dist in (8.0, 12.0):
        cols = np.abs(u - dist) < 0.5  # a metre's band: the foam's breaks average out
        side = cover[:, cols].mean(axis=1)
        side[np.abs(v) < 2 * beam] = 0  # leave out the turbulent core
        want = (dist + length / 2) * math.tan(math.radians(KELVIN_HALF_ANGLE))
        assert abs(abs(v[int(np.argmax(side))]) - want) < 0.6
    assert wake_cover(length, beam, 0.1, 0.1, (1,)) is None


def test_a_planing_hull_throws_white_water_in_a_narrower_v():
    """At 10 m/s (planing) the near wake is white water: solid right behind the transom,
    and beside it, a hull length behind, the whitest water lies at the wing angle from the
    transom's corners, inside the Kelvin wedge."""
    from sdcomp.render.wake import KELVIN_HALF_ANGLE, WING_ANGLE

    length, beam = 5.0, 2.0
    cover, u, v = _wake(10.0)
    stern = cover[np.abs(v) < beam / 3][:, (u > length / 2) & (u < length)]
    assert stern.mean() > 0.6
    dist = 2 * length
    side = cover[:, np.abs(u - dist) < 0.5].mean(axis=1)
    side[np.abs(v) < beam] = 0
    behind = dist - length / 2
    want = beam / 2 + behind * math.tan(math.radians(WING_ANGLE))
    kelvin = (dist + length / 2) * math.tan(math.radians(KELVIN_HALF_ANGLE))
    got = abs(v[int(np.argmax(side))])
    assert abs(got - want) < 0.8 and got < kelvin - 1.0


def test_a_moving_object_leaves_a_wake_and_the_same_mask(gen):
    """Under way, an object draws a wake on the water behind it: turned round, the wake is
    on the other side of it; its layer's weights are the same as standing still."""
    from sdcomp.render.composite import composite
    from sdcomp.render.layers import build_layers
    from sdcomp.render.lighting import lighting

    water = _water("coastal", 0.3, wind=3.0)
    light = _light(gen, water)
    sprites = gen.compositor.assets.sprites

    def draw(heading, speed):
        s = _scene(gen, [replace(_rov(), heading=heading, speed=speed)], water)
        image = np.full((gen.model.height, gen.model.width, 3), 60, np.uint8)
        layers = build_layers(s, lighting(s, light), sprites, foam_onto=image)
        composite(image, layers, False)
        return image, layers[0]

    centroids = []
    for heading in (0.0, 180.0):
        still, a = draw(heading, 0.0)
        moving, b = draw(heading, 3.0)
        assert np.array_equal(a.weight, b.weight) and np.array_equal(a.alpha, b.alpha)
        changed = np.argwhere((moving != still).any(axis=2))
        assert len(changed) > 100
        x0, y0, x1, y1 = a.roi
        centroids.append(changed.mean(axis=0) - ((y0 + y1) / 2, (x0 + x1) / 2))
    # behind the object: on opposite sides for opposite headings, well away from it
    assert float(centroids[0] @ centroids[1]) < 0
    assert min(np.hypot(*c) for c in centroids) > 5


def _scene(g: Generator, placements, water: WaterParams, pitch: float = 90.0):
    m = g.model
    pls = tuple(replace(p, asset=object_asset(g.config, p.category_id - 1))
                for p in placements)
    return replace(g.scene(0), placements=pls, camera=CameraPose(12.0, pitch, 0.0),
                   water=water, look=clean_look(m.width, m.height, m.fx, m.fy),
                   defocus_blur=None, shore=None, hills=None)


def _rov(x=0.0, y=0.0, draft=0.0) -> Placement:
    return Placement(Role.OBJECT, "", 1, x, y, 30.0, 0.0, 0.0, draft)


def test_an_object_is_brighter_in_sun_than_under_overcast_relative_to_its_water(gen):
    """Exposure follows the water, so it is the contrast that changes: under a clear sky the
    sunlit object stands out from the water more than under an overcast one."""
    out = {}
    for sky in ("clear", "overcast"):
        s = _scene(gen, [_rov()], _water("lake", 0.5, wind=2.0).__class__(
            **{**_water("lake", 0.5, wind=2.0).__dict__, "sky": sky}))
        f = gen.render_scene(s)
        (obj,) = f.objects
        m = f.instances == obj.instance_id
        img = f.image.astype(np.float32).mean(axis=2)
        out[sky] = float(img[m].mean()) / float(img[~m].mean())
    assert out["clear"] > out["overcast"] > 1.0


def test_deeper_objects_fade_into_the_water(gen):
    """The same object drawn deeper in murky water: fewer mask pixels and closer to the
    water's colour. (In clearer water a bright object exposed for the dark water around it
    stays clipped white down to a metre: as in real footage. At turbidity 0.2 the image's
    beam attenuation is about 15 per metre: a few centimetres of depth tell.)"""
    water = _water("turbid", 0.2, wind=1.0)
    prev_area, prev_contrast = None, None
    for draft in (0.0, 0.04, 0.08, 0.14):
        f = gen.render_scene(_scene(gen, [_rov(draft=draft)], water),
                             AnnotationRule(1, amodal=True))
        img = f.image.astype(np.float32)
        bg = np.median(img.reshape(-1, 3), axis=0)
        if f.objects:
            (o,) = f.objects
            area, contrast = o.area, float(np.abs(img[o.amodal] - bg).mean())
        else:
            area, contrast = 0, 0.0
        if prev_area is None:
            first_area = area
        if prev_area is not None:
            assert area <= prev_area and contrast < prev_contrast
        prev_area, prev_contrast = area, contrast
    assert prev_area < 0.5 * first_area


def test_objects_cut_by_the_edge_are_labelled_by_what_is_visible(sprites_dir):
    """The default labels an object with a tenth of its silhouette in the frame (truncated,
    its visible pixels and box); with --min-in-frame 0.25 it is not labelled but its pixels
    are the image's ignore region; a whole object is labelled either way, not truncated."""
    g = Generator(GeneratorConfig(seed=2, clutter=0, count=1), sprites_dir)
    g25 = Generator(GeneratorConfig(seed=2, clutter=0, count=1, min_in_frame=0.25),
                    sprites_dir)
    water = _water("ocean", 0.2, wind=1.0)
    full = g.render_scene(_scene(g, [_rov()], water))
    (whole,) = full.objects
    assert not whole.truncated and full.ignore is None
    half_w = 12.0 * g.model.width / 2 / g.model.fx  # metres from the centre to the edge
    found = False
    for off in np.linspace(0.2, 1.0, 17):
        pl = [_rov(y=-(half_w + off * 0.5))]  # towards the right edge (nadir, heading 0)
        loose = g.render_scene(_scene(g, pl, water))
        strict = g25.render_scene(_scene(g25, pl, water))
        assert np.array_equal(loose.image, strict.image)
        if loose.objects and loose.objects[0].area < 0.2 * whole.area:
            (o,) = loose.objects
            assert o.truncated and loose.truncated == 1 and loose.ignore is None
            x, _, w, _ = o.bbox
            assert x + w == g.model.width  # cut by the right edge
            assert strict.objects == [] and strict.dropped == 0
            (ign,) = strict.ignored
            assert (ign.area, ign.bbox) == (o.area, o.bbox) and ign.truncated
            assert np.array_equal(strict.ignore, loose.instances == 1)
            found = True
    assert found


def test_labels_follow_the_lens(sprites_dir):
    """With the camera's look (lens distortion and its zoom), masks and boxes are those of
    the recorded image: the boxes still derive from the masks, and an object off the centre
    moves outwards with the zoom, relative to the pinhole's."""
    cfg = GeneratorConfig(seed=4, clutter=0, count=1)
    g = Generator(cfg, sprites_dir)
    water = _water("lake", 0.3, wind=2.0)
    base = _scene(g, [_rov(x=-2.0, y=2.5)], water)
    pin = g.render_scene(base)
    m = g.model
    from sdcomp.scene.look_table import sample_look

    look = replace(sample_look("mavic2pro", np.random.default_rng(0), m.width, m.height,
                               fx=m.fx, fy=m.fy), k1=-0.03, k2=0.0, motion_px=0.0)
    lens = g.render_scene(replace(base, look=look))
    assert "lens" in lens.camera["stages"] and lens.camera["zoom"] > 1.0
    (a,), (b,) = pin.objects, lens.objects
    ys, xs = np.nonzero(lens.instances == b.instance_id)
    assert b.bbox == (xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
    cx, cy = (m.width - 1) / 2, (m.height - 1) / 2
    ca = np.hypot(a.bbox[0] + a.bbox[2] / 2 - cx, a.bbox[1] + a.bbox[3] / 2 - cy)
    cb = np.hypot(b.bbox[0] + b.bbox[2] / 2 - cx, b.bbox[1] + b.bbox[3] / 2 - cy)
    assert cb > ca


def test_glitter_switch_keeps_the_mean_glint(sprites_dir):
    """glitter off: the sun's reflection is drawn as its smooth mean, so the image keeps its
    mean linear brightness within 10 % but loses the sparkles' fine detail."""
    cfg = GeneratorConfig(seed=1, clutter=0, count=0, sun_elevation="70-80", wind="3-5",
                          look="clean", sky=("clear",))
    on = Generator(cfg, sprites_dir)
    off = Generator(replace(cfg, glitter=False), sprites_dir)
    for i in range(3):
        a = on.render(i).image.astype(np.float32)
        b = off.render(i).image.astype(np.float32)
        la, lb = (float(srgb_to_linear(x / 255.0).mean()) for x in (a, b))
        assert abs(la - lb) < 0.1 * la
        da = np.abs(np.diff(a, axis=1)).mean()
        db = np.abs(np.diff(b, axis=1)).mean()
        assert db <= da


def test_things_under_way_by_kind_and_the_under_way_factor():
    """Boats travel at 2-12 m/s about half the time, buoys and logs never; --under-way 0
    stops everything, and the other draws stay where they are (same placements)."""
    from sdcomp.scene.objects import UNDER_WAY
    from sdcomp.scene.sample import sample_scene

    base = {"objects": [{"mesh": "boat", "category": "boat"}], "count": "2",
            "clutter": 2.0, "clutter_kinds": ["buoy", "log"], "altitude": "40", "n": 60}
    moving = GeneratorConfig.from_mapping(base)
    still = GeneratorConfig.from_mapping({**base, "under_way": 0.0})
    speeds, kinds = [], []
    for i in range(60):
        a, b = sample_scene(moving, i), sample_scene(still, i)
        assert [(p.asset, p.x, p.y) for p in a.placements] == [
            (p.asset, p.x, p.y) for p in b.placements]
        assert all(p.speed == 0.0 for p in b.placements)
        speeds += [p.speed for p in a.placements]
        kinds += [p.role for p in a.placements]
    boats = np.array([s for s, r in zip(speeds, kinds, strict=True) if r is Role.OBJECT])
    others = [s for s, r in zip(speeds, kinds, strict=True) if r is Role.CLUTTER]
    chance, lo, hi = UNDER_WAY["boat"]
    assert abs(np.mean(boats > 0) - chance) < 0.15
    assert boats[boats > 0].min() >= lo and boats.max() <= hi
    assert others and not any(others)
