"""Every search-and-rescue variant: builds, deterministic, closed and watertight, within the
triangle budget, centred, named, described by JSON-able parameters it is a pure function
of; the variants of a kind all differ."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from sdcomp.assets import sar
from sdcomp.assets.sar import KINDS, VARIANTS, build, build_from_params, describe_variant
from sdcomp.errors import UserError

from .sar_meshes import all_variants, build_cached, face_areas, variant_id

#: the product's budget per variant (atlas build time and size), not a reference bound: a
#: decked boat with four people aboard is about 7500 triangles (each person about 1000)
MAX_TRIANGLES = 10000
MAX_BUILD_S = 0.5


@pytest.fixture(params=all_variants(), ids=variant_id)
def kv(request):
    """(kind, variant) of every variant of every kind."""
    return request.param


def test_api_shape():
    assert KINDS == ("swimmer", "boat", "jetski", "life_saving_appliances", "buoy")
    assert set(VARIANTS) == set(KINDS)
    assert all(8 <= n <= 20 for n in VARIANTS.values())
    assert sar.variant_names("jetski") == tuple(f"jetski-{v:02d}" for v in range(8))
    assert sar.parse_name("buoy-07") == ("buoy", 7)
    for other in ("buoy-10", "buoy", "bluerov2", "boat-7", "swimmer-00x"):
        assert sar.parse_name(other) is None


def test_builds_closed_watertight_in_budget(kv):
    kind, v = kv
    mesh = build_cached(kind, v)
    assert mesh.name == f"{kind}-{v:02d}"
    assert mesh.closed
    assert 0 < len(mesh.faces) < MAX_TRIANGLES
    tm = mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    f = mesh.faces
    assert np.all((f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2]))
    assert face_areas(mesh).min() > 1e-12


def test_centred_with_waterline_inside(kv):
    mesh = build_cached(*kv)
    np.testing.assert_allclose(mesh.bounds.sum(axis=0), 0.0, atol=1e-6)
    assert mesh.bounds[0, 2] < mesh.waterline < mesh.bounds[1, 2]


def test_deterministic_and_fast(kv):
    kind, v = kv
    first = build_cached(kind, v)
    t0 = time.perf_counter()
    again = build(kind, v)
    assert time.perf_counter() - t0 < MAX_BUILD_S
    assert again.content_hash() == first.content_hash()


def test_params_json_and_pure(kv):
    kind, v = kv
    params = describe_variant(kind, v)
    assert params["kind"] == kind and isinstance(params["sub_type"], str)
    text = json.dumps(params, sort_keys=True)
    assert json.loads(text) == params  # plain JSON types only
    assert describe_variant(kind, v) == params
    rebuilt = build_from_params(json.loads(text), sar.mesh_name(kind, v))
    assert rebuilt.content_hash() == build_cached(kind, v).content_hash()


def test_same_across_processes():
    """A fresh interpreter builds bit-identical meshes (no hash() salt, no global state)."""
    probe = [(k, VARIANTS[k] - 1) for k in KINDS]
    code = ("import json; from sdcomp.assets.sar import build;"
            f"print(json.dumps([build(k, v).content_hash() for k, v in {probe!r}]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert json.loads(out) == [build_cached(k, v).content_hash() for k, v in probe]


@pytest.mark.parametrize("kind", KINDS)
def test_variants_differ(kind):
    meshes = [build_cached(kind, v) for v in range(VARIANTS[kind])]
    assert len({m.content_hash() for m in meshes}) == len(meshes)
    params = [json.dumps(describe_variant(kind, v), sort_keys=True)
              for v in range(VARIANTS[kind])]
    assert len(set(params)) == len(params)
    # not just tiny perturbations: sizes and colour sets vary across the kind
    ext = np.array([m.extents for m in meshes])
    assert (ext.max(axis=0) / ext.min(axis=0)).max() > 1.3
    palettes = {frozenset(map(tuple, np.unique(m.face_colors, axis=0))) for m in meshes}
    assert len(palettes) == len(meshes)


@pytest.mark.parametrize("kind", KINDS)
def test_every_sub_type_present(kind):
    subs = {describe_variant(kind, v)["sub_type"] for v in range(VARIANTS[kind])}
    assert subs == set(sar.sub_types(kind))


def test_bad_arguments():
    with pytest.raises(UserError, match="unknown object kind 'submarine'; use one of swimmer"):
        build("submarine", 0)
    for bad in (-1, VARIANTS["buoy"], 1.0, True):
        with pytest.raises(UserError, match="buoy variant .* does not exist; use 0 to 9"):
            describe_variant("buoy", bad)
