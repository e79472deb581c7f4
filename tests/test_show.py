"""Tests of the dataset contact sheet (sdcomp.show) on a tiny hand-made dataset."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli.show import main
from sdcomp.errors import UserError, run_cli
from sdcomp.io.layout import load_dataset
from sdcomp.io.png import encode_png16
from sdcomp.report.sheet import (
    PAD,
    PALETTE,
    band_height,
    caption,
    category_colour,
    contact_sheet,
    render_cell,
    select_indices,
)

from .datasets import generate

ROOT = Path(__file__).resolve().parents[1]
W, H = 64, 48
FILL_BGR = (90, 60, 30)  # image background: far from every palette colour
META = {"height_above_takeoff(meter)": 23.1, "gimbal_pitch(degrees)": 90.0,
        "water_color": "brown", "turbidity": 0.4, "gsd(m/px)": 0.01}
# per image: split and instances (category_id, mask of the instance as (x, y, w, h) rects);
# image 0 one rectangle, 1 two (categories swapped against instance ids), 2 empty,
# 3 (val) one rectangle, 4 an L shape (a rectangle less its lower right quarter)
IMAGES = [
    ("train", [(1, [(10, 8, 20, 12)])]),
    ("train", [(2, [(4, 4, 10, 10)]), (1, [(36, 20, 20, 16)])]),
    ("train", []),
    ("val", [(2, [(20, 10, 30, 20)])]),
    ("train", [(1, [(30, 10, 24, 12), (30, 22, 12, 12)])]),
]


def make_dataset(root: Path, images=IMAGES, size=(W, H), ext=".png") -> Path:
    """The generator's layout: images/, masks/, annotations/instances_{train,val}.json."""
    w, h = size
    for sub in ("images", "masks", "annotations"):
        (root / sub).mkdir(parents=True)
    coco = {s: {"info": {}, "licenses": [], "categories": [
        {"id": 1, "name": "bluerov2"}, {"id": 2, "name": "boat"}],
        "images": [], "annotations": []} for s in ("train", "val")}
    for i, (split, instances) in enumerate(images):
        img = np.empty((h, w, 3), np.uint8)
        img[:] = FILL_BGR
        mask = np.zeros((h, w), np.uint16)
        anns = []
        for k, (cat, rects) in enumerate(instances, start=1):
            for x, y, rw, rh in rects:
                mask[y:y + rh, x:x + rw] = k
                img[y:y + rh, x:x + rw] = (40 + 30 * k, 120, 150)
            ys, xs = np.nonzero(mask == k)
            x0, y0 = int(xs.min()), int(ys.min())
            anns.append({"id": (i + 1) * 1000 + k, "image_id": i + 1, "category_id": cat,
                         "bbox": [x0, y0, int(xs.max()) - x0 + 1, int(ys.max()) - y0 + 1],
                         "area": int((mask == k).sum()),
                         "segmentation": {"size": [h, w], "counts": "x"}, "iscrowd": 0,
                         "instance_id": k})
        name = f"{i:06d}"
        assert cv2.imwrite(str(root / "images" / f"{name}{ext}"), img)
        (root / "masks" / f"{name}.png").write_bytes(encode_png16(mask))
        coco[split]["images"].append({"id": i + 1, "file_name": f"{name}{ext}", "width": w,
                                      "height": h, "mask_file": f"{name}.png",
                                      "meta": dict(META)})
        coco[split]["annotations"] += anns
    for split, c in coco.items():
        (root / "annotations" / f"instances_{split}.json").write_text(json.dumps(c))
    (root / "dataset.json").write_text(json.dumps({"config": {}, "counts": {}}))
    return root


@pytest.fixture
def ds(tmp_path: Path) -> Path:
    return make_dataset(tmp_path / "ds")


def cell_of(sheet: np.ndarray, k: int, cell: int, columns: int) -> np.ndarray:
    r, c = divmod(k, columns)
    return sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]


def colour_pixels(tile: np.ndarray, category_id: int) -> np.ndarray:
    """(N, 2) x, y of the pixels drawn in the category's colour."""
    ys, xs = np.nonzero((tile == category_colour(category_id)).all(axis=2))
    return np.stack([xs, ys], axis=1)


