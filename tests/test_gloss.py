"""Gloss on hard object surfaces (sdcomp.render.gloss): Fresnel's reflectance, the GGX
highlight's normalisation, the mirrored sky's table against the sky itself, and what
add_gloss does to a surface for known geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sdcomp.render.gloss import (
    F0,
    N_HULL,
    add_gloss,
    ggx,
    roughness,
    sky_lookup,
    sky_table,
)
from sdcomp.render.water.optics import schlick
from sdcomp.render.water.sky import make_sky


@pytest.fixture(scope="module")
def sky():
    return make_sky("clear", 40.0, 120.0, 0.0, None, 1500.0, 50.0, (0.0, 0.0), 1.0, 20000.0)


def test_fresnel_runs_from_f0_at_normal_incidence_to_one_at_grazing():
    f = schlick(np.array([1.0, 0.5, 0.0], np.float32), N_HULL)
    assert f[0] == pytest.approx(F0)
    assert f[2] == pytest.approx(1.0)
    assert F0 < f[1] < 0.1  # 60 degrees: still near F0 (0.059 for n = 1.5)


@pytest.mark.parametrize("alpha", [0.1, 0.2, 0.4])
def test_ggx_projected_distribution_integrates_to_one(alpha):
    """The microfacet distribution's projected area over the hemisphere is the surface's."""
    t = np.linspace(0.0, math.pi / 2, 20001)
    c = np.cos(t).astype(np.float32)
    integrand = ggx(c, alpha).astype(np.float64) * np.cos(t) * np.sin(t) * 2 * math.pi
    assert np.trapezoid(integrand, t) == pytest.approx(1.0, abs=2e-3)


def test_the_sky_table_reads_back_the_sky_it_was_made_from(sky):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(4000, 3)).astype(np.float32)
    d[:, 2] = np.abs(d[:, 2])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    exact = sky.radiance(d, np.full(len(d), 0.2, np.float32))
    got = sky_lookup(sky_table(sky), d)
    err = np.abs(got - exact).sum(1) / exact.sum(1)
    assert np.median(err) < 0.01 and np.percentile(err, 99) < 0.06
    # the horizon and the zenith exactly where the table holds them
    z = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], np.float32)
    np.testing.assert_allclose(sky_lookup(sky_table(sky), z),
                               sky.radiance(z, np.full(2, 0.2, np.float32)), rtol=1e-4)


def _flat(n=4, nz=1.0):
    normal = np.zeros((n, n, 3), np.float32)
    normal[..., 0] = math.sqrt(1 - nz * nz)
    normal[..., 2] = nz
    return normal


def test_a_level_surface_seen_from_above_mirrors_the_zenith(sky):
    """Pose frame = world frame (view straight down onto a surface facing up: +z up)."""
    table = sky_table(sky)
    diffuse = np.full((4, 4, 3), 0.3, np.float32)
    alpha = np.ones((4, 4), np.float32)
    alpha[0, 0] = 0.0  # uncovered: left alone
    out = add_gloss(diffuse.copy(), alpha, _flat(), np.eye(3), np.array([0.0, 0.8, 0.6]),
                    np.zeros(3, np.float32), table, np.zeros(3, np.float32), 0.15)
    zenith = sky_lookup(table, np.array([[0.0, 0.0, 1.0]], np.float32))[0]
    np.testing.assert_allclose(out[1, 1], 0.3 * (1 - F0) + F0 * zenith, rtol=1e-5)
    np.testing.assert_array_equal(out[0, 0], diffuse[0, 0])


def test_the_sun_in_the_mirror_direction_makes_the_highlight_peak(sky):
    table = sky_table(sky)
    alpha = np.ones((2, 2), np.float32)
    sun = np.array([1.0, 1.0, 1.0], np.float32)
    base = np.zeros((2, 2, 3), np.float32)
    # the sun straight behind the camera: the half vector is the view, = the normal
    at = add_gloss(base.copy(), alpha, _flat(2), np.eye(3), np.array([0.0, 0.0, 1.0]), sun,
                   table, np.zeros(3, np.float32), 0.2)
    sky_only = add_gloss(base.copy(), alpha, _flat(2), np.eye(3), np.array([0.0, 0.0, 1.0]),
                         np.zeros(3, np.float32), table, np.zeros(3, np.float32), 0.2)
    peak = float(ggx(np.float32(1.0), 0.2)) * F0 / 4.0
    np.testing.assert_allclose(at - sky_only, peak, rtol=1e-4)
    # the sun 60 degrees off the mirror direction: the half vector 30 degrees off the
    # normal, in GGX's tail (2 % of the peak at this roughness)
    off = add_gloss(base.copy(), alpha, _flat(2), np.eye(3),
                    np.array([math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))]),
                    sun, table, np.zeros(3, np.float32), 0.2)
    c30 = np.float32(math.cos(math.radians(30)))
    tail = float(ggx(c30, 0.2)) * float(schlick(c30, N_HULL)) / 4.0
    np.testing.assert_allclose(off - sky_only, tail, rtol=1e-4)
    assert tail < peak / 40


def test_a_surface_facing_the_sea_mirrors_the_sea():
    """Seen obliquely, a surface tilted down reflects the view ray below the horizon."""
    sky = make_sky("overcast", 40.0, 0.0, 1.0, None, 1500.0, 50.0, (0.0, 0.0), 1.0, 20000.0)
    below = np.array([0.01, 0.02, 0.015], np.float32)
    # pose frame: view +z is horizontal in the world (to_world maps pose z to world x),
    # the normal tilted 60 degrees from the view towards world -z
    to_world = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    n = np.zeros((1, 1, 3), np.float32)
    n[..., 1], n[..., 2] = -math.sin(math.radians(60)), math.cos(math.radians(60))
    out = add_gloss(np.zeros((1, 1, 3), np.float32), np.ones((1, 1), np.float32), n,
                    to_world, np.array([0.0, 0.5, 0.5]), np.zeros(3, np.float32),
                    sky_table(sky), below, 0.15)
    f = float(schlick(np.float32(0.5), N_HULL))
    np.testing.assert_allclose(out[0, 0], f * below, rtol=1e-5)


def test_only_hard_hulls_are_glossy():
    assert roughness("boat-03") == roughness("jetski-00") == roughness("buoy-09") == 0.1
    assert roughness("clutter:boat-03") == roughness("clutter:buoy-01") == 0.1  # distractors
    for matte in ("swimmer-04", "life_saving_appliances-01", "bluerov2", "bluerov2-heavy",
                  "clutter:log", "clutter:swimmer-02", "boat-7.glb"):
        assert roughness(matte) is None


def test_a_render_glosses_the_boat_and_leaves_the_swimmer_and_water_alone(sprites_dir,
                                                                          monkeypatch):
    """The same scene (a boat and a swimmer, clean look) with gloss and with every asset
    matte: only the boat's pixels change, and its dark parts get brighter (they mirror the
    sky; the white hull is clipped either way)."""
    from dataclasses import replace

    import cv2

    from sdcomp.pipeline import Generator
    from sdcomp.render import layers
    from sdcomp.scene.camera import CameraPose
    from sdcomp.scene.config import GeneratorConfig
    from sdcomp.scene.look_table import clean_look
    from sdcomp.scene.presets import preset
    from sdcomp.scene.scene import Placement, Role

    g = Generator(GeneratorConfig.from_mapping({**preset("seadronessee"), "width": 320,
                                                "height": 320, "seed": 3}), sprites_dir)
    m = g.model
    base = g.scene(0)
    pls = (Placement(Role.OBJECT, "boat-00", 2, -2.5, 0.0, 30.0, 0.0, 0.0, 0.0),
           Placement(Role.OBJECT, "swimmer-00", 1, 3.5, 1.0, 0.0, 0.0, 0.0, 0.0))
    scene = replace(base, placements=pls, camera=CameraPose(15.0, 90.0, 0.0),
                    water=replace(base.water, sky="clear", cloud_cover=0.0,
                                  sun_elevation=50.0),
                    look=clean_look(m.width, m.height, m.fx, m.fy), defocus_blur=None,
                    shore=None, hills=None)
    glossy = g.render_scene(scene)
    monkeypatch.setattr(layers, "roughness", lambda asset: None)
    matte = g.render_scene(scene)
    np.testing.assert_array_equal(glossy.instances, matte.instances)
    ids = {o.category_id: o.instance_id for o in glossy.objects}
    boat = cv2.dilate((glossy.instances == ids[2]).astype(np.uint8), np.ones((5, 5))) > 0
    a, b = glossy.image.astype(np.int16), matte.image.astype(np.int16)
    np.testing.assert_array_equal(a[~boat], b[~boat])  # the swimmer and the water
    inside = glossy.instances == ids[2]
    assert np.abs(a[inside] - b[inside]).max() > 20
    la, lb = a[inside].sum(1), b[inside].sum(1)
    dark = lb < np.percentile(lb, 25)
    assert la[dark].mean() > lb[dark].mean() + 10
