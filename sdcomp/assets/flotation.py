"""Where a solid floats: the height of its waterline from the volume it displaces.

Heights are z in the solid's own frame (metres, z up); volumes in cubic metres; masses in
kilograms. Archimedes: a body of mass ``m`` floats where the volume under the water
surface is ``m / rho``.
"""

from __future__ import annotations

import manifold3d as m3

SEAWATER = 1025.0  #: density of sea water, kg/m^3


def volume_below(solid: m3.Manifold, z: float) -> float:
    """Volume (m^3) of the part of ``solid`` below the plane at height ``z``."""
    return solid.trim_by_plane([0.0, 0.0, -1.0], -z).volume()


def waterline_for_volume(solid: m3.Manifold, displaced: float) -> float:
    """Height z at which ``solid`` displaces ``displaced`` m^3 of water (bisection to
    1e-5 m); ValueError unless 0 < displaced < the solid's volume."""
    lo, hi = solid.bounding_box()[2], solid.bounding_box()[5]
    total = solid.volume()
    if not 0 < displaced < total:
        raise ValueError(f"displacement {displaced:.4g} m^3 outside (0, {total:.4g})")
    for _ in range(40):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if volume_below(solid, mid) < displaced else (lo, mid)
        if hi - lo < 1e-5:
            break
    return (lo + hi) / 2


def waterline_for_fraction(solid: m3.Manifold, fraction: float) -> float:
    """Height z at which ``fraction`` (0-1) of the solid's volume lies under water."""
    return waterline_for_volume(solid, fraction * solid.volume())


def waterline_for_mass(solid: m3.Manifold, mass_kg: float, rho: float = SEAWATER) -> float:
    """Height z where ``solid`` of total mass ``mass_kg`` floats in water of density
    ``rho`` (kg/m^3)."""
    return waterline_for_volume(solid, mass_kg / rho)
