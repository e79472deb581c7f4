"""The memory an atlas build needs, and how many workers fit in this machine's memory.

A build holds the mesh and what its loading left in the heap (:data:`HELD_BYTES_PER_FACE`),
every pose's sprite, their occlusion maps and the arrays it saves
(:data:`HELD_BYTES_PER_SPRITE_PIXEL` per sprite pixel of every pose), in the building
process; and each worker rasterises one pose at a time: a z-buffer and its attribute planes
per sub-pixel (:data:`RENDER_BYTES_PER_SUBPIXEL`, ``(size x supersample)^2`` of them) and the
mesh's transformed vertices and faces (:data:`RENDER_BYTES_PER_FACE`). Measured (docs/meshes.md,
"Memory"): 148 bytes a sub-pixel (a 1024 px sprite at supersample 8), 213-360 bytes a face
(1.3 and 5.2 million faces; three vertices per face the dearer), 79 bytes a sprite pixel
(188 poses of 512 px: 3.8 GiB in the building process, 0.5 GiB in each of two workers), 365
bytes a face held by the building process (a PLY of 1.3 million faces, 128 px: 842 MiB
there, 413 MiB in each of two workers).

:func:`fitting_workers` lowers the number of workers to what fits (the atlas does not depend
on it) and refuses, with the figure, a build that does not fit even with one.
"""

from __future__ import annotations

from ..util.log import get_logger
from ..util.memory import check_fits, machine_bytes

MIB = 1 << 20
BASE_BYTES = 150 * MIB  #: the building process before its sprites: interpreter, mesh
HELD_BYTES_PER_SPRITE_PIXEL = 80
HELD_BYTES_PER_FACE = 500
RENDER_BYTES_PER_SUBPIXEL = 150
RENDER_BYTES_PER_FACE = 400
WORKER_BYTES = 100 * MIB  #: a worker process's own, beside its pose


def build_bytes(faces: int, size: int, supersample: int, poses: int) -> tuple[int, int]:
    """(bytes the building process holds, bytes each rendering worker needs) for an atlas
    of ``poses`` sprites of ``size`` px at ``supersample`` of a mesh of ``faces`` faces."""
    held = (BASE_BYTES + HELD_BYTES_PER_SPRITE_PIXEL * poses * size * size
            + HELD_BYTES_PER_FACE * faces)
    each = (WORKER_BYTES + RENDER_BYTES_PER_SUBPIXEL * (size * supersample) ** 2
            + RENDER_BYTES_PER_FACE * faces)
    return held, each


def fitting_workers(name: str, faces: int, size: int, supersample: int, poses: int,
                    workers: int) -> int:
    """The workers (at most ``workers``, at least 1) whose build of the atlas ``name`` fits in
    this machine's memory; UserError naming the sizes and the figure when one does not."""
    held, each = build_bytes(faces, size, supersample, poses)
    fit = (machine_bytes() - held) // each
    if fit < 1:
        check_fits(held + each, f"the sprite atlas of {name} ({poses} poses of {size} px at "
                   f"supersample {supersample}, {faces:,} faces)",
                   "lower --size or --supersample, or simplify the mesh")
        fit = 1
    if fit < workers:
        get_logger(__name__).info("building the atlas of %s with %d workers instead of %d: "
                                  "more would not fit in this machine's memory", name, fit,
                                  workers)
    return int(max(1, min(workers, fit)))
