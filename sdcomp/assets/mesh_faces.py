"""A mesh file's triangle count, read cheaply before the file is loaded, and the memory
that loading it needs.

:func:`claimed_faces` reads what the file says about its size without building the mesh:
the PLY header's ``element face N``, the OFF header's face count, a binary STL's uint32
triangle count (bytes 80-83, at most what its size holds), the glTF/GLB JSON's index (or
position) accessor counts / 3; ASCII STL and OBJ files have no header and are streamed,
counting ``endfacet`` and ``f`` lines. Polygons count as one face each (a lower bound of
their triangles).

:func:`check_mesh_memory` refuses a file whose count would need more memory to load than the
machine has (:func:`sdcomp.util.memory.check_fits`), before trimesh allocates anything.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

from ..util.memory import check_fits, machine_bytes

#: peak memory of loading a mesh file (trimesh, our checks and merge), bytes per triangle:
#: measured 734 for binary STL (three vertices per triangle), 571 for PLY, 558 for OBJ,
#: about 560 for GLB (1.3 and 5.2 million triangles; docs/meshes.md), rounded up
LOAD_BYTES_PER_FACE = 800
#: the interpreter, numpy and trimesh before a mesh is read, bytes (measured 120-130 MiB)
LOAD_BASE_BYTES = 160 << 20
CHUNK = 1 << 24  # bytes read at a time when a file is streamed
HEADER_BYTES = 1 << 16  # a PLY or OFF header longer than this is not read for its count


def check_mesh_memory(path: Path, suffix: str) -> None:
    """UserError when the mesh file ``path`` (``suffix``: its lower-case extension) claims
    more triangles than this machine's memory can load, naming the count and the figure."""
    faces = claimed_faces(path, suffix)
    if faces is None:
        return
    need = LOAD_BASE_BYTES + faces * LOAD_BYTES_PER_FACE
    most = max(0, (machine_bytes() - LOAD_BASE_BYTES) // LOAD_BYTES_PER_FACE)
    check_fits(need, f"mesh file {str(path)!r} ({faces:,} faces, about "
               f"{LOAD_BYTES_PER_FACE} bytes each to load)",
               f"simplify it to under {most:,} faces (e.g. a decimate modifier) or use a "
               f"machine with more memory")


def claimed_faces(path: Path, suffix: str) -> int | None:
    """The number of faces ``path`` says it holds, or None where it cannot tell cheaply (an
    unreadable header: the loader then reports what is wrong)."""
    reader = {".ply": _ply_faces, ".off": _off_faces, ".stl": _stl_faces, ".obj": _obj_faces,
              ".glb": _glb_faces, ".gltf": _gltf_faces}.get(suffix)
    if reader is None:
        return None
    try:
        return reader(path)
    except (OSError, ValueError, KeyError, TypeError, IndexError, struct.error):
        return None


def _header_lines(path: Path) -> list[str]:
    """The first :data:`HEADER_BYTES` of ``path`` as lines (Latin-1: any byte is a
    character), stripped."""
    with path.open("rb") as f:
        head = f.read(HEADER_BYTES)
    return [line.strip() for line in head.decode("latin-1").splitlines()]


def _ply_faces(path: Path) -> int | None:
    """The ``element face N`` of a PLY header (ASCII or binary alike)."""
    lines = _header_lines(path)
    if not lines or lines[0] != "ply":
        return None
    for line in lines[1:]:
        words = line.split()
        if words[:2] == ["element", "face"] and len(words) == 3:
            return int(words[2])
        if line == "end_header":
            break
    return None


def _off_faces(path: Path) -> int | None:
    """The face count of an OFF header: ``OFF`` then ``V F E`` (comments skipped; the
    counts may follow ``OFF`` on its line)."""
    words: list[str] = []
    for line in _header_lines(path):
        line = line.split("#", 1)[0]
        words += line.split()
        if words and not words[0].upper().endswith("OFF"):
            return None
        if len(words) >= 3:
            return int(words[2])
    return None


def _stl_faces(path: Path) -> int:
    """A binary STL's triangle count (uint32 at byte 80; at most the 50-byte records the
    file holds: a reader refuses a count the size does not match before allocating), or an
    ASCII one's ``endfacet`` count. A file that begins with ``solid`` is ASCII unless its
    size is exactly that of a binary file of the count it would hold."""
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(84)
    count = struct.unpack("<I", head[80:84])[0] if len(head) == 84 else 0
    if head[:5].lower() == b"solid" and size != 84 + 50 * count:
        return _count(path, (b"endfacet",), lower=True)
    return min(count, max(0, size - 84) // 50)


def _obj_faces(path: Path) -> int:
    """The face lines (``f ...``) of an OBJ file, streamed."""
    return _count(path, (b"\nf ", b"\nf\t"), first=b"\n")


def _count(path: Path, words: tuple[bytes, ...], first: bytes = b"",
           lower: bool = False) -> int:
    """Occurrences of the ``words`` in the bytes ``first`` + the file (lower-cased when
    ``lower``), read :data:`CHUNK` bytes at a time."""
    keep = max(map(len, words)) - 1  # bytes of one chunk a word may continue from
    n, tail = 0, first
    with path.open("rb") as f:
        while chunk := f.read(CHUNK):
            data = tail + (chunk.lower() if lower else chunk)
            n += sum(data.count(w) for w in words)
            tail = data[-keep:] if keep else b""
    return n


def _glb_faces(path: Path) -> int | None:
    """The triangles of a GLB's JSON chunk (the 12-byte header, then the chunk's length
    and type ``JSON``)."""
    with path.open("rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF" or head[16:20] != b"JSON":
            return None
        length = struct.unpack("<I", head[12:16])[0]
        if length > path.stat().st_size:
            return None
        return _gltf_triangles(json.loads(f.read(length)))


def _gltf_faces(path: Path) -> int:
    """The triangles of a glTF file (JSON)."""
    return _gltf_triangles(json.loads(path.read_bytes()))


def _gltf_triangles(doc: dict) -> int:
    """Triangles of a glTF document: per primitive, its index accessor's count (else its
    POSITION accessor's) / 3 (strips and fans: count - 2), times the nodes that show its
    mesh (at least one)."""
    accessors = doc.get("accessors", [])
    shown: dict[int, int] = {}
    for node in doc.get("nodes", []):
        if isinstance(node, dict) and isinstance(node.get("mesh"), int):
            shown[node["mesh"]] = shown.get(node["mesh"], 0) + 1
    total = 0
    for m, mesh in enumerate(doc.get("meshes", [])):
        for prim in mesh.get("primitives", []):
            mode = prim.get("mode", 4)
            if mode not in (4, 5, 6):  # points and lines hold no triangles
                continue
            ref = prim.get("indices", prim.get("attributes", {}).get("POSITION"))
            count = int(accessors[ref]["count"]) if isinstance(ref, int) else 0
            total += (count // 3 if mode == 4 else max(0, count - 2)) * max(1, shown.get(m, 0))
    return total
