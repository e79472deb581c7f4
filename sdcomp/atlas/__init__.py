"""Stage 2, the atlas: a mesh pre-rendered once at every pose, stored, and served as sprites.

- :mod:`~sdcomp.atlas.poses`: view geometry and the pose grid;
- :mod:`~sdcomp.atlas.raster`: the orthographic z-buffer rasteriser (one pose -> a sprite);
- :mod:`~sdcomp.atlas.store`: building, saving and loading atlases;
- :mod:`~sdcomp.atlas.cache`: an atlas folder's reuse-or-build, one process at a time;
- :mod:`~sdcomp.atlas.sheet`: the contact sheet of an atlas;
- :mod:`~sdcomp.atlas.sprites`: atlas sprites as premultiplied mip levels for the renderer.

``python -m sdcomp.atlas build|info`` is :mod:`sdcomp.cli.atlas`.
"""

from .cache import ensure_atlas
from .store import (
    Atlas,
    AtlasConfig,
    AtlasError,
    build_atlas,
    cache_key,
    load_atlas,
    read_index,
    save_atlas,
)

__all__ = ["Atlas", "AtlasConfig", "AtlasError", "build_atlas", "cache_key", "ensure_atlas",
           "load_atlas", "read_index", "save_atlas"]
