"""Backgrounds from the user's footage: video files, frames drawn per image from (seed, i),
labelled real objects kept out of every image, and the label readers (COCO, YOLO)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.errors import UserError
from sdcomp.render import photos
from sdcomp.render.footage import VideoReader, list_sources
from sdcomp.render.footage_labels import read_labels, yolo_names
from sdcomp.render.photos import Backgrounds

from .datasets import cli, generate

FRAMES, W, H = 48, 160, 90
SMALL = ["--n", "24", "--size", "64", "--clutter", "0", "--count", "0", "--seed", "3"]


def _write_video(path: Path, frames: list[np.ndarray], fps: int = 30) -> None:
    """An MPEG-4 part 2 file (predicted frames between key frames, so seeking is tested)."""
    h, w = frames[0].shape[:2]
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    assert out.isOpened()
    for f in frames:
        out.write(f[..., ::-1])  # RGB -> BGR
    out.release()


def _lake(k: int, buoys: list[tuple[int, int]]) -> np.ndarray:
    """Frame ``k``: magenta water whose brightness encodes k, with bright green buoys."""
    img = np.zeros((H, W, 3), np.uint8)
    img[..., 0], img[..., 1], img[..., 2] = 120 + 2 * k, 30, 160
    for x, y in buoys:
        cv2.circle(img, (x, y), 6, (0, 255, 0), -1)
    return img


@pytest.fixture(scope="module")
def footage(tmp_path_factory) -> dict:
    """A video of a buoy crossing the frame, COCO labels of every frame, and a video of
    frames crowded with labelled buoys (no crop avoids them)."""
    d = tmp_path_factory.mktemp("footage")
    xs = [12 + 3 * k for k in range(FRAMES)]
    _write_video(d / "lake.mp4", [_lake(k, [(x, 45)]) for k, x in enumerate(xs)])
    images = [{"id": k + 1, "file_name": f"lake_{k:06d}.png", "width": W, "height": H}
              for k in range(FRAMES)]
    anns = [{"id": k + 1, "image_id": k + 1, "category_id": 7, "bbox": [x - 6, 39, 12, 12]}
            for k, x in enumerate(xs)]
    (d / "lake.json").write_text(json.dumps(
        {"images": images, "annotations": anns, "categories": [{"id": 7, "name": "buoy"}]}))
    crowd = [(x, y) for x in range(10, W, 40) for y in range(15, H, 30)]  # in every crop
    (d / "crowd").mkdir()
    _write_video(d / "crowd" / "crowd.mp4", [_lake(k, crowd) for k in range(4)])
    yolo = d / "crowd_labels"
    yolo.mkdir()
    for k in range(4):
        (yolo / f"crowd_{k:06d}.txt").write_text("".join(
            f"0 {x / W:.6f} {y / H:.6f} {12 / W:.6f} {12 / H:.6f}\n" for x, y in crowd))
    return {"dir": d, "video": d / "lake.mp4", "coco": d / "lake.json",
            "crowd": d / "crowd", "crowd_labels": yolo}


def _green(img: np.ndarray) -> int:
    """Pixels of the buoys' green (RGB) in an image."""
    return int(((img[..., 1] > 150) & (img[..., 0] < 110) & (img[..., 2] < 110)).sum())


def _read(folder: Path) -> list[np.ndarray]:
    return [cv2.imread(str(p))[..., ::-1] for p in sorted((folder / "images").rglob("*.jpg"))]


def test_video_frames_seek_to_the_frame_sequential_decoding_gives(footage):
    cap = cv2.VideoCapture(str(footage["video"]))
    seq = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        seq.append(f[..., ::-1])
    assert len(seq) == FRAMES
    reader = VideoReader()
    for k in (40, 3, 29, 0, FRAMES - 1, 17):  # backwards and forwards across key frames
        assert np.array_equal(reader.frame(footage["video"], k), seq[k]), k


def test_every_video_frame_is_a_source_with_its_label_key(footage):
    sources = list_sources(footage["dir"])  # the folder: lake.mp4 (crowd/ is a subfolder)
    assert [s.frame for s in sources] == list(range(FRAMES))
    assert sources[7].key == "lake_000007" and (sources[7].width, sources[7].height) == (W, H)


