"""Lofted boat hulls: stations of a parametric half-section along a parametric plan and profile.

Frame: metres, x forward (stern at x = -L/2, stem at x = +L/2), y port, z up, keel amidships
at z = 0, sheer amidships at z = depth. A station at fraction ``u`` of the length (0 = stern,
1 = stem) is a closed ring: keel, port half-section up to the gunwale, across the deck to the
starboard gunwale and back down; the loft of the rings is a closed solid whose top is the deck.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import manifold3d as m3
import numpy as np

from ..lofts import loft

HALF_POINTS = 7  # points of a half-section, keel to gunwale
MIN_HALF_BEAM = 0.012  # metres: the stem and a double-ender's stern are this narrow


@dataclass(frozen=True)
class HullSpec:
    """A hull's main dimensions (metres) and shape parameters.

    shape: "v" (hard chine, straight deadrise: planing motor boats, RIBs, skiffs) or "round"
        (superellipse sections: sailboats, kayaks, canoes, rowing boats).
    transom: stern half-beam over the maximum half-beam (about 0 for double-enders).
    max_at: fraction of the length from the stern where the beam is largest.
    sheer_bow / sheer_stern: rise of the sheer (deck edge) at the stem / stern, metres.
    bow_rise / stern_rise: rise of the keel at the stem / stern as a fraction of depth.
    forefoot: fraction of the length from the stern where the keel starts to rise forward.
    fullness: superellipse exponent of round sections (2 = ellipse, larger = boxier).
    chine: chine half-width over the gunwale half-width (v shape; < 1 means flared topsides).
    """

    length: float
    beam: float
    depth: float
    shape: str = "v"
    deadrise: float = 18.0
    transom: float = 0.85
    max_at: float = 0.45
    sheer_bow: float = 0.15
    sheer_stern: float = 0.0
    bow_rise: float = 0.55
    stern_rise: float = 0.0
    forefoot: float = 0.55
    fullness: float = 2.2
    chine: float = 0.86

    def half_beam(self, u: float) -> float:
        """Half-beam at the sheer (metres) at length fraction ``u``."""
        m = self.max_at
        if u <= m:
            w = (m - u) / m
            f = self.transom + (1 - self.transom) * math.cos(math.pi / 2 * w) ** 0.9
        else:
            w = (u - m) / (1 - m)
            f = math.cos(math.pi / 2 * min(w, 1.0)) ** 0.85
        return max(f * self.beam / 2, MIN_HALF_BEAM)

    def keel(self, u: float) -> float:
        """Height of the keel line (metres) at ``u``."""
        k = 0.0
        if u > self.forefoot:
            k += self.depth * self.bow_rise * ((u - self.forefoot) / (1 - self.forefoot)) ** 2
        aft = 1 - self.forefoot
        if self.stern_rise > 0 and u < aft:
            k += self.depth * self.stern_rise * ((aft - u) / aft) ** 2
        return k

    def sheer(self, u: float) -> float:
        """Height of the sheer (deck edge, metres) at ``u``."""
        bow = max(0.0, (u - 0.3) / 0.7) ** 2
        stern = max(0.0, (0.7 - u) / 0.7) ** 2
        return self.depth + self.sheer_bow * bow + self.sheer_stern * stern

    def x(self, u: float) -> float:
        return -self.length / 2 + u * self.length

    def half_section(self, u: float, inset: float = 0.0, bottom: float = 0.0,
                     top: float = 0.0) -> np.ndarray:
        """(HALF_POINTS, 2) (y, z) points from the keel to the port gunwale at ``u``.

        ``inset``/``bottom`` move the section in from the sides / up from the keel and
        ``top`` raises the gunwale (for the inside of a hollow hull).
        """
        b = max(self.half_beam(u) - inset, MIN_HALF_BEAM)
        k = self.keel(u) + bottom
        s = self.sheer(u) + top
        if self.shape == "round":
            t = np.linspace(0.0, math.pi / 2, HALF_POINTS)
            e = 2.0 / self.fullness
            return np.stack([b * np.sin(t) ** e, s - (s - k) * np.cos(t) ** e], axis=1)
        dr = math.radians(self.deadrise + (60.0 - self.deadrise) * max(0.0, (u - 0.6) / 0.4) ** 2)
        yc = self.chine * b
        zc = k + yc * math.tan(dr)
        if zc > k + 0.6 * (s - k):
            zc = k + 0.6 * (s - k)
            yc = (zc - k) / math.tan(dr)
        bottom_t = np.array([0.0, 1 / 3, 2 / 3, 1.0])
        side_t = np.array([1 / 3, 2 / 3, 1.0])
        ys = np.concatenate([yc * bottom_t, yc + (b - yc) * side_t])
        zs = np.concatenate([k + (zc - k) * bottom_t, zc + (s - zc) * side_t])
        return np.stack([ys, zs], axis=1)

    def ring(self, u: float, **kw) -> np.ndarray:
        """(2 * HALF_POINTS - 1, 3) closed station ring at ``u`` (keel, port, starboard)."""
        half = self.half_section(u, **kw)
        port = half
        stbd = half[:0:-1] * [-1, 1]
        yz = np.concatenate([port, stbd])
        return np.column_stack([np.full(len(yz), self.x(u)), yz])


def stations(n: int, u0: float = 0.0, u1: float = 1.0) -> np.ndarray:
    """``n`` length fractions from ``u0`` to ``u1``, denser towards both ends."""
    t = 0.5 - 0.5 * np.cos(np.pi * np.linspace(0.0, 1.0, n))
    return u0 + (u1 - u0) * t


def hull_solid(spec: HullSpec, n: int = 18) -> m3.Manifold:
    """The closed hull (deck on top) lofted over ``n`` stations."""
    return loft([spec.ring(u) for u in stations(n)])


def interior(spec: HullSpec, wall: float, floor: float, u0: float, u1: float,
             n: int = 14, top: float = 0.5) -> m3.Manifold:
    """The hollow of an open hull between ``u0`` and ``u1``: walls ``wall`` thick, floor
    ``floor`` above the keel, reaching ``top`` metres above the sheer (to cut the deck away)."""
    return loft([spec.ring(u, inset=wall, bottom=floor, top=top) for u in stations(n, u0, u1)])


def usable_span(spec: HullSpec, min_half_beam: float, u0: float = 0.0,
                u1: float = 1.0) -> tuple[float, float]:
    """The longest [a, b] within [u0, u1] where the half-beam exceeds ``min_half_beam``."""
    us = np.linspace(u0, u1, 400)
    ok = np.array([spec.half_beam(u) > min_half_beam for u in us])
    if not ok.any():
        raise ValueError("the hull is nowhere that wide")
    idx = np.flatnonzero(ok)
    return float(us[idx[0]]), float(us[idx[-1]])


def deck_band(spec: HullSpec, below: float, above: float, out: float = 0.01,
              n: int = 18, u0: float = 0.0, u1: float = 1.0) -> m3.Manifold:
    """A thin slab following the sheer (``below`` under it to ``above`` over it, ``out``
    beyond the sides): painted, it gives the deck its colour and the hull a rubbing strake."""
    rings = []
    for u in stations(n, u0, u1):
        b = spec.half_beam(u) + out
        s = spec.sheer(u)
        x = spec.x(u)
        rings.append(np.array([[x, b, s - below], [x, b, s + above], [x, -b, s + above],
                               [x, -b, s - below]]))
    return loft(rings)


def plan_inset(spec: HullSpec, inset: float, u0: float, u1: float, z0: float, z1: float,
               n: int = 10, taper: float = 0.0) -> m3.Manifold:
    """A prism whose plan follows the hull's sheer-line plan inset by ``inset`` metres,
    between ``u0`` and ``u1`` along the length and from ``z0`` to ``z1`` (a cabin trunk, a
    cockpit well); ``taper`` narrows the top by that many metres each side."""
    rings = []
    for u in stations(n, u0, u1):
        b = max(spec.half_beam(u) - inset, 0.03)
        bt = max(b - taper, 0.02)
        x = spec.x(u)
        rings.append(np.array([[x, b, z0], [x, bt, z1], [x, -bt, z1], [x, -b, z0]]))
    return loft(rings)
