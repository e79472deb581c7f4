"""Gloss: the light a hard object's surface reflects like a mirror, on top of its diffuse
colour.

Gelcoat, paint and moulded plastic are dielectrics whose surface reflects about 4 % of the
light at normal incidence (Fresnel's ``F0`` for a refractive index near 1.5), more at grazing
incidence (Schlick's approximation ``F = F0 + (1 - F0) (1 - cos)^5``), and lets the rest in
to be scattered back as the diffuse colour (``1 - F`` of the Lambertian term). What the
mirror shows:

- the **sky** in the reflected direction ``r = 2 (n . v) n - v`` (or, for a surface facing
  down, the sea's light from below), blurred by 0.2 radians: a white hull seen obliquely
  mirrors the bright sky near the horizon as the water does, a black seat the sky above it;
- the **sun**, as a highlight: the microfacet model with the GGX (Trowbridge-Reitz)
  distribution of roughness ``alpha`` (Walter et al. 2007), radiance
  ``E_sun F(v . h) D(n . h) / (4 (n . v))`` for the half vector ``h`` between the view and
  the sun (the masking term taken as 1); where a curved hull, a windscreen or a round buoy
  faces the half vector, a small, nearly white glint.

Which kinds are glossy: :data:`ROUGHNESS`. Directions are unit vectors in one frame (the
sprite pose's: right, up, toward the camera, so the view ``v`` is +z there). Radiances are
relative linear RGB before exposure, as :mod:`sdcomp.render.lighting` has them.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..scene.objects import asset_kind
from .water.optics import schlick
from .water.sky import Sky

N_HULL = 1.5  #: refractive index of gelcoat, paint and plastic
F0 = ((N_HULL - 1) / (N_HULL + 1)) ** 2  #: Fresnel reflectance at normal incidence (0.04)
#: GGX roughness (alpha) of the glossy kinds' surfaces, objects and clutter alike:
#: the gelcoat, paint and moulded plastic of hulls, jet skis and buoys, polished (GGX's long
#: tail grows with alpha squared: at 0.1 a round buoy's highlight is a small spot and flat
#: tops far from the sun's mirror direction get little of it; what pales a red top under a
#: blue sky is the mirrored sky). The other kinds stay matte: swimmers (hair, skin, the nylon jersey
#: of wetsuits and life jackets), whose colours are fitted to real boxes as seen (with gloss
#: their median contrast against the water went from -1.16 to -0.59, real -1.88), the
#: fabric and foam of life-saving appliances, the BlueROV2 and clutter-only meshes (logs)
ROUGHNESS = {"boat": 0.1, "jetski": 0.1, "buoy": 0.1}
MIN_COS_VIEW = 0.1  #: the highlight's 1 / (4 n.v) is capped at grazing views (masking)
SKY_TEXELS = 33  #: the sky table's side: the upper hemisphere in stereographic projection


def roughness(asset: str) -> float | None:
    """The GGX roughness of asset ``asset`` (a key such as ``boat-03`` or
    ``clutter:boat-03``, by its kind: :func:`~sdcomp.scene.objects.asset_kind`); None for a
    matte one (no gloss)."""
    return ROUGHNESS.get(asset_kind(asset))


def sky_table(sky: Sky, blur: float = 0.2) -> np.ndarray:
    """(SKY_TEXELS, SKY_TEXELS, 3) float32 sky radiance (relative linear RGB) seen through an
    angular blur of ``blur`` radians: what a glossy surface mirrors, looked up by
    :func:`sky_lookup`. Texel (i, j) holds the direction whose stereographic projection
    ``(x, y) / (1 + z)`` is ``(2 j / (SKY_TEXELS - 1) - 1, 2 i / (SKY_TEXELS - 1) - 1)``
    (world frame); points outside the unit disc hold the horizon in their direction. The
    projection spends half the radius on the lowest 37 degrees of sky, where it changes
    most, with no trigonometry per pixel."""
    c = np.linspace(-1.0, 1.0, SKY_TEXELS)
    a, b = np.meshgrid(c, c)
    r2 = a * a + b * b
    scale = np.where(r2 > 1.0, 1.0 / np.sqrt(np.maximum(r2, 1e-12)), 1.0)
    a, b = a * scale, b * scale
    r2 = np.minimum(r2, 1.0)
    d = np.stack([2 * a, 2 * b, 1 - r2], axis=-1) / (1 + r2)[..., None]
    blurs = np.full(d.shape[:2], blur, np.float32)
    return sky.radiance(d.astype(np.float32), blurs).astype(np.float32)


def sky_lookup(table: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(N, 3) float32 radiance of :func:`sky_table` ``table`` in world directions ``d``
    (N, 3) float32 unit vectors with z >= 0 (lower ones read the horizon), bilinear."""
    inv = np.float32((SKY_TEXELS - 1) / 2) / (1.0 + np.maximum(d[:, 2:3], 0.0))
    m = d[:, :2] * inv + np.float32((SKY_TEXELS - 1) / 2)
    out = cv2.remap(table, m[:, :1], m[:, 1:], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(-1, 3)


def ggx(cos_h: np.ndarray, alpha: float) -> np.ndarray:
    """The GGX normal distribution D (per steradian, float32 like ``cos_h``) at the cosine
    ``cos_h`` between the normal and the half vector, roughness ``alpha``."""
    a2 = np.float32(alpha * alpha)
    t = cos_h * cos_h * (a2 - 1) + 1
    return a2 / (np.float32(math.pi) * t * t)


def add_gloss(diffuse: np.ndarray, alpha: np.ndarray, normal: np.ndarray,
              to_world: np.ndarray, sun_dir: np.ndarray, sun: np.ndarray, table: np.ndarray,
              below: np.ndarray, rough: float) -> np.ndarray:
    """``diffuse`` (n, n, 3) float32 Lambertian radiance times ``1 - F`` plus the mirrored
    sky and the sun's highlight (module docstring), in place where ``alpha`` > 0; returns
    it.

    Args:
        diffuse: (n, n, 3) float32 linear radiance of the surfaces without gloss.
        alpha: (n, n) float32 coverage (uncovered pixels are left alone).
        normal: (n, n, 3) float32 unit normals in the pose frame (view = +z).
        to_world: (3, 3) the pose frame's axes in the world (columns).
        sun_dir: (3,) unit vector towards the sun, pose frame.
        sun: (3,) direct irradiance of the sun on a surface facing it.
        table: :func:`sky_table` of the image's sky.
        below: (3,) radiance of the sea seen from above the surface (mirrored by
            surfaces that face down).
        rough: GGX roughness.
    """
    covered = alpha > 0.0
    if not covered.any():
        return diffuse
    n = normal[covered]
    nz = n[:, 2]
    f = schlick(nz, N_HULL)
    r = n * (2.0 * nz)[:, None]
    r[:, 2] -= 1.0
    r_world = r @ np.asarray(to_world, np.float32).T
    mirrored = sky_lookup(table, r_world)
    mirrored[r_world[:, 2] < 0.0] = np.asarray(below, np.float32)
    out = diffuse[covered]
    out *= (1.0 - f)[:, None]
    out += mirrored * f[:, None]
    s = np.asarray(sun_dir, np.float32)
    if float(np.max(sun)) > 0.0:
        h = s + np.array([0.0, 0.0, 1.0], np.float32)
        h /= max(float(np.linalg.norm(h)), 1e-6)
        cos_h = np.clip(n @ h, 0.0, 1.0)
        spec = ggx(cos_h, rough) * np.float32(schlick(float(h[2]), N_HULL))
        spec *= ((n @ s > 0.0) & (nz > 0.0)) / (4.0 * np.maximum(nz, MIN_COS_VIEW))
        out += spec[:, None] * np.asarray(sun, np.float32)
    diffuse[covered] = out
    return diffuse
