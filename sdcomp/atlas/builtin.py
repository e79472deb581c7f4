"""Atlas parameters of the built-in meshes: how large their sprites are and which poses they
store, chosen per kind so that the first build of every kind takes about a minute.

- the BlueROV2 and user meshes: :class:`AtlasConfig`'s defaults (128 px, 4x4 supersampled,
  188 poses every 7.5 degrees);
- the search-and-rescue kinds (:data:`KIND_ATLAS`): 3x3 supersampled, 104 poses (rings
  every 15 degrees off nadir to 80, every view within 10 degrees of a stored one: the in-
  plane rotation is exact anyway), 128 px for swimmers, boats and jet skis and 96 px for
  life-saving appliances and buoys, which are a few dozen pixels in SeaDronesSee's frames;
  each variant's sprite is made larger (:func:`sprite_size`: up to 1.5 times, to 128 or 192
  px) when its bounding sphere is much wider than its footprint (a sailboat's mast, an
  upright swimmer's legs, a spar buoy), so that the visible part keeps its pixels;
- clutter (:data:`CLUTTER_ATLAS`): 64 px, 3x3, 104 poses, whatever the mesh; moorings
  (docks, canopied lifts, 7-8 m long beside the objects they hold) 256 px at 2x2
  (:data:`MOORING_ATLAS`: 3-4 cm a pixel, as fine as a 3 m jet ski's 128 px).

Sprites are square; their pixel pitch (metres per pixel) covers the mesh's bounding sphere
at every pose (:func:`sdcomp.atlas.store.metres_per_pixel`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..assets.clutter import MOORINGS
from ..assets.mesh import ColoredMesh
from .poses import PoseGrid
from .store import AtlasConfig

#: the pose grid of clutter and of the search-and-rescue kinds (104 poses)
COARSE_GRID = PoseGrid(off_nadir_step=15.0, max_error=10.0)
#: atlas parameters of clutter meshes: small sprites, the coarse pose grid
CLUTTER_ATLAS = AtlasConfig(size=64, supersample=3, grid=COARSE_GRID)
#: atlas parameters of the moorings (:data:`sdcomp.assets.clutter.MOORINGS`)
MOORING_ATLAS = AtlasConfig(size=256, supersample=2, grid=COARSE_GRID)
#: base atlas parameters of each search-and-rescue kind (see :func:`sprite_size`)
KIND_ATLAS = {
    "swimmer": AtlasConfig(size=128, supersample=3, grid=COARSE_GRID),
    "boat": AtlasConfig(size=128, supersample=3, grid=COARSE_GRID),
    "jetski": AtlasConfig(size=128, supersample=3, grid=COARSE_GRID),
    "life_saving_appliances": AtlasConfig(size=96, supersample=3, grid=COARSE_GRID),
    "buoy": AtlasConfig(size=96, supersample=3, grid=COARSE_GRID),
}
TALL_RATIO = 1.25  # bounding-sphere diameter over footprint above which sprites grow
MAX_GROWTH = 1.5  # ... by at most this factor


def sprite_size(mesh: ColoredMesh, base: int) -> int:
    """Sprite side (pixels) for ``mesh`` in an atlas of ``base`` px: ``base`` times the
    ratio of its bounding-sphere diameter to its footprint (largest horizontal extent) over
    :data:`TALL_RATIO`, at most :data:`MAX_GROWTH` times ``base``, rounded (in log scale)
    to a size whose mip levels halve exactly to a few pixels (2**k or 3 * 2**k: 96, 128,
    192 px)."""
    diameter = 2.0 * float(np.linalg.norm(mesh.vertices, axis=1).max())
    footprint = max(float(mesh.extents[0]), float(mesh.extents[1]), 1e-9)
    want = base * min(max(diameter / footprint / TALL_RATIO, 1.0), MAX_GROWTH)
    k = math.floor(math.log2(want))
    sizes = (1 << k, 3 << (k - 1), 2 << k)
    return min(sizes, key=lambda size: abs(math.log(size / want)))


def object_atlas(mesh: ColoredMesh, kind: str | None) -> AtlasConfig:
    """The atlas parameters of ``mesh`` as an object of interest: for a variant of the
    search-and-rescue ``kind``, the kind's with the variant's :func:`sprite_size`; the
    defaults for any other mesh (``kind`` None)."""
    if kind is None:
        return AtlasConfig()
    base = KIND_ATLAS[kind]
    return replace(base, size=sprite_size(mesh, base.size))


def clutter_atlas(mesh: ColoredMesh) -> AtlasConfig:
    """The atlas parameters of ``mesh`` as clutter: :data:`MOORING_ATLAS` for a mooring,
    else :data:`CLUTTER_ATLAS`."""
    return MOORING_ATLAS if mesh.name in MOORINGS else CLUTTER_ATLAS
