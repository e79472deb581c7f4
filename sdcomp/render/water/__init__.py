"""The sea and the sky seen by a drone camera, physically based (see docs/water.md).

- :mod:`~sdcomp.render.water.surface`: :func:`render_water`, the sea and sky of one image;
- :mod:`~sdcomp.render.water.coarse`: the smooth terms on a coarse grid, exposure, and the
  light a floating object sees (:class:`WaterLight`);
- :mod:`~sdcomp.render.water.layers`, :mod:`~sdcomp.render.water.shading`,
  :mod:`~sdcomp.render.water.glitter`: the per-pixel waves, their shading, whitecaps and
  the sun's glitter;
- :mod:`~sdcomp.render.water.waves`, :mod:`~sdcomp.render.water.spectrum`: slope statistics
  (Elfouhaily et al. 1997 scaled to Cox & Munk 1954);
- :mod:`~sdcomp.render.water.sky`: the sky (CIE skies, clouds, haze);
- :mod:`~sdcomp.render.water.optics`: Fresnel, IOPs and reflectance (Gordon et al. 1988);
- :mod:`~sdcomp.render.water.textures`: the periodic tiles, built once per generator;
- :mod:`~sdcomp.render.water.geometry`: rays, coarse grids and pixel footprints.
"""

from .coarse import WaterLight, auto_exposure
from .surface import render_water
from .textures import WaterTextures
from .waves import wave_state

__all__ = ["WaterLight", "WaterTextures", "auto_exposure", "render_water", "wave_state"]
