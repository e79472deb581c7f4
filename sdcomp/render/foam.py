"""The water disturbed by a floating object: contact foam around its waterline.

Small waves break against a floating hull and the water it rocks in froths: from the air a
floating object is ringed by a thin, broken band of foam a few tens of centimetres wide, whiter
in wind. Only a body that stands against the short waves makes it (a hull; not a swimmer's
head or a small buoy, which ride them: :func:`ring_share`), and any body moving through the
water splashes there, a swimmer's head too (:func:`splash_strength`). The band is drawn on
the water (it is not the object: it is never annotated) before
the objects and their shadows, so the objects' coverage hides it (at a hull's edge pixels the
foam fills the water's part only), shadows darken it, and the masks are unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

RING_WIDTH = 0.12  # metres: the foam band's width around the waterline
RING_EDGE = 0.03  # metres: the hull within this height of the water makes foam
RING_WALL = 0.5  # metres: an outline this close above the water is a wall into it
RING_MIN_PX = 0.7  # sprite pixels: narrower bands are not drawn
FOAM_ALBEDO = 0.6  # of fresh foam (diffuse)
FOAM_BUBBLES = 0.05  # metres: the size of the foam's patches
BAND_PIXELS = 1 << 18  # rings are warped and blended in bands of rows of this many pixels
#: metres across (square root of the area above the water) below which a floating body
#: rides the short waves and makes no contact foam, and from which it makes all of it
RING_SMALL_M = 0.3
RING_FULL_M = 1.5
#: m/s: a body moving through the water at this speed or faster breaks its surface all
#: round (a swimmer's kicks and strokes, a small craft's spray), whatever its size: its
#: waterline froths with :data:`SPLASH_PEAK` coverage, slower in proportion
SPLASH_SPEED = 1.0
SPLASH_PEAK = 0.35
#: a swimmer at rest who treads water (:func:`sdcomp.scene.objects.stirring` 1) ringed by
#: disturbed, lighter water this wide and strong: the kicks and sculling break the surface
#: into small ripples and bubbles around the head and shoulders
STIR_WIDTH = 0.35  # metres
STIR_PEAK = 0.22


@dataclass(frozen=True)
class FoamRing:
    """One object's contact foam, ready to draw: ``cover`` (h, w) float32 coverage in the
    sprite's pixels, ``affine`` (2, 3) float64 from them to the frame window ``roi`` = (x0,
    y0, x1, y1), ``colour`` the lit foam's sRGB levels (0..255, 3 floats); ``depth`` metres
    (the rings are drawn far first)."""

    depth: float
    cover: np.ndarray
    affine: np.ndarray
    roi: tuple[int, int, int, int]
    colour: tuple[float, ...]


def draw_ring(image: np.ndarray, ring: FoamRing) -> None:
    """Composite ``ring`` over the uint8 (H, W, 3) ``image`` in place: ``image (1 - c) +
    colour c`` with ``c`` the coverage warped into the frame (bilinear), band by band of
    rows (:data:`BAND_PIXELS`): no frame-sized temporary."""
    x0, y0, x1, y1 = ring.roi
    rows = max(1, BAND_PIXELS // max(x1 - x0, 1))
    colour = np.array(ring.colour, np.float32)
    for a in range(y0, y1, rows):
        b = min(a + rows, y1)
        shift = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, float(a - y0)]])
        c = cv2.warpAffine(ring.cover, ring.affine - shift, (x1 - x0, b - a),
                           flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                           borderValue=0)
        np.clip(c, 0.0, 1.0, out=c)
        region = image[a:b, x0:x1]
        out = region.astype(np.float32) * (1.0 - c)[..., None] + c[..., None] * colour
        region[:] = np.clip(out + 0.5, 0, 255).astype(np.uint8)


def ring_share(dry_m: float) -> float:
    """The share of the full contact foam (:func:`ring_strength`) that an object whose part
    above the water is ``dry_m`` metres across (square root of its area) makes: waves break
    into froth against a body that stands in their way, not against one so small that it
    rides them (a swimmer's head, a small buoy): none below :data:`RING_SMALL_M`, all from
    :data:`RING_FULL_M`."""
    return float(np.clip((dry_m - RING_SMALL_M) / (RING_FULL_M - RING_SMALL_M), 0.0, 1.0))


def splash_strength(speed: float) -> float:
    """Peak coverage of the froth a body moving at ``speed`` m/s through the water makes
    at its waterline (:data:`SPLASH_PEAK` from :data:`SPLASH_SPEED`, in proportion below;
    none at rest): a crawling swimmer's white water, which a head at rest does not make."""
    return SPLASH_PEAK * min(max(float(speed), 0.0) / SPLASH_SPEED, 1.0)


def ring_strength(wind: float) -> float:
    """Peak coverage of the contact foam at ``wind`` m/s: a faint froth in calm water, half
    the surface at a strong breeze."""
    return min(0.12 + 0.04 * max(wind, 0.0), 0.5)


def contact_foam(alpha: np.ndarray, depth: np.ndarray, pitch_m: float, strength: float,
                 seed: tuple[int, ...], width_m: float = RING_WIDTH
                 ) -> tuple[int, np.ndarray] | None:
    """(pad, coverage (n + 2 pad, n + 2 pad) float32) of the foam ring of a sprite of
    coverage ``alpha`` (n, n) whose pixels lie ``depth`` (n, n) metres under the water
    (negative: above), ``pitch_m`` metres per pixel; the canvas is the sprite's padded by
    ``pad`` pixels on each side. The ring: the hull's pixels at the waterline (within
    :data:`RING_EDGE` of the water, dry next to wet, or on the outline of a wall standing
    less than :data:`RING_WALL` out of the water; never the outline of a submerged part),
    dilated by ``width_m`` (:data:`RING_WIDTH`), softened,
    broken into patches of :data:`FOAM_BUBBLES` (a smooth random field of ``seed``), scaled
    to ``strength``. None when no ring is drawn (no hull at the water: standing clear of it
    or wholly under it; or the band narrower than :data:`RING_MIN_PX`)."""
    width = width_m / pitch_m
    if width < RING_MIN_PX or strength <= 0:
        return None
    body = alpha > 0.5
    dry = body & (depth <= 0)
    wet = body & (depth > 0)
    cross = np.ones((3, 3), np.uint8)
    near = (cv2.dilate(wet.astype(np.uint8), cross) > 0) & dry
    near |= (cv2.dilate(dry.astype(np.uint8), cross) > 0) & wet
    near |= body & (np.abs(depth) < RING_EDGE)
    # walls seen from above: the outline of a hull whose edge stands near the water (not
    # the outline of a part wholly under it: a swimmer's legs make no foam)
    outline = body & (cv2.erode(body.astype(np.uint8), cross) == 0)
    near |= outline & (depth > -RING_WALL) & (depth < RING_EDGE)
    if not dry.any() or not near.any():
        return None
    pad = int(math.ceil(1.5 * width)) + 1
    k = 2 * int(math.ceil(width)) + 1
    src = cv2.copyMakeBorder(near.astype(np.uint8), pad, pad, pad, pad, cv2.BORDER_CONSTANT,
                             value=0)
    grown = cv2.dilate(src, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    ring = cv2.GaussianBlur(np.asarray(grown, np.float32), (0, 0), max(width / 3.0, 0.5))
    rng = np.random.default_rng([*seed, 0xF0A3])
    white = np.asarray(rng.standard_normal(ring.shape), np.float32)
    field = np.asarray(cv2.GaussianBlur(white, (0, 0), max(FOAM_BUBBLES / pitch_m, 0.5)),
                       np.float32)
    field /= np.float32(max(float(field.std()), 1e-6))
    patches = np.clip(0.35 + 0.8 * field, 0.0, 1.0)
    cover = ring * patches * np.float32(strength)
    return pad, np.minimum(cover, 1.0).astype(np.float32)