def geometry(cell: int, size=(W, H)) -> tuple[float, float, int, int]:
    """(sx, sy, ox, oy) of an image letterboxed into a cell, as show.py places it."""
    w, h = size
    s = min((cell - 2 * PAD) / w, (cell - 2 * PAD) / h)
    dw, dh = round(w * s), round(h * s)
    return dw / w, dh / h, (cell - dw) // 2, (cell - dh) // 2


def to_cell(rect, g) -> tuple[float, float, float, float]:
    """An image rectangle (x, y, w, h) as cell coordinates x0, y0, x1, y1 (pixel edges)."""
    sx, sy, ox, oy = g
    x, y, w, h = rect
    return ox + x * sx, oy + y * sy, ox + (x + w) * sx, oy + (y + h) * sy


def near_border(pts: np.ndarray, box, tol: float) -> np.ndarray:
    """Whether each point lies within ``tol`` of the border of ``box`` (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = box
    x, y = pts[:, 0] + 0.5, pts[:, 1] + 0.5
    inside_outer = (x > x0 - tol) & (x < x1 + tol) & (y > y0 - tol) & (y < y1 + tol)
    inside_inner = (x > x0 + tol) & (x < x1 - tol) & (y > y0 + tol) & (y < y1 - tol)
    return inside_outer & ~inside_inner


def entries(folder: Path, split="all"):
    return load_dataset(folder, split).entries


# --------------------------------------------------------------------------- layout, selection

@pytest.mark.parametrize("n, columns, cell, shape", [
    (4, 3, 64, (128, 192)),   # 4 cells in rows of 3
    (24, 6, 40, (40, 200)),   # only 5 images: one row of 5
    (5, 2, 32, (96, 64)),     # 3 rows of 2
    (1, 6, 50, (50, 50)),
])
def test_sheet_shape_follows_n_columns_cell(ds, n, columns, cell, shape):
    sheet = contact_sheet(ds, n=n, columns=columns, cell=cell)
    assert sheet.shape == (*shape, 3) and sheet.dtype == np.uint8


def test_select_indices():
    assert select_indices(10, 4) == [0, 3, 6, 9]
    assert select_indices(5, 2) == [0, 4]
    assert select_indices(7, 1) == [0]
    assert select_indices(3, 24) == [0, 1, 2]
    assert select_indices(10, 3, "first") == [0, 1, 2]
    for count in range(2, 40):
        for n in range(2, count + 1):
            picks = select_indices(count, n)
            assert picks[0] == 0 and picks[-1] == count - 1
            assert len(set(picks)) == n and picks == sorted(picks)
    r = select_indices(100, 10, "random", seed=3)
    assert r == select_indices(100, 10, "random", seed=3) != select_indices(100, 10, "random", 4)
    assert len(set(r)) == 10 and r == sorted(r) and all(0 <= i < 100 for i in r)


def test_spread_shows_first_and_last_image(ds):
    cell = 64
    es = entries(ds)
    sheet = contact_sheet(ds, n=2, select="spread", columns=2, cell=cell)
    assert np.array_equal(cell_of(sheet, 0, cell, 2), render_cell(ds, es[0], cell))
    assert np.array_equal(cell_of(sheet, 1, cell, 2), render_cell(ds, es[-1], cell))
    first = contact_sheet(ds, n=2, select="first", columns=2, cell=cell)
    assert np.array_equal(cell_of(first, 1, cell, 2), render_cell(ds, es[1], cell))


def test_images_sorted_by_id_across_splits(ds):
    assert [e.id for e in entries(ds)] == [1, 2, 3, 4, 5]
    assert [e.split for e in entries(ds)] == ["train", "train", "train", "val", "train"]


def test_split_filtering(ds):
    assert [e.id for e in entries(ds, "train")] == [1, 2, 3, 5]
    assert [e.id for e in entries(ds, "val")] == [4]
    cell = 48
    val = contact_sheet(ds, split="val", cell=cell)
    assert val.shape == (cell, cell, 3)
    assert np.array_equal(val, render_cell(ds, entries(ds)[3], cell))
    train = contact_sheet(ds, split="train", cell=cell, columns=6)
    assert train.shape == (cell, 4 * cell, 3)
    assert np.array_equal(cell_of(train, 3, cell, 6), render_cell(ds, entries(ds)[4], cell))


def test_only_one_coco_file_present(ds):
    (ds / "annotations" / "instances_val.json").unlink()
    assert [e.id for e in entries(ds)] == [1, 2, 3, 5]


# --------------------------------------------------------------------------- drawing

@pytest.mark.parametrize("cell", [256, 64])
def test_outline_and_box_drawn_around_the_instance(ds, cell):
    tile = contact_sheet(ds, n=1, select="first", cell=cell, labels=False)
    g = geometry(cell)
    box = to_cell((10, 8, 20, 12), g)
    pts = colour_pixels(tile, 1)
    assert len(pts) > 0
    tol = max(g[0], 1.0) + 1  # half a source pixel (the contour runs through pixel centres)
    assert near_border(pts, box, tol).all(), "category colour far from the instance border"
    # the outline runs along all four sides
    x0, y0, x1, y1 = box
    for side in (np.abs(pts[:, 0] + 0.5 - x0) < tol, np.abs(pts[:, 0] + 0.5 - x1) < tol):
        ys = pts[side, 1]
        assert ys.min() <= y0 + tol and ys.max() >= y1 - tol - 1
    for side in (np.abs(pts[:, 1] + 0.5 - y0) < tol, np.abs(pts[:, 1] + 0.5 - y1) < tol):
        xs = pts[side, 0]
        assert xs.min() <= x0 + tol and xs.max() >= x1 - tol - 1
    # no other category's colour, and the image inside the outline is untouched
    assert len(colour_pixels(tile, 2)) == 0
    inner = tile[int(y0 + tol + 1):int(y1 - tol - 1), int(x0 + tol + 1):int(x1 - tol - 1)]
    assert inner.size and (inner == inner[0, 0]).all()


def test_outline_follows_the_mask_not_only_the_box(ds):
    """An L-shaped instance: its outline runs along the notch, where its box does not."""
    cell = 256
    tile = render_cell(ds, entries(ds)[4], cell, labels=False)
    g = geometry(cell)
    sx, sy, ox, oy = g
    pts = colour_pixels(tile, 1)
    bx0, by0, bx1, by1 = to_cell((30, 10, 24, 24), g)
    tol = sx + 1
    # every coloured pixel is on the box border or on the notch's two edges (x = 42, y = 22)
    on_box = near_border(pts, (bx0, by0, bx1, by1), tol)
    nx, ny = ox + 42 * sx, oy + 22 * sy
    x, y = pts[:, 0] + 0.5, pts[:, 1] + 0.5
    on_notch = (((np.abs(x - nx) < tol) & (y > ny - tol) & (y < by1 + tol))
                | ((np.abs(y - ny) < tol) & (x > nx - tol) & (x < bx1 + tol)))
    assert (on_box | on_notch).all()
    # and the notch edges are drawn (inside the box, away from its border)
    notch_only = on_notch & ~on_box
    assert (np.abs(x[notch_only] - nx) < tol).sum() > 5 * sy
    assert (np.abs(y[notch_only] - ny) < tol).sum() > 5 * sx


def test_box_drawn_from_the_annotation(ds):
    """A box that disagrees with the mask is drawn where the annotation says: a thin
    rectangle on the bbox's pixel edges; without instance_id there is no outline."""
    path = ds / "annotations" / "instances_train.json"
    coco = json.loads(path.read_text())
    ann = coco["annotations"][0]
    assert ann["image_id"] == 1
    ann["bbox"] = [4, 5, 40, 30]
    del ann["instance_id"]
    path.write_text(json.dumps(coco))
    cell = 256
    tile = render_cell(ds, entries(ds)[0], cell, labels=False)
    sx, sy, ox, oy = geometry(cell)
    x0, y0 = ox + round(4 * sx), oy + round(5 * sy)
    x1, y1 = ox + round(44 * sx) - 1, oy + round(35 * sy) - 1
    drawn = (tile == category_colour(1)).all(axis=2)
    expected = np.zeros_like(drawn)
    expected[y0:y1 + 1, [x0, x1]] = True
    expected[[y0, y1], x0:x1 + 1] = True
    assert np.array_equal(drawn, expected)