def test_frames_are_drawn_per_image_from_the_seed(footage):
    bg = Backgrounds(footage["video"])
    picks = [bg.pick((5, i, 4), 64, 64) for i in range(40)]
    again = Backgrounds(footage["video"])
    assert all(np.array_equal(p, again.pick((5, i, 4), 64, 64)) for i, p in enumerate(picks))
    # the red channel says which frame it came from (120 + 2 k): many frames are used
    frames = {round((float(np.median(p[..., 0])) - 120) / 2) for p in picks}
    assert len(frames) >= 20 and min(frames) >= 0 and max(frames) < FRAMES


def test_labelled_objects_never_reach_the_images(footage, tmp_path, sprites_dir):
    """Without labels the real buoy shows in many images; with them in none, and the run
    is byte-identical with 1 and 2 workers."""
    plain, one, two = tmp_path / "plain", tmp_path / "one", tmp_path / "two"
    rc, _, err = generate(SMALL, plain, sprites_dir, "--backgrounds", footage["video"])
    assert rc == 0, err
    assert sum(_green(im) > 0 for im in _read(plain)) >= 6
    args = ["--backgrounds", footage["video"], "--background-labels", footage["coco"]]
    rc, _, err = generate(SMALL, one, sprites_dir, *args)
    assert rc == 0, err
    rc, _, err = generate(SMALL, two, sprites_dir, *args, workers=2)
    assert rc == 0, err
    images = _read(one)
    assert len(images) == 24 and all(_green(im) == 0 for im in images)
    names = sorted(p.relative_to(one) for p in (one / "images").rglob("*.jpg"))
    assert len(names) == 24
    assert all((one / n).read_bytes() == (two / n).read_bytes() for n in names)
    cfg = json.loads((one / "dataset.json").read_text())["config"]
    assert cfg["background_labels"] == str(footage["coco"])


def test_crowded_frames_have_their_objects_painted_over(footage):
    """No crop of these frames avoids a buoy: the buoys in the crop are painted over from
    the water around them (YOLO labels, matched to the video's frames by name)."""
    bare = Backgrounds(footage["crowd"])
    bg = Backgrounds(footage["crowd"], footage["crowd_labels"])
    for i in range(6):
        before, after = bare.pick((1, i, 4), 96, 54), bg.pick((1, i, 4), 96, 54)
        assert _green(before) > 50 and _green(after) == 0, i
        # painted with the water's colour (red 120-126 in these 4 frames), not the buoys'
        assert 118 <= float(np.median(after[..., 0])) <= 128
        assert float(np.percentile(after[..., 0], 5)) > 100


def test_the_first_clear_draw_is_taken_unchanged_when_there_is_one(footage):
    """A crop that avoids the labelled buoy is used as it is (not painted)."""
    bg = Backgrounds(footage["video"], footage["coco"])
    bare = Backgrounds(footage["video"])
    same = sum(np.array_equal(bg.pick((2, i, 4), 64, 64), bare.pick((2, i, 4), 64, 64))
               for i in range(30))
    assert 3 <= same < 30  # where the first draw held no buoy both agree, elsewhere not


def test_label_readers(tmp_path, footage):
    coco = read_labels(footage["coco"])
    assert coco.categories == {7: "buoy"} and len(coco.frames) == FRAMES
    f = coco.of("lake_000002")
    assert f is not None and f.pixels(2 * W, 2 * H).tolist() == [[24.0, 78.0, 24.0, 24.0]]
    labels = tmp_path / "ds" / "labels"
    labels.mkdir(parents=True)
    (labels / "a.txt").write_text("1 0.5 0.5 0.2 0.4\n\n0 0.1 0.1 0.3 0.1 0.2 0.3\n")
    (labels.parent / "data.yaml").write_text('train: x\nnames:\n  0: "boat"\n  1: buoy\n')
    yolo = read_labels(labels)
    a = yolo.of("a")
    assert yolo.categories == {1: "boat", 2: "buoy"} and a is not None
    assert a.categories.tolist() == [2, 1]
    assert np.allclose(a.pixels(100, 50), [[40, 15, 20, 20], [10, 5, 20, 10]])
    (labels.parent / "data.yaml").write_text("names: [kayak, 'sup board']\n")
    assert yolo_names(labels) == {1: "kayak", 2: "sup board"}
    (labels / "b.txt").write_text("0 0.5 0.5 nan_width\n")
    with pytest.raises(UserError, match=r"b\.txt:1"):
        read_labels(labels)


