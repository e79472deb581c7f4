"""The sea for video: a world-fixed, moving surface (WaterParams.origin, frame_heading,
time; sdcomp.render.water.animate)."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest

from sdcomp.render.water import WaterTextures, animate
from sdcomp.render.water.animate import AnimatedTextures, band_split, evolved_tile, textures_for
from sdcomp.render.water.surface import render_water
from sdcomp.render.water.textures import N_TILE, pitch
from sdcomp.render.water.waves import omega
from sdcomp.scene.camera import CameraModel, CameraPose
from sdcomp.scene.water import WaterParams

MODEL = CameraModel(5472, 3648, 77.0, 416, 416)
SQUARE = CameraModel(3648, 3648, 77.0, 416, 416)  # square pixels: turns map pixels to pixels
SEA = WaterParams(wind=5.0, wind_dir=30.0, seed=11, swell_height=0.4, swell_dir=60.0,
                  patchiness=0.3, sky="broken", cloud_cover=0.4)


@pytest.fixture(scope="module")
def tex() -> WaterTextures:
    return WaterTextures.build(5)


def _hp(img: np.ndarray) -> np.ndarray:
    """High-pass grey image (the waves, without the smooth terms)."""
    g = img.astype(np.float32).mean(2)
    return g - cv2.GaussianBlur(g, (0, 0), 4.0)


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    return float((a * b).sum() / math.sqrt(float((a * a).sum() * (b * b).sum())))


def _render(tex, pose, model=MODEL, **kw) -> np.ndarray:
    return render_water(model, pose, replace(SEA, **kw), tex, glint="none")[0]


def test_defaults_render_the_still_image(tex):
    """The video fields at their defaults are the still image, byte for byte (and the still
    tiles are what the renderer reads)."""
    for pitch_deg, heading in ((90.0, 20.0), (30.0, 200.0)):
        pose = CameraPose(25.0, pitch_deg, heading)
        a = render_water(MODEL, pose, SEA, tex)[0]
        b = render_water(MODEL, pose, replace(SEA, origin=(0.0, 0.0), frame_heading=None,
                                              time=None), tex)[0]
        assert np.array_equal(a, b)
    assert textures_for(SEA, tex) is tex
    moving = textures_for(replace(SEA, time=2.0), tex)
    assert isinstance(moving, AnimatedTextures)
    assert textures_for(replace(SEA, time=2.0), tex) is moving  # cached per frame


def test_still_split_reproduces_the_tiles(tex, monkeypatch):
    """Without the downwind bias the travelling split at t = 0 is the still tile (the
    half-tile roll and the axis turn folded into the spectrum)."""
    monkeypatch.setattr(animate, "GAMMA", 0.0)
    for s, lev in ((0, 3), (2, 7)):
        still = tex.ensure(s, lev).astype(np.int16)
        moved = evolved_tile(tex, s, lev, 0.0, 1.0).astype(np.int16)
        diff = np.abs(still - moved)
        assert diff.max() <= 1 and (diff == 0).mean() > 0.99


def test_evolved_tile_is_the_plain_inverse_transform(tex):
    """The evolved tile's slope codes are those of the spectrum's 2-D inverse FFT (NumPy's,
    in double precision, here): OpenCV's single-precision DFT rounds differently only where
    a value lies on a code's edge (one code, in under 1e-4 of the texels); the grain and
    foam channels are the still tile's, the last row and column wrap."""
    for s, lev, t in ((0, 5, 0.37), (1, 8, 2.5)):
        got = evolved_tile(tex, s, lev, t, -1.0)
        f = np.fft.ifft2(animate.evolved_spectrum(tex, s, lev, t, -1.0).astype(np.complex128))
        sd = tex.code_sd(s, lev)
        two = np.stack([f.real, f.imag], -1)
        codes = two * np.array([animate.SLOPE_SCALE / sd[0], animate.SLOPE_SCALE / sd[1]])
        want = np.clip(codes + 128.5, 0, 255).astype(np.uint8)
        diff = np.abs(got[:N_TILE, :N_TILE, :2].astype(np.int16) - want)
        assert diff.max() <= 1 and (diff > 0).mean() < 1e-4
        assert np.array_equal(got[..., 2:], tex.ensure(s, lev)[..., 2:])
        assert np.array_equal(got[N_TILE], got[0]) and np.array_equal(got[:, N_TILE],
                                                                      got[:, 0])