def test_colour_per_category_not_per_instance(ds):
    cell = 256
    tile = render_cell(ds, entries(ds)[1], cell, labels=False)
    g = geometry(cell)
    tol = g[0] + 1
    # instance 1 is category 2, instance 2 is category 1
    assert near_border(colour_pixels(tile, 2), to_cell((4, 4, 10, 10), g), tol).all()
    assert near_border(colour_pixels(tile, 1), to_cell((36, 20, 20, 16), g), tol).all()
    assert len(colour_pixels(tile, 1)) > 0 and len(colour_pixels(tile, 2)) > 0
    assert category_colour(1) != category_colour(2)
    assert len({c for _, c in PALETTE}) == len(PALETTE)


def test_empty_image_gets_no_outlines(ds):
    tile = render_cell(ds, entries(ds)[2], 128, labels=False)
    for _, colour in PALETTE:
        assert not (tile == colour).all(axis=2).any()
    g = geometry(128)
    x0, y0, x1, y1 = (int(v) for v in to_cell((0, 0, W, H), g))
    img = tile[y0 + 1:y1 - 1, x0 + 1:x1 - 1]
    assert (img == FILL_BGR[::-1]).all()  # just the (RGB) photo
    assert caption(entries(ds)[2]).endswith("n=0")


def test_empty_image_without_mask_file(ds):
    (ds / "masks" / "000002.png").unlink()  # not needed: nothing to outline
    tile = render_cell(ds, entries(ds)[2], 64)
    assert tile.shape == (64, 64, 3)