def _one_line_error(rc: int, err: str, *words: str) -> None:
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert all(w in err for w in words), err


def test_footage_mistakes_are_one_line_errors_writing_nothing(tmp_path, footage, sprites_dir):
    out = tmp_path / "out"
    base = [*SMALL, "--out", out, "--sprites", sprites_dir, "--workers", 1, "--no-progress"]
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"images": [{"id": 1, "file_name": "x.jpg"}],
                                 "annotations": [], "categories": []}))
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"\0" * 2000)
    cases = [
        (["--backgrounds", footage["video"], "--background-labels", other],
         ("--background-labels", "none of its 1 labelled frames")),
        (["--background-labels", footage["coco"]], ("--background-labels", "--backgrounds")),
        (["--backgrounds", footage["video"], "--background-labels", tmp_path / "nope"],
         ("--background-labels", "nope")),
        (["--backgrounds", broken], ("--backgrounds", "broken.mp4")),
    ]
    for extra, words in cases:
        rc, _, err = cli([*base, *extra])
        _one_line_error(rc, err, *words)
        assert not out.exists(), extra


def test_a_large_photo_is_cached_downscaled(tmp_path, monkeypatch):
    """Frames are kept at the largest size their smallest crop needs: a 2000 px photo for
    64 px images is cached 8 times smaller, and the picks are those of the full photo up to
    resampling."""
    folder = tmp_path / "big"
    folder.mkdir()
    yy, xx = np.mgrid[0:1500, 0:2000]
    img = np.stack([xx * 255 // 2000, yy * 255 // 1500, np.full_like(xx, 90)], -1)
    cv2.imwrite(str(folder / "a.png"), img.astype(np.uint8)[..., ::-1])
    bg = Backgrounds(folder)
    small = bg.pick((0, 1, 4), 64, 64)
    assert [k[1] for k in bg._cache] == [0.125]  # the cache is the point
    monkeypatch.setattr(photos, "MIN_CROP", 0.01)  # needs the whole frame now
    full = Backgrounds(folder)
    full_pick = full._cut(0, np.array([0.0, 0.0, 0.75, 1.0]), False, 64, 64)
    monkeypatch.undo()
    cut = bg._cut(0, np.array([0.0, 0.0, 0.75, 1.0]), False, 64, 64)
    assert np.abs(full_pick.astype(int) - cut.astype(int)).max() <= 3
    assert small.shape == (64, 64, 3)


def test_folder_of_written_frames_is_checked(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="no photos or videos"):
        Backgrounds(tmp_path / "empty")
    with pytest.raises(UserError, match="no such folder"):
        Backgrounds(tmp_path / "missing")


def test_footage_is_not_recorded_by_a_second_camera_unless_asked(tmp_path):
    """Over your own frames the default look is clean (they have been through a camera):
    the camera stage runs no stage on a frame with no objects;
    an explicit drone look still records it."""
    from sdcomp.pipeline import Generator
    from sdcomp.scene.config import GeneratorConfig

    folder = tmp_path / "frames"
    folder.mkdir()
    frame = _lake(0, [])
    cv2.imwrite(str(folder / "a.png"), cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
    base = {"backgrounds": str(folder), "count": 0, "clutter": 0.0, "n": 1, "seed": 4}
    auto = GeneratorConfig.from_mapping(base)
    assert auto.look_preset == "clean"
    drone = GeneratorConfig.from_mapping({**base, "look": "mavic2pro"})
    assert drone.look_preset == "mavic2pro"
    assert GeneratorConfig.from_mapping({"look": "auto"}).look_preset == "mavic2pro"
    plain, looked = (Generator(c).render(0) for c in (auto, drone))
    assert plain.camera["stages"] == [] and looked.camera["stages"]
    assert np.abs(looked.image.astype(int) - plain.image).mean() > 1.0