def test_nadir_sea_is_fixed_in_the_world(tex):
    """Moving the camera by d metres along its right axis moves the sea by d / gsd pixels
    when ``origin`` follows the camera; without it the sea moves with the camera."""
    pose = CameraPose(30.0, 90.0, 90.0)  # camera right = world +x
    gsd = 30.0 / MODEL.fx
    shift = 40
    d = shift * gsd
    kw = {"frame_heading": 15.0, "time": 3.0}
    a = _hp(_render(tex, pose, origin=(100.0, 50.0), **kw))
    b = _hp(_render(tex, pose, origin=(100.0 + d, 50.0), **kw))
    assert _corr(a[8:-8, shift + 8:-8], b[8:-8, 8:-shift - 8]) > 0.9
    c = _hp(_render(tex, pose, origin=(100.0, 50.0), **kw))
    assert _corr(a[8:-8, shift + 8:-8], c[8:-8, 8:-shift - 8]) < 0.3
    # the camera-following frame is fixed in the world too when it does not turn
    a2 = _hp(_render(tex, pose, origin=(0.0, 0.0), time=3.0))
    b2 = _hp(_render(tex, pose, origin=(d, 0.0), time=3.0))
    assert _corr(a2[8:-8, shift + 8:-8], b2[8:-8, 8:-shift - 8]) > 0.9


def test_turning_camera_sees_the_same_sea(tex):
    """With a world-fixed frame a camera turned by 90 degrees sees the same sea turned;
    with the camera-following frame it sees another pattern."""
    p0, p1 = CameraPose(30.0, 90.0, 10.0), CameraPose(30.0, 90.0, 100.0)
    kw = {"frame_heading": 70.0, "time": 1.5, "origin": (12.0, -7.0), "model": SQUARE}
    a = _hp(_render(tex, p0, **kw))
    b = _hp(_render(tex, p1, **kw))
    # heading + 90: right' = -down, down' = right, so b = a turned clockwise
    assert _corr(np.rot90(a, -1)[8:-8, 8:-8], b[8:-8, 8:-8]) > 0.9
    a = _hp(_render(tex, p0, SQUARE, time=1.5, origin=(12.0, -7.0)))
    b = _hp(_render(tex, p1, SQUARE, time=1.5, origin=(12.0, -7.0)))
    assert _corr(np.rot90(a, -1)[8:-8, 8:-8], b[8:-8, 8:-8]) < 0.5


def _tile_spectrum(tex, s, lev, t, sign=1.0) -> np.ndarray:
    return np.fft.fft2(evolved_tile(tex, s, lev, t, sign)[:N_TILE, :N_TILE, 0].astype(
        np.float64) - 128.0)


def _wavenumbers(lev: int) -> np.ndarray:
    f = np.fft.fftfreq(N_TILE) * N_TILE
    kx, ky = np.meshgrid(f, f)
    return 2 * math.pi * np.hypot(kx, ky) / (N_TILE * pitch(lev))  # rad/m


def test_modes_follow_the_dispersion_relation(tex):
    """Each mode of a tile is a pair of waves exp(-+i omega t) with omega(k) of deep water
    with capillarity: C(t + dt) + C(t - dt) = 2 cos(omega dt) C(t)."""
    for lev, dt in ((0, 0.01), (8, 0.2)):
        c0, cm, cp = (_tile_spectrum(tex, 0, lev, 5.0 + e) for e in (0.0, -dt, dt))
        k = _wavenumbers(lev)
        strong = np.abs(c0) > np.quantile(np.abs(c0), 0.995)
        pred = 2 * np.cos(omega(k) * dt) * c0
        err = np.abs(cp + cm - pred)[strong] / np.abs(c0)[strong]
        assert np.median(err) < 0.05
        # a wrong speed (gravity only) does not fit the short waves' modes as well
        if lev == 0:
            grav = 2 * np.cos(np.sqrt(9.81 * k) * dt) * c0
            assert np.median(np.abs(cp + cm - grav)[strong] / np.abs(c0)[strong]) > 0.1


def test_waves_move_and_short_ones_change_faster(tex):
    def tile(lev, t):
        return evolved_tile(tex, 0, lev, t, 1.0)[:N_TILE, :N_TILE, 0].astype(np.float64)

    near = _corr(tile(6, 1.0), tile(6, 1.05))
    far = _corr(tile(6, 1.0), tile(6, 3.0))
    assert near > far
    assert near > 0.8
    fast = _corr(tile(1, 1.0), tile(1, 1.05))  # centimetre waves
    assert fast < near
    # not a rigid translation of the pattern at 0: the best circular shift fits badly
    a, b = tile(6, 0.0) - 128.0, tile(6, 3.0) - 128.0
    xc = np.fft.ifft2(np.fft.fft2(a) * np.conj(np.fft.fft2(b))).real
    assert xc.max() / math.sqrt(float((a * a).sum() * (b * b).sum())) < 0.6
    # the long waves of the coarse grid move too, at the still tiles' code scale
    moving = AnimatedTextures(tex, 3.0, 1.0)
    assert not np.array_equal(moving.coarse_level(9), tex.coarse_level(9))
    assert moving.level_sd is tex.level_sd


