"""Input files a user hands over, good and bad, for the input tests (tests/test_user_inputs.py)
and fuzzers: photos of every kind (truncated, empty, garbage, a wrong extension, a header
claiming 100000 x 100000 pixels, 16-bit, grey, CMYK, EXIF-rotated), videos (truncated, cut
short, no frames) and COCO / YOLO label files, with the command lines that read them.
"""

from __future__ import annotations

import json
import struct
import tempfile
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import event
from hypothesis import strategies as st
from PIL import Image

from .datasets import cli, generate, one_line_error

W, H = 160, 120  # every good frame


def scene(seed: int = 0) -> np.ndarray:
    """(H, W, 3) uint8 BGR: greenish water with a little texture and one bright object."""
    rng = np.random.default_rng(seed)
    img = np.empty((H, W, 3), np.uint8)
    img[...] = (90, 110, 60)
    img = cv2.add(img, rng.integers(0, 20, (H, W, 3), dtype=np.uint8))
    cv2.rectangle(img, (20, 20), (40, 32), (230, 230, 230), -1)
    return img


def png_header(w: int, h: int, idat: bytes = b"") -> bytes:
    """A PNG file of one IHDR claiming ``w`` x ``h`` RGB pixels, ``idat`` and IEND."""
    def chunk(tag: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + tag + body
                + struct.pack(">I", zlib.crc32(tag + body)))
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", idat or zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


def jpeg_bytes(seed: int = 0) -> bytes:
    return cv2.imencode(".jpg", scene(seed))[1].tobytes()


def _exif(path: Path) -> None:
    im = Image.fromarray(scene()[..., ::-1])
    ex = Image.Exif()
    ex[0x0112] = 6  # shown turned 90 degrees clockwise: 120 wide, 160 high
    im.save(path, exif=ex.tobytes())


#: photos that are fine, each a file name and how to write it: the commands read them
ODD_PHOTOS: dict[str, Callable[[Path], None]] = {
    "png16.png": lambda p: cv2.imwrite(str(p), scene().astype(np.uint16) * 257),
    "grey.png": lambda p: cv2.imwrite(str(p), scene()[..., 1]),
    "cmyk.jpg": lambda p: Image.fromarray(scene()[..., ::-1]).convert("CMYK").save(p),
    "exif.jpg": _exif,
    "pngnamedjpg.jpg": lambda p: p.write_bytes(cv2.imencode(".png", scene())[1].tobytes()),
}

#: photos no command can use: each must stop it with one line naming the file
BAD_PHOTOS: dict[str, Callable[[Path], None]] = {
    "truncated.jpg": lambda p: p.write_bytes(jpeg_bytes()[: len(jpeg_bytes()) // 2]),
    "truncated.png": lambda p: p.write_bytes(
        cv2.imencode(".png", scene())[1].tobytes()[:3000]),
    "empty.jpg": lambda p: p.write_bytes(b""),
    "garbage.jpg": lambda p: p.write_bytes(np.random.default_rng(3).bytes(3000)),
    "bomb.png": lambda p: p.write_bytes(png_header(100_000, 100_000)),
}


def write_video(path: Path, n: int, fourcc: str = "mp4v") -> None:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), 10, (W, H))
    for k in range(n):
        w.write(scene(k))
    w.release()


def _cut(path: Path, n: int, fourcc: str) -> None:
    write_video(path, n, fourcc)
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])


#: videos no command can use
BAD_VIDEOS: dict[str, Callable[[Path], None]] = {
    "noframes.mp4": lambda p: write_video(p, 0),
    "truncated.mp4": lambda p: _cut(p, 30, "mp4v"),  # its index (moov) is lost
    "cutshort.avi": lambda p: _cut(p, 30, "MJPG"),  # opens, claims 30 frames, has ~10
}


def frames_folder(root: Path, extra: dict[str, Callable[[Path], None]] | None = None,
                  n: int = 3) -> Path:
    """A folder of ``n`` good JPEG frames ``ok<k>.jpg`` and the ``extra`` files."""
    d = root / "frames"
    d.mkdir(parents=True)
    for k in range(n):
        (d / f"ok{k}.jpg").write_bytes(jpeg_bytes(k))
    for name, write in (extra or {}).items():
        write(d / name)
    return d


