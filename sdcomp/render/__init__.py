"""Stage 4, rendering: a :class:`~sdcomp.scene.scene.Scene` and its assets to an image.

:class:`~sdcomp.render.compositor.Compositor` runs the stages: the background
(:mod:`~sdcomp.render.background`: water, floor, :mod:`~sdcomp.render.land` and sky, or
:mod:`~sdcomp.render.photos`), the sprite layers (:mod:`~sdcomp.render.layers`), compositing
(:mod:`~sdcomp.render.composite`) and camera effects (:mod:`~sdcomp.render.effects`), with the
light of :mod:`~sdcomp.render.lighting`, the optics of :mod:`~sdcomp.render.water.optics` and the
ground textures of :mod:`~sdcomp.render.textures` seen through :mod:`~sdcomp.render.ground`.
"""

from .compositor import Compositor, RenderAssets, Rendered

__all__ = ["Compositor", "RenderAssets", "Rendered"]