def test_more_energy_travels_downwind(tex):
    """The split puts more energy in waves travelling towards where the wind blows; the
    tiles' measured travelling components agree."""
    for sign in (1.0, -1.0):
        sp = band_split(tex, 6, 45.0, sign)
        down = sign * np.array([math.cos(math.radians(45.0)), math.sin(math.radians(45.0))])
        along = sp["mx"] * down[0] + sp["my"] * down[1]
        e_fwd, e_back = np.abs(sp["fwd"]) ** 2, np.abs(sp["back"]) ** 2
        downwind = e_fwd[along > 0].sum() + e_back[along < 0].sum()
        upwind = e_fwd[along < 0].sum() + e_back[along > 0].sum()
        assert downwind > 2.0 * upwind
    # from the tiles: C(t) = A exp(-i w t) + B exp(i w t), A travelling along +k
    lev, dt = 5, 0.05
    c0, c1 = _tile_spectrum(tex, 0, lev, 0.0), _tile_spectrum(tex, 0, lev, dt)
    w = omega(_wavenumbers(lev)) * dt
    ok = np.abs(np.sin(w)) > 0.2
    a = np.where(ok, (c1 - c0 * np.exp(1j * w)) / np.where(ok, -2j * np.sin(w), 1), 0)
    f = np.fft.fftfreq(N_TILE)
    kx = np.broadcast_to(f[None, :], a.shape)  # set 0: the wind along tile +x
    e = np.abs(a) ** 2
    assert e[kx > 0].sum() > 2.0 * e[kx < 0].sum()


def test_video_clouds_drift_with_the_wind_aloft():
    """A video's clouds (and their shadows) move over the sea at CLOUD_WIND x the wind,
    veered by CLOUD_VEER; without time they stay where the still's hash puts them."""
    import math
    from dataclasses import replace as _replace

    from sdcomp.render.water.coarse import CLOUD_VEER, CLOUD_WIND, build_sky
    from sdcomp.render.water.textures import WaterTextures
    from sdcomp.scene.water import WaterParams

    tex = WaterTextures.build(3)
    p = WaterParams(sky="broken", cloud_cover=0.5, wind=6.0, wind_dir=30.0, seed=9,
                    cloud_scale=10.0)
    still = np.array(build_sky(p, tex).cloud_offset)
    at0 = np.array(build_sky(_replace(p, time=0.0), tex).cloud_offset)
    at10 = np.array(build_sky(_replace(p, time=10.0), tex).cloud_offset)
    assert np.allclose(still, at0)
    a = math.radians(30.0 + CLOUD_VEER)
    moved = CLOUD_WIND * 6.0 * 10.0 / 10.0  # texels of 10 m in 10 s
    assert np.allclose(at0 - at10, [moved * math.cos(a), moved * math.sin(a)])


def test_video_sparkles_are_drawn_anew_each_frame():
    """The glitter noise window changes from frame to frame of a video (facets live for
    tens of milliseconds) and is a pure function of (seed, time)."""
    from dataclasses import replace as _replace

    from sdcomp.render.water.surface import view_water
    from sdcomp.render.water.textures import WaterTextures
    from sdcomp.scene.camera import CameraModel, CameraPose
    from sdcomp.scene.water import WaterParams

    tex = WaterTextures.build(3)
    model = CameraModel(width=160, height=160)
    pose = CameraPose(20.0, 90.0, 0.0)
    p = WaterParams(seed=4, frame_heading=0.0)
    offs = [view_water(model, pose, _replace(p, time=k / 30), tex).noise_off
            for k in range(4)]
    assert len(set(offs)) == 4
    assert view_water(model, pose, _replace(p, time=2 / 30), tex).noise_off == offs[2]


def test_video_water_has_no_level_pop_as_the_altitude_wanders():
    """Straight down, a still draws one wave level per image (the one nearest the pixel
    footprint); a video frame's water cross-fades levels per row instead, so two frames a
    thirtieth of a second apart whose altitudes straddle a level boundary still look alike
    (a still-style pair would jump to another level's texture)."""
    from dataclasses import replace as _replace

    from sdcomp.render.water.surface import render_water
    from sdcomp.render.water.textures import WaterTextures, pitch
    from sdcomp.scene.camera import CameraModel, CameraPose
    from sdcomp.scene.water import WaterParams

    tex = WaterTextures.build(5)
    model = CameraModel(width=256, height=256)
    # the altitude at which the footprint crosses the boundary between levels 3 and 4
    boundary = pitch(3) * 2 ** 0.5 * model.fx
    p = WaterParams(seed=8, wind=5.0, frame_heading=0.0, time=1.0, sky="overcast",
                    cloud_cover=1.0)
    a, _ = render_water(model, CameraPose(boundary * 0.995, 90.0, 0.0), p, tex, glint="none")
    b, _ = render_water(model, CameraPose(boundary * 1.005, 90.0, 0.0),
                        _replace(p, time=1.0 + 1 / 30), tex, glint="none")
    ya, yb = (cv2.cvtColor(x, cv2.COLOR_RGB2GRAY).astype(np.float32) for x in (a, b))
    hp = [y - cv2.GaussianBlur(y, (0, 0), 3) for y in (ya, yb)]
    corr = float(np.corrcoef(hp[0].ravel(), hp[1].ravel())[0, 1])
    assert corr > 0.5, corr