def test_large_image_decoded_reduced_is_placed_exactly(tmp_path):
    """A 512x384 jpg in a 64 px cell is decoded at 1/8 size; outlines still line up."""
    folder = make_dataset(tmp_path / "big", [("train", [(2, [(100, 80, 200, 120)])])],
                          size=(512, 384), ext=".jpg")
    cell = 64
    tile = contact_sheet(folder, cell=cell, labels=False)
    g = geometry(cell, (512, 384))
    pts = colour_pixels(tile, 2)
    assert len(pts) > 20
    assert near_border(pts, to_cell((100, 80, 200, 120), g), 1.5).all()


def test_caption(ds):
    es = entries(ds)
    assert caption(es[0]) == "000000 alt 23m pitch 90 brown t0.40 n=1"
    assert caption(es[1]) == "000001 alt 23m pitch 90 brown t0.40 n=2"
    es[0].image["meta"] = {}
    assert caption(es[0]) == "000000 n=1"


def test_no_labels_differs_only_in_caption_band(ds):
    cell, columns = 128, 3
    a = contact_sheet(ds, cell=cell, columns=columns)
    b = contact_sheet(ds, cell=cell, columns=columns, labels=False)
    assert a.shape == b.shape
    band = band_height(cell)
    rows = np.nonzero((a != b).any(axis=(1, 2)))[0]
    assert len(rows) > 0
    assert ((rows % cell) >= cell - band).all()
    # the band is darker than the picture it covers, in every shown cell
    for k in range(5):
        ca, cb = cell_of(a, k, cell, columns), cell_of(b, k, cell, columns)
        assert np.median(ca[-band:]) < 0.5 * np.median(cb[-band:])
        assert ca[-band:].max() > 200  # the (light) text
    # empty trailing cell (5 images in 2 rows of 3) untouched
    assert np.array_equal(cell_of(a, 5, cell, columns), cell_of(b, 5, cell, columns))


# --------------------------------------------------------------------------- command line

