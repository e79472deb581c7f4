"""Stage 2, the atlas: a mesh pre-rendered once at every pose, stored, and served as sprites.

- :mod:`~sdcomp.atlas.poses`: view geometry and the pose grid;
- :mod:`~sdcomp.atlas.raster`: the orthographic z-buffer rasteriser (one pose -> a sprite);
- :mod:`~sdcomp.atlas.store`: building, saving, loading and caching atlases;
- :mod:`~sdcomp.atlas.sheet`: the contact sheet of an atlas;
- :mod:`~sdcomp.atlas.sprites`: atlas sprites as premultiplied mip levels for the renderer.

``python -m sdcomp.atlas build|info`` is :mod:`sdcomp.cli.atlas`.
"""

from .store import (
    Atlas,
    AtlasConfig,
    AtlasError,
    build_atlas,
    cache_key,
    ensure_atlas,
    load_atlas,
    read_index,
    save_atlas,
)

__all__ = ["Atlas", "AtlasConfig", "AtlasError", "build_atlas", "cache_key", "ensure_atlas",
           "load_atlas", "read_index", "save_atlas"]