def coco_labels(frames: Path, path: Path, mutate: Callable[[dict], None] | None = None
                ) -> Path:
    """A COCO file labelling every photo of ``frames`` (one box each; video frames by key),
    changed by ``mutate``, written to ``path``."""
    images, anns = [], []
    for p in sorted(frames.iterdir()):
        names = ([p.name] if p.suffix.lower() in (".jpg", ".png")
                 else [f"{p.stem}_{k:06d}.jpg" for k in range(3)])
        for name in names:
            images.append({"id": len(images) + 1, "file_name": name, "width": W, "height": H})
            anns.append({"id": len(anns) + 1, "image_id": len(images), "category_id": 1,
                         "bbox": [20, 20, 21, 13], "area": 273, "iscrowd": 0})
    coco = {"images": images, "annotations": anns,
            "categories": [{"id": 1, "name": "bluerov2"}]}
    if mutate is not None:
        mutate(coco)
    path.write_text(json.dumps(coco))
    return path


def _set(key: str, value) -> Callable[[dict], None]:
    def change(c: dict) -> None:
        c["annotations"][0][key] = value
    return change


def _drop(key: str) -> Callable[[dict], None]:
    return lambda c: c["annotations"][0].pop(key)


#: label files a command must refuse, naming the file: (what is wrong, how to make it)
BAD_COCO: dict[str, Callable[[dict], None]] = {
    "no image_id": _drop("image_id"),
    "no category_id": _drop("category_id"),
    "no bbox": _drop("bbox"),
    "dangling image_id": _set("image_id", 999),
    "unknown category": _set("category_id", 7),
    "negative width": _set("bbox", [20, 20, -5, 10]),
    "text bbox": _set("bbox", ["a", 1, 2, 3]),
    "image without id": lambda c: c["images"][0].pop("id"),
    "image without file_name": lambda c: c["images"][0].pop("file_name"),
    "repeated image id": lambda c: c["images"][1].update(id=c["images"][0]["id"]),
    "categories not a list": lambda c: c.update(categories={"1": "boat"}),
    "not a list of images": lambda c: c.update(images={"a": 1}),
}

#: label files that are fine: boxes partly or wholly outside the frame, file names with
#: folders that climb out or are absolute (frames are matched by the name's stem only)
ODD_COCO: dict[str, Callable[[dict], None]] = {
    "box partly outside": _set("bbox", [150, 110, 40, 40]),
    "box wholly outside": _set("bbox", [500, 500, 10, 10]),
    "name climbs out": lambda c: c["images"][0].update(file_name="../../../etc/ok0.jpg"),
    "absolute name": lambda c: c["images"][1].update(file_name="/nowhere/at/all/ok1.jpg"),
    "float ids": lambda c: c["annotations"][0].update(image_id=1.0),
}


def yolo_labels(frames: Path, root: Path, line: str = "0 0.2 0.2 0.1 0.1") -> Path:
    """A YOLO labels folder: ``line`` for the first good frame, one box for the others."""
    d = root / "yolo"
    d.mkdir()
    for k, p in enumerate(sorted(q for q in frames.iterdir() if q.stem.startswith("ok"))):
        (d / f"{p.stem}.txt").write_text((line if k == 0 else "0 0.3 0.3 0.1 0.1") + "\n")
    return d


BAD_YOLO = {"negative width": "0 0.5 0.5 -0.1 0.1", "three numbers": "0 0.5 0.5 0.1",
            "a word": "boat 0.5 0.5 0.1 0.1", "not finite": "0 nan 0.5 0.1 0.1"}
ODD_YOLO = {"outside": "0 1.4 1.3 0.2 0.2", "polygon": "0 0.1 0.1 0.3 0.1 0.2 0.3"}


@pytest.fixture(scope="module")
def generated(tmp_path_factory, sprites_dir) -> Path:
    """A small generated dataset: what ``realism`` compares and ``bench sim2real`` trains on."""
    out = tmp_path_factory.mktemp("inputs") / "generated"
    rc, _, err = generate(["--n", "6", "--size", "96", "--seed", "1", "--altitude", "5-8"],
                          out, sprites_dir)
    assert rc == 0, err
    return out


@pytest.fixture(scope="module")
def command(generated, sprites_dir) -> dict[str, Callable]:
    """:func:`commands` of the :func:`generated` dataset."""
    return commands(generated, sprites_dir)


def run(command: dict, name: str, frames: Path, labels: Path, out: Path) -> tuple[int, str]:
    """Run command ``name`` of :func:`commands` in this process: (exit status, stderr)."""
    entry, argv, _ = command[name](frames, labels, out)
    rc, _, err = cli(argv, entry)
    return rc, err


def assert_refused(rc: int, err: str, out: Path, *names: str) -> None:
    """Exit status 2, one line naming each of ``names``, nothing written under ``out``."""
    assert rc == 2, err
    one_line_error(err)
    for n in names:
        assert n in err, (n, err)
    assert not out.exists() or not any(out.rglob("*")), sorted(out.rglob("*"))


