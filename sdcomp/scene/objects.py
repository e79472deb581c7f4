"""What floats in a scene, by name: objects of interest (:class:`ObjectSpec`) and clutter
kinds, the asset keys (sprite names) each is drawn from, and the rules that keep the two
apart.

An object names a built-in mesh, a search-and-rescue kind (all its variants: ``swimmer`` is
``swimmer-00`` ... ``swimmer-19``), a single variant, or a mesh file; its asset keys are
those mesh names (or the file path). A clutter kind is a search-and-rescue kind (its
variants, as distractors: asset keys ``clutter:boat-03``) or one of the clutter-only
meshes, ``log`` and ``foam`` (``clutter:log``). A kind is never both in one run: the
default clutter list drops the kinds that are objects; a list given by the user that names
one is refused (:func:`resolve_clutter_kinds`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import manifold3d as m3
import numpy as np

from ..assets import clutter, library, sar
from ..errors import SettingError, UserError

CLUTTER_PREFIX = "clutter:"  # asset keys of clutter: "clutter:log", "clutter:boat-03"
#: clutter kinds drawn when none are given
DEFAULT_CLUTTER_KINDS = ("buoy", "log", "boat", "foam")
#: every clutter kind: the defaults, then the other search-and-rescue kinds
CLUTTER_KINDS = (*DEFAULT_CLUTTER_KINDS,
                 *(k for k in sar.KINDS if k not in DEFAULT_CLUTTER_KINDS))
#: kind: (chance of being under way, slowest and fastest speed through the water, m/s) of
#: the kinds that travel (boats under way or at rest, jet skis mostly riding, swimmers
#: swimming, the BlueROV2 driving on the surface); buoys, appliances, logs, foam and mesh
#: files drift at rest. Scaled by the config's ``under_way``.
UNDER_WAY = {"boat": (0.5, 2.0, 12.0), "jetski": (0.6, 3.0, 15.0),
             "swimmer": (0.8, 0.3, 1.0), "bluerov2": (0.3, 0.3, 1.5),
             "bluerov2-heavy": (0.3, 0.3, 1.5)}
#: COCO supercategories of the search-and-rescue kinds (SeaDronesSee's)
SUPERCATEGORIES = {"swimmer": "person", "boat": "boat", "jetski": "boat",
                   "life_saving_appliances": "object", "buoy": "object"}


def _positive(v: Any) -> bool:
    """Whether ``v`` (a number or its text) is a finite number above 0."""
    try:
        return 0.0 < float(v) < math.inf
    except ValueError:
        return False


@dataclass(frozen=True)
class ObjectSpec:
    """An object of interest: a built-in mesh or kind name (a kind stands for all its
    variants) or a mesh file, its COCO category, its ``weight``: how often it is drawn
    relative to the other objects (class proportions), and its ``frame``: the part of the
    image its centre is placed in, uniformly, as fractions of the width and height
    ``(u0, v0, u1, v1)`` (None: anywhere in the frame). Where a camera operator frames the
    objects they look for (swimmers near the centre) and the rest lie in the background
    (boats high in an oblique frame, far away), the frame sets how far objects are and so
    their pixel sizes. ``size``: the quantiles (at probabilities evenly spaced from 0 to 1)
    of its box size ``sqrt(w h)`` over the camera's focal length (``fx``: so the sizes keep
    their meaning when the frame is cropped or resized), or None; where given,
    each object draws a size from them and is placed, within its frame part, on the image
    row at which it shows about that size (as far as the view allows: a straight-down view
    has one scale). ``size_weight``: how often each interval between two neighbouring
    quantiles of ``size`` is drawn, relative to the others (None: evenly, as quantiles
    are): a size that few views can show is drawn again in those that cannot, so the
    sizes shown lean to those most views can; more weight on it gives it back its share
    (:func:`draw_size`)."""

    mesh: str = "bluerov2"
    category: str = ""
    weight: float = 1.0
    frame: tuple[float, float, float, float] | None = None
    size: tuple[float, ...] | None = None
    size_weight: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if self.frame is not None:
            object.__setattr__(self, "frame", _frame(self.frame))
        if self.size is not None:
            object.__setattr__(self, "size", _size(self.size))
        if self.size_weight is not None:
            object.__setattr__(self, "size_weight", _size_weight(self.size_weight,
                                                                 self.size))
        if not isinstance(self.mesh, str) or not self.mesh.strip() or "\0" in self.mesh:
            raise SettingError("object", "{name} needs a built-in mesh name (bluerov2, "
                                         "bluerov2-heavy, swimmer, boat, jetski, "
                                         "life_saving_appliances, buoy) or a mesh file path")
        w = self.weight
        if isinstance(w, bool) or not isinstance(w, (int, float, str)) or not _positive(w):
            raise SettingError("weight", f"{{name}} {w!r} must be a positive number (how "
                                         f"often this object is drawn relative to the others)")
        object.__setattr__(self, "weight", float(w))
        if not self.category:
            object.__setattr__(self, "category", Path(self.mesh).stem if Path(
                self.mesh).suffix else self.mesh)
        if not isinstance(self.category, str) or not self.category.strip():
            raise SettingError("category", f"{{name}} {self.category!r} must be a non-empty "
                                           f"name")


def _size(v: Any) -> tuple[float, ...]:
    """``v`` as box-size quantiles (box sizes over the focal length): at least two numbers,
    each above 0 and below 1, none smaller than the one before (SettingError otherwise)."""
    try:
        q = tuple(float(x) for x in v)
    except (TypeError, ValueError):
        q = ()
    if len(q) < 2 or not all(0.0 < x < 1.0 for x in q) or any(
            b < a for a, b in zip(q, q[1:], strict=False)):
        raise SettingError("size", f"{{name}} {v!r} must be at least two box sizes over "
                                   f"the focal length, each in (0, 1), in increasing order: "
                                   f"the quantiles (e.g. [0.005, 0.012, 0.03])")
    return q


def _size_weight(v: Any, size: tuple[float, ...] | None) -> tuple[float, ...]:
    """``v`` as weights of the intervals between the quantiles ``size``: one positive
    number per interval (SettingError otherwise, or where ``size`` is None)."""
    n = len(size) - 1 if size is not None else 0
    try:
        w = tuple(float(x) for x in v)
    except (TypeError, ValueError):
        w = ()
    if not n or len(w) != n or not all(0.0 < x < math.inf for x in w):
        many = f"{n} positive numbers" if n else "positive numbers (with size given)"
        raise SettingError("size_weight", f"{{name}} {v!r} must be {many}, one per interval "
                                          f"between neighbouring sizes (e.g. [2, 1] for "
                                          f"size [0.005, 0.012, 0.03])")
    return w


def draw_size(size: tuple[float, ...], weight: tuple[float, ...] | None, t: float) -> float:
    """The box size (over the focal length) that the uniform draw ``t`` in [0, 1) picks
    from the quantiles ``size`` (at evenly spaced probabilities, linear between them),
    each interval between two drawn with its ``weight`` (None: evenly, the quantiles'
    own distribution)."""
    q = np.asarray(size, np.float64)
    if weight is None:
        return float(np.interp(t, np.linspace(0.0, 1.0, len(q)), q))
    edges = np.concatenate([[0.0], np.cumsum(weight)]) / sum(weight)
    k = min(int(np.searchsorted(edges, t, "right")) - 1, len(weight) - 1)
    frac = (t - edges[k]) / max(edges[k + 1] - edges[k], 1e-12)
    return float(q[k] + (q[k + 1] - q[k]) * min(max(frac, 0.0), 1.0))


def _frame(v: Any) -> tuple[float, float, float, float]:
    """``v`` as a frame part ``(u0, v0, u1, v1)``: four numbers in [0, 1], u0 < u1 and
    v0 < v1 (SettingError otherwise)."""
    try:
        u0, v0, u1, v1 = (float(x) for x in v)
    except (TypeError, ValueError):
        u0 = v0 = u1 = v1 = math.nan
    if not (0.0 <= u0 < u1 <= 1.0 and 0.0 <= v0 < v1 <= 1.0):
        raise SettingError("frame", f"{{name}} {v!r} must be four fractions of the image "
                                    f"[u0, v0, u1, v1] with 0 <= u0 < u1 <= 1 and "
                                    f"0 <= v0 < v1 <= 1 (e.g. [0.3, 0.3, 0.8, 0.9])")
    return (u0, v0, u1, v1)


def object_spec(o: Any) -> ObjectSpec:
    """An :class:`ObjectSpec` from a spec, a mesh name or a {mesh, category, weight, frame,
    size, size_weight} table (UserError for another key, SettingError for a bad value)."""
    if isinstance(o, str):
        return ObjectSpec(o)
    if isinstance(o, dict):
        unknown = set(o) - {"mesh", "category", "weight", "frame", "size", "size_weight"}
        if unknown:
            raise UserError(f"objects: unknown key {sorted(map(str, unknown))[0]!r}; "
                            f"use mesh, category, weight, frame, size and size_weight")
        return ObjectSpec(**o)
    if not isinstance(o, ObjectSpec):
        raise SettingError("object", f"{{name}} {o!r} is not a mesh name or path")
    return o


def object_kind(mesh: str) -> str | None:
    """The search-and-rescue kind an object's ``mesh`` (a kind or a variant name) is of;
    None for the BlueROV2 and mesh files."""
    return library.kind_of(mesh) if library.is_builtin(mesh) else None


def object_assets(mesh: str) -> tuple[str, ...]:
    """Asset keys an object of ``mesh`` is drawn from, one per variant (one for a single
    mesh)."""
    return library.variants(mesh) if library.is_builtin(mesh) else (mesh,)


def clutter_assets(kind: str) -> tuple[str, ...]:
    """Asset keys of clutter ``kind``, one per variant."""
    return tuple(CLUTTER_PREFIX + name for name in library.variants(kind))


def clutter_mesh_name(asset: str) -> str:
    """The mesh (and atlas file) name of a clutter asset key: ``clutter-boat-03`` for a
    variant (its own, smaller atlas beside an object's ``boat-03``), ``log`` for a
    clutter-only mesh."""
    name = asset.removeprefix(CLUTTER_PREFIX)
    return "clutter-" + name if library.kind_of(name) else name


def low_enough(assets: tuple[str, ...], altitude: float) -> tuple[str, ...]:
    """The variants among ``assets`` (object or clutter keys of one kind) whose top stands
    at most half the camera's ``altitude`` (m) above the water (all of them if none does):
    a taller object, a sailboat's mast under a low drone, would be drawn at the scale of
    its middle, far too large (the renderer linearises the perspective at the object)."""
    low = tuple(a for a in assets if _top(a) <= 0.5 * altitude)
    return low or assets


#: metres: what lies deeper under the waterline than this hardly shows from the air (the
#: part of a body that counts towards its visible size): green coastal water
#: (``--preset seadronessee``'s) keeps half an object's image 0.2-0.5 m down, the mask's
#: rule, but the surface's refraction lifts what lies under it to 0.5-0.75 of its depth
#: and a dark body keeps little contrast under the sky's reflection, so the part that
#: widens a box ends about a decimetre down (measured at 1080p: boxes come out at 0.99-1.05
#: of the size they are placed for, swimmers 1.05, life-saving appliances 0.9)
VISIBLE_DEPTH = 0.1


def visible_hull(asset: str) -> np.ndarray:
    """(K, 3) float64: the corners of the convex hull of the part of the object drawn from
    ``asset`` above :data:`VISIBLE_DEPTH` under its waterline, metres in its body frame
    with z up from the waterline: what its box shows, seen from anywhere (a view's box is
    the extent of their projections). Kept once known."""
    return _sizes(asset.removeprefix(CLUTTER_PREFIX))[1]


def footprint_radius(asset: str) -> float:
    """Metres: the radius of the disc an object drawn from ``asset`` keeps to itself on the
    water (no other object's disc overlaps it: two bodies do not share the water): the
    mean of its footprint's half length and half beam (its whole mesh, over the sea's
    plane), so a swimmer keeps about half a metre, a 6 m boat two."""
    return _sizes(asset.removeprefix(CLUTTER_PREFIX))[0]


def keel_depth(asset: str) -> float:
    """Metres from the waterline down to the lowest point of the object drawn from
    ``asset`` (its whole mesh: how high it must be lifted to stand clear of the water)."""
    return _sizes(asset.removeprefix(CLUTTER_PREFIX))[2]


def measure_all(assets: Iterable[str]) -> None:
    """Work out the footprint, visible hull and top of every one of ``assets`` now (each
    builds its mesh once: 25-50 ms): call it before forking workers, which then inherit
    them instead of each building them in its first images."""
    for asset in assets:
        if asset.removeprefix(CLUTTER_PREFIX) != "foam":  # foam keeps no disc, no size
            footprint_radius(asset)


@functools.cache
def _sizes(name: str) -> tuple[float, np.ndarray, float]:
    """(radius metres, hull (K, 3), keel depth metres) of mesh ``name``
    (:func:`footprint_radius`, :func:`visible_hull`, :func:`keel_depth`)."""
    parsed = sar.parse_name(name)
    if parsed is None:  # a clutter-only mesh (a log, foam), a built-in or a file
        mesh = clutter.build(name) if name in clutter.KINDS else library.MeshSpec(name).load()
    else:  # one build for both: the variant's top is kept for low_enough too
        mesh = sar.build(*parsed)
        sar.top_above_water(*parsed, mesh=mesh)
    v = mesh.vertices
    half = (v[:, :2].max(axis=0) - v[:, :2].min(axis=0)) / 2.0
    cut = mesh.waterline - VISIBLE_DEPTH
    pts = np.concatenate([v[v[:, 2] >= cut], _crossings(v, mesh.faces, cut)])
    if len(pts) == 0:  # nothing that high: the whole of it
        pts = v
    pts = pts - np.array([0.0, 0.0, float(mesh.waterline)])
    # the hull's corners: all a projection's extent needs (a flat part has no hull: its
    # points themselves)
    hull = np.asarray(m3.Manifold.hull_points(pts).to_mesh().vert_properties,
                      np.float64)[:, :3]
    keel = float(mesh.waterline - v[:, 2].min())
    return float(half.mean()), hull if len(hull) else pts, keel


def _crossings(v: np.ndarray, faces: np.ndarray, z: float) -> np.ndarray:
    """(M, 3) the points where the edges of triangles ``faces`` (F, 3) of vertices ``v``
    (V, 3) cross the plane at height ``z``: with the vertices above it, the corners of the
    mesh cut there (a spar's column where it leaves the water)."""
    a = v[faces]  # (F, 3, 3)
    b = np.roll(a, -1, axis=1)  # each corner's next: the triangle's edges
    za, zb = a[..., 2] - z, b[..., 2] - z
    cross = (za < 0) != (zb < 0)
    t = za[cross] / (za[cross] - zb[cross])
    return a[cross] + (b[cross] - a[cross]) * t[:, None]


def _top(asset: str) -> float:
    name = asset.removeprefix(CLUTTER_PREFIX)
    parsed = sar.parse_name(name)
    if parsed is None:
        return 0.0
    if not sar.top_known(*parsed):  # built here once, for its visible size as well
        _sizes(name)
    return sar.top_above_water(*parsed)


def resolve_clutter_kinds(kinds: tuple[str, ...], object_meshes: list[str]
                          ) -> tuple[str, ...]:
    """``kinds`` checked and without repeats; the kinds of ``object_meshes`` are dropped
    from the default list and refused (SettingError) from any other."""
    for k in kinds:
        if k not in CLUTTER_KINDS:
            raise SettingError("clutter_kinds", f"{{name}} {k!r} is unknown; use some of "
                                                f"{', '.join(CLUTTER_KINDS)}")
    kinds = tuple(dict.fromkeys(kinds))
    taken = {object_kind(m) for m in object_meshes} - {None}
    if kinds == DEFAULT_CLUTTER_KINDS:
        return tuple(k for k in kinds if k not in taken)
    both = [k for k in kinds if k in taken]
    if both:
        rest = " ".join(k for k in kinds if k not in taken)
        fix = f"e.g. {{name}} {rest}" if rest else "or set --clutter 0"
        raise SettingError("clutter_kinds", f"{{name}} {both[0]} is also an --object, "
                                            f"annotated there: leave it out ({fix})")
    return kinds


def asset_kind(asset: str) -> str:
    """The kind of the object or clutter drawn from ``asset``: ``boat`` for ``boat-03`` and
    ``clutter:boat-03``, else the mesh name itself (``bluerov2``, ``log``, a file)."""
    name = asset.removeprefix(CLUTTER_PREFIX)
    return library.kind_of(name) or name


def coco_categories(objects) -> list[dict]:
    """COCO categories of ``objects`` (:class:`ObjectSpec` s): ids from 1 in their order,
    supercategories as SeaDronesSee's for its kinds, else "object"."""
    return [{"id": i + 1, "name": o.category,
             "supercategory": SUPERCATEGORIES.get(object_kind(o.mesh) or "", "object")}
            for i, o in enumerate(objects)]


def under_way(asset: str) -> tuple[float, float, float]:
    """(chance of being under way, slowest, fastest m/s) of the object or clutter drawn
    from ``asset`` (:data:`UNDER_WAY` by its kind; (0, 0, 0) for kinds that do not
    travel)."""
    name = asset.removeprefix(CLUTTER_PREFIX)
    kind = asset_kind(asset)
    if kind == "swimmer" and not _swimming(name):
        return (0.0, 0.0, 0.0)  # treading, waving, floating: drifting, not swimming
    return UNDER_WAY.get(kind, (0.0, 0.0, 0.0))


#: how much a body at rest stirs the water around it (0-1, by swimmer pose): a swimmer
#: treading water, waving or in distress kicks and sculls all the time, one floating on
#: the back hardly moves; the swimming poses travel instead (:func:`under_way`)
STIR = {"tread": 1.0, "wave": 1.0, "distress": 1.0, "back": 0.4}


def stirring(asset: str) -> float:
    """0-1: how much the object or clutter drawn from ``asset`` stirs the water around it
    at rest (:data:`STIR` by a swimmer variant's pose; 0 for everything else)."""
    if asset_kind(asset) != "swimmer":
        return 0.0
    return STIR.get(_pose_of(asset.removeprefix(CLUTTER_PREFIX)), 0.0)


@functools.cache
def _pose_of(name: str) -> str:
    """The pose (sub-type) of swimmer variant ``name``; "" for a name that is not a
    variant's."""
    parsed = sar.parse_name(name)
    return sar.describe_variant(*parsed)["sub_type"] if parsed is not None else ""


@functools.cache
def _swimming(name: str) -> bool:
    """Whether the swimmer variant ``name`` (e.g. ``swimmer-02``) swims (a pose of
    :data:`sar.swimmer.SWIMMING`); True for a name that is not a variant's."""
    pose = _pose_of(name)
    return not pose or pose in sar.swimmer.SWIMMING