def test_cli_writes_png(ds, capsys):
    out = ds / "out" / "s.png"
    out.parent.mkdir()
    rc = run_cli(main, [str(ds), "--out", str(out), "--n", "3", "--columns", "2",
                        "--cell", "64"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert str(out) in captured.out and "3 of 5 images" in captured.out
    assert "bluerov2 red" in captured.out
    png = cv2.imread(str(out), cv2.IMREAD_UNCHANGED)
    assert png.shape == (128, 128, 3)
    expected = contact_sheet(ds, n=3, columns=2, cell=64)
    assert np.array_equal(cv2.cvtColor(png, cv2.COLOR_BGR2RGB), expected)
    assert [p.name for p in out.parent.iterdir()] == ["s.png"]  # no temporary left


def test_cli_default_out_and_options(ds, capsys):
    rc = run_cli(main, [str(ds), "--split", "val", "--cell", "32", "--select", "random",
                        "--seed", "5", "--no-labels"])
    assert rc == 0
    png = cv2.imread(str(ds / "sheet.png"))
    assert png.shape == (32, 32, 3)
    assert "1 of 1 images" in capsys.readouterr().out
    # a second run overwrites the sheet and does not pick it up as data
    assert run_cli(main, [str(ds), "--cell", "32"]) == 0
    assert cv2.imread(str(ds / "sheet.png")).shape == (32, 5 * 32, 3)


def test_module_runs_as_script(ds):
    out = ds / "m.png"
    proc = subprocess.run([sys.executable, "-m", "sdcomp.show", str(ds), "--out", str(out),
                           "--cell", "32"], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert cv2.imread(str(out)).shape == (32, 160, 3)
    bad = subprocess.run([sys.executable, "-m", "sdcomp.show", str(ds / "nope")], cwd=ROOT,
                         capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.startswith("error: ") and "Traceback" not in bad.stderr


def _break(ds: Path, how: str) -> list[str]:
    """Damage the dataset or build bad arguments; returns the extra argv."""
    if how == "no-annotations":
        for p in (ds / "annotations").iterdir():
            p.unlink()
        (ds / "annotations").rmdir()
    elif how == "no-coco":
        for p in (ds / "annotations").iterdir():
            p.unlink()
    elif how == "bad-json":
        (ds / "annotations" / "instances_val.json").write_text('{"images": [')
    elif how == "not-coco":
        (ds / "annotations" / "instances_train.json").write_text('[1, 2]')
    elif how == "missing-image":
        (ds / "images" / "000004.png").unlink()
    elif how == "missing-mask":
        (ds / "masks" / "000001.png").unlink()
    elif how == "val-missing":
        (ds / "annotations" / "instances_val.json").unlink()
        return ["--split", "val"]
    return []


@pytest.mark.parametrize("how, argv, words", [
    ("", ["--n", "0"], ["--n 0", "at least 1"]),
    ("", ["--columns", "0"], ["--columns 0", "at least 1"]),
    ("", ["--cell", "31"], ["--cell 31", "at least 32"]),
    ("", ["--split", "test"], ["--split 'test'", "train", "val", "all"]),
    ("", ["--select", "best"], ["--select 'best'", "spread"]),
    ("", ["--out", "{ds}/no/such/dir/s.png"], ["does not exist", "create it"]),
    ("", ["--out", "{ds}/images"], ["is a folder"]),
    ("", ["--out", "{ds}/s.jpg"], ["must end in .png"]),
    ("no-annotations", [], ["not a generated dataset", "annotations/"]),
    ("no-coco", [], ["not a generated dataset", "instances_train.json"]),
    ("bad-json", [], ["instances_val.json", "not valid JSON", "--resume"]),
    ("not-coco", [], ["instances_train.json", "not a COCO file"]),
    ("missing-image", [], ["000004.png", "missing", "--resume"]),
    ("missing-mask", [], ["000001.png", "missing", "--resume"]),
    ("val-missing", [], ["--split val", "instances_val.json", "does not exist"]),
])
def test_cli_errors(ds, capsys, how, argv, words):
    extra = _break(ds, how)
    argv = [a.replace("{ds}", str(ds)) for a in argv]
    before = sorted(p for p in ds.rglob("*"))
    rc = run_cli(main, [str(ds), *argv, *extra])
    captured = capsys.readouterr()
    assert rc == 2
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert sorted(p for p in ds.rglob("*")) == before  # nothing written


def test_cli_error_missing_folder(tmp_path, capsys):
    rc = run_cli(main, [str(tmp_path / "nope")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    assert "does not exist" in err and "nope" in err
    assert list(tmp_path.iterdir()) == []
    rc = run_cli(main, [str(tmp_path)])  # a folder, but no dataset
    assert rc == 2 and "not a generated dataset" in capsys.readouterr().err
    (tmp_path / "f").write_text("x")
    assert run_cli(main, [str(tmp_path / "f")]) == 2
    assert "not a dataset folder" in capsys.readouterr().err


def test_python_api_raises_user_errors(ds):
    with pytest.raises(UserError, match="--n"):
        contact_sheet(ds, n=0)
    with pytest.raises(UserError, match="--split"):
        contact_sheet(ds, split="test")
    with pytest.raises(UserError, match="000004.png"):
        (ds / "images" / "000004.png").unlink()
        contact_sheet(ds)


# --------------------------------------------------------------------------- no COCO files

ANN_KEYS = ("instance_id", "category_id", "bbox", "area", "segmentation", "iscrowd")


def test_folder_without_coco_files_is_read_from_its_journal(tmp_path, sprites_dir):
    """--format yolo writes no COCO files: the folder is read from its journal, with the
    same images, annotations, categories and contact sheet as the same run written with
    COCO files; with the journal gone, one line says how to rewrite it."""
    base = ["--n", "8", "--seed", "5", "--count", "1-3"]
    with_coco, yolo_only = tmp_path / "coco", tmp_path / "yolo"
    assert generate(base, with_coco, sprites_dir, "--format", "coco,yolo")[0] == 0
    assert generate(base, yolo_only, sprites_dir, "--format", "yolo")[0] == 0
    assert not (yolo_only / "annotations" / "instances_train.json").exists()
    for split in ("all", "train", "val"):
        a, b = load_dataset(with_coco, split), load_dataset(yolo_only, split)
        assert a.categories == b.categories == {1: "bluerov2"}
        assert [(e.split, e.image) for e in a.entries] == [(e.split, e.image) for e in b.entries]
        assert [[{k: x[k] for k in ANN_KEYS} for x in e.annotations] for e in a.entries] == [
            [{k: x[k] for k in ANN_KEYS} for x in e.annotations] for e in b.entries]
    assert sum(len(e.annotations) for e in load_dataset(yolo_only).entries) > 0
    assert np.array_equal(contact_sheet(with_coco, n=8), contact_sheet(yolo_only, n=8))
    (yolo_only / "records.jsonl").unlink()
    with pytest.raises(UserError, match="records.jsonl is missing") as err:
        load_dataset(yolo_only)
    assert "--resume" in str(err.value) and "\n" not in str(err.value)


def test_small_objects_are_zoomed_by_default(tmp_path, capsys):
    """Objects of a few pixels in a large image: the default sheet has a cell per object
    (and says why); --no-zoom draws whole images; large objects stay whole images."""
    small = make_dataset(tmp_path / "small", images=[
        ("train", [(1, [(100, 80, 4, 3)]), (1, [(300, 200, 5, 4)])]), ("val", [])],
        size=(640, 480))
    assert run_cli(main, [str(small), "--cell", "64", "--out", str(tmp_path / "a.png")]) == 0
    out = capsys.readouterr().out
    assert "objects are small" in out and "2 objects" in out
    assert run_cli(main, [str(small), "--cell", "64", "--no-zoom",
                          "--out", str(tmp_path / "b.png")]) == 0
    assert "2 of 2 images" in capsys.readouterr().out
    big = make_dataset(tmp_path / "big")  # objects 10-30 px in a 64 px image
    assert run_cli(main, [str(big), "--cell", "64", "--out", str(tmp_path / "c.png")]) == 0
    out = capsys.readouterr().out
    assert "objects are small" not in out and "5 of 5 images" in out