def commands(generated: Path, sprites: Path) -> dict[str, Callable]:
    """Each command that reads the user's frames, as (frames, labels, out) -> (entry, argv,
    the folder it writes)."""
    from sdcomp.bench.cli import main as bench
    from sdcomp.cli.fit import main as fit
    from sdcomp.cli.generate import main as generate
    from sdcomp.cli.realism import main as realism

    def realism_cmd(frames, labels, out):
        return realism, [generated, "--real", frames, "--real-labels", labels, "--out", out,
                         "--no-cnn", "-q"], out

    def fit_cmd(frames, labels, out):
        return fit, [frames, "--labels", labels, "--out", out / "fitted.toml", "--renders",
                     2, "--passes", 1, "--size", 160, "--sprites", sprites, "-q"], out

    def backgrounds_cmd(frames, labels, out):
        return generate, ["--n", 3, "--size", 48, "--clutter", 0, "--backgrounds", frames,
                          "--background-labels", labels, "--out", out, "--sprites",
                          sprites, "--workers", 1, "--no-progress"], out

    def sim2real_cmd(frames, labels, out):
        return bench, ["sim2real", "--train", generated, "--real", frames, "--real-labels",
                       labels, "--out", out, "--backbone", "mobilenet_v3-fpn", "--weights",
                       "none", "--max-iter", 1, "--batch-size", 1, "--no-progress"], out

    return {"realism": realism_cmd, "fit": fit_cmd, "backgrounds": backgrounds_cmd,
            "sim2real": sim2real_cmd}


# --------------------------------------------------------------------------- fuzzing

def photo_files():
    """A hypothesis strategy of (file name, bytes): a good photo of any kind (JPEG, PNG,
    16-bit, grey, CMYK, EXIF-rotated) then cut short, with bytes flipped, junk around it or
    replaced by random bytes, under any image extension."""

    def good(kind: str) -> bytes:
        if kind in ("jpg", "png"):
            return cv2.imencode(f".{kind}", scene())[1].tobytes()
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / kind
            ODD_PHOTOS[kind](p)
            return p.read_bytes()

    def damage(data: bytes, how: str, at: float, junk: bytes) -> bytes:
        k = int(at * len(data))
        if how == "cut":
            return data[:k]
        if how == "flip":
            return data[:k] + bytes([data[k] ^ 0xFF]) + data[k + 1:] if k < len(data) else data
        if how == "prepend":
            return junk + data
        if how == "append":
            return data + junk
        if how == "random":
            return junk
        return data

    kinds = st.sampled_from(["jpg", "png", *ODD_PHOTOS])
    hows = st.sampled_from(["none", "cut", "flip", "prepend", "append", "random"])
    exts = st.sampled_from([".jpg", ".jpeg", ".png", ".bmp", ".tif", ".webp", ".JPG"])
    return st.builds(lambda kind, how, at, junk, ext: (f"fuzz{ext}", damage(good(kind), how,
                                                                            at, junk)),
                     kinds, hows, st.floats(0, 1), st.binary(max_size=64), exts)


#: values a fuzzed label field takes
def label_values():
    return st.one_of(
        st.none(), st.booleans(), st.integers(-3, 1000), st.sampled_from([2**63, -2**31]),
        st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
        st.sampled_from(["../../etc/passwd", "/abs/ok0.jpg", "ok1.png", "a\\b\\ok2.jpg", ""]),
        st.lists(st.one_of(st.integers(-50, 500), st.floats(-1e3, 1e308)), max_size=6))


def coco_edits():
    """A strategy of functions that change a COCO dict: fields of its records set to any
    value or deleted, records repeated or dropped, sections replaced."""
    keys = ["id", "image_id", "category_id", "bbox", "file_name", "width", "height", "name",
            "area", "iscrowd", "meta"]
    edit = st.tuples(st.sampled_from(["images", "annotations", "categories"]),
                     st.integers(0, 5), st.sampled_from(["set", "del", "dup", "drop", "whole"]),
                     st.sampled_from(keys), label_values())

    def apply(edits: list) -> Callable[[dict], None]:
        def change(coco: dict) -> None:
            for section, i, how, key, value in edits:
                recs = coco.get(section)
                if how == "whole" or not isinstance(recs, list) or not recs:
                    coco[section] = value if how == "whole" else recs
                    continue
                rec = recs[i % len(recs)]
                if how == "dup":
                    recs.append(dict(rec) if isinstance(rec, dict) else rec)
                elif how == "drop":
                    recs.remove(rec)
                elif isinstance(rec, dict) and how == "set":
                    rec[key] = value
                elif isinstance(rec, dict):
                    rec.pop(key, None)
        return change
    return st.lists(edit, min_size=1, max_size=4).map(apply)


