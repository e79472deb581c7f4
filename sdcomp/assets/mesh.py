"""A triangle mesh with one sRGB colour per face and a waterline: what the renderer draws.

Frame and units: metres; x forward, y port (left), z up; origin at the centre of the mesh's
axis-aligned bounding box. ``waterline`` is the height (z, metres) where the sea surface cuts
the object when it floats; the renderer reports heights relative to it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class ColoredMesh:
    """An immutable coloured triangle mesh.

    Attributes:
        vertices: (V, 3) float64, metres, body frame (x forward, y port, z up).
        faces: (F, 3) int64 vertex indices, counter-clockwise seen from outside.
        face_colors: (F, 3) uint8 sRGB albedo of each face.
        waterline: z of the sea surface in the body frame, metres.
        name: short name used for file names (atlas, exports).
        closed: True when every part is a closed, consistently oriented surface, so that
            back faces can never be seen and may be culled.
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_colors: np.ndarray
    waterline: float
    name: str
    closed: bool = False
    _hash: list = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self) -> None:
        v = np.ascontiguousarray(self.vertices, dtype=np.float64)
        f = np.ascontiguousarray(self.faces, dtype=np.int64)
        c = np.ascontiguousarray(self.face_colors, dtype=np.uint8)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices must be (V, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"faces must be (F, 3), got {f.shape}")
        if c.shape != f.shape:
            raise ValueError(f"face_colors must be (F, 3) like faces, got {c.shape}")
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError("faces index vertices that do not exist")
        for arr in (v, f, c):
            arr.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        object.__setattr__(self, "face_colors", c)
        object.__setattr__(self, "waterline", float(self.waterline))

    @property
    def extents(self) -> np.ndarray:
        """(3,) float64 size of the axis-aligned bounding box, metres."""
        return self.vertices.max(axis=0) - self.vertices.min(axis=0)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64 min and max corners of the bounding box, metres."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def content_hash(self) -> str:
        """SHA-256 (hex) of the geometry, colours and waterline: equal meshes, equal hashes."""
        if not self._hash:
            h = hashlib.sha256()
            h.update(np.float64(self.waterline).tobytes())
            h.update(np.array(self.closed).tobytes())
            for arr in (self.vertices, self.faces, self.face_colors):
                h.update(str(arr.shape).encode())
                h.update(arr.tobytes())
            self._hash.append(h.hexdigest())
        return self._hash[0]

    def to_trimesh(self):
        """The mesh as a ``trimesh.Trimesh`` with face colours (for export and viewing)."""
        import trimesh

        rgba = np.concatenate(
            [self.face_colors, np.full((len(self.faces), 1), 255, np.uint8)], axis=1)
        return trimesh.Trimesh(self.vertices, self.faces, face_colors=rgba, process=False)


def centred(vertices: np.ndarray, waterline: float) -> tuple[np.ndarray, float]:
    """Shift ``vertices`` (V, 3) so their bounding box is centred on the origin.

    Returns the shifted vertices and the waterline expressed in the new frame.
    """
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2.0
    return vertices - centre, float(waterline - centre[2])