def yolo_lines():
    """A strategy of YOLO label lines: well formed, odd (outside, polygons) or garbage."""
    num = st.one_of(st.floats(-2, 3), st.sampled_from(["nan", "inf", "-0", "1e400", "x"]))
    made = st.lists(num, min_size=0, max_size=8).map(lambda v: " ".join(map(str, v)))
    return st.one_of(st.sampled_from([*BAD_YOLO.values(), *ODD_YOLO.values()]),
                     st.tuples(st.integers(-2, 5), made).map(lambda t: f"{t[0]} {t[1]}"),
                     st.text(max_size=30).map(lambda t: t.replace("\r", "")))


def check_frames(frames: Path, name: str) -> str:
    """Read every frame of ``frames`` as the commands do (:func:`list_sources`, then each
    one's pixels): "ok" when all decode to the listed size as 8-bit RGB, "refused" when a
    UserError names ``name``; anything else fails."""
    from sdcomp.errors import UserError
    from sdcomp.render.footage import VideoReader, list_sources, read_source
    try:
        sources = list_sources(frames, "--real")
        for s in sources:
            rgb = read_source(s, VideoReader(), "--real")
            assert rgb.dtype == np.uint8 and rgb.shape == (s.height, s.width, 3), s
    except UserError as e:
        assert name in str(e) and "\n" not in str(e), str(e)
        return "refused"
    return "ok"


def check_labels(frames: Path, labels: Path) -> str:
    """Read ``labels`` of ``frames`` as ``realism``/``fit`` (:func:`load_real`) and ``bench
    sim2real`` (:func:`real_frames`) do: "ok" with finite boxes of sizes >= 0 inside
    the frames for sim2real, "refused" when a one-line UserError names the labels, "no
    match" when they name none of the frames; anything else fails."""
    from sdcomp.bench.realdata import real_frames
    from sdcomp.errors import UserError
    from sdcomp.report.realism.sources import load_real
    try:
        real = real_frames(frames, labels)
        fs = load_real(frames, labels)
    except UserError as e:
        msg = str(e)
        assert labels.name in msg and "\n" not in msg, msg
        return "no match" if "none of" in msg else "refused"
    for a in real.coco["annotations"]:
        x, y, w, h = a["bbox"]
        assert np.isfinite([x, y, w, h]).all() and w > 0 and h > 0, a
        im = real.coco["images"][a["image_id"] - 1]
        assert x >= 0 and y >= 0 and x + w <= im["width"] and y + h <= im["height"], a
    for f in fs.frames:
        b = np.asarray(f.boxes if f.boxes is not None else [], np.float64).reshape(-1, 4)
        assert np.isfinite(b).all() and (b[:, 2:] >= 0).all(), f.boxes
    return "ok"


NL = "\n"


def check_user_files(file: tuple[str, bytes], edit: Callable, lines: list[str]) -> None:
    """A fuzzed photo ``file`` among good frames (:func:`check_frames`), then COCO labels
    changed by ``edit`` and YOLO ``lines`` of the good frames (:func:`check_labels`)."""
    with tempfile.TemporaryDirectory() as d:
        frames = frames_folder(Path(d))
        (frames / file[0]).write_bytes(file[1])
        event(f"photo {check_frames(frames, file[0])}")
        (frames / file[0]).unlink()
        event(f"coco {check_labels(frames, coco_labels(frames, Path(d) / 'l.json', edit))}")
        event(f"yolo {check_labels(frames, yolo_labels(frames, Path(d), NL.join(lines)))}")


def check_command(command: dict, cmd: str, file: tuple[str, bytes], edit: Callable) -> None:
    """Command ``cmd`` of :func:`commands` on good frames with the fuzzed photo ``file`` and
    COCO labels changed by ``edit``: it works (exit 0) or is refused (:func:`assert_refused`:
    one line, nothing written)."""
    with tempfile.TemporaryDirectory() as d:
        frames = frames_folder(Path(d))
        (frames / file[0]).write_bytes(file[1])
        out = Path(d) / "out"
        rc, err = run(command, cmd, frames, coco_labels(frames, Path(d) / "l.json", edit), out)
        event(f"{cmd} exit {rc}")
        if rc != 0:
            assert_refused(rc, err, out)
