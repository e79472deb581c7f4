"""The files users hand over, through every command that reads them (``realism``, ``fit``,
``bench sim2real``, ``generate --backgrounds``): each either works or stops with exit
status 2 and one line naming the file and what is wrong, having written nothing. One rule
for a frame that cannot be read: stop (a truncated JPEG used to be skipped silently by
``realism`` and ``fit`` while a garbage one stopped them).
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from PIL import Image

from sdcomp.errors import UserError
from sdcomp.render.footage import VideoReader, list_sources, read_source
from sdcomp.render.footage_labels import read_labels

from .datasets import one_line_error
from .user_inputs import (
    BAD_COCO,
    BAD_PHOTOS,
    BAD_VIDEOS,
    BAD_YOLO,
    ODD_COCO,
    ODD_PHOTOS,
    ODD_YOLO,
    H,
    W,
    assert_refused,
    coco_labels,
    command,
    frames_folder,
    generated,
    run,
    scene,
    yolo_labels,
)

__all__ = ["command", "generated"]  # fixtures

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")


# --------------------------------------------------------------------------- photos

@pytest.mark.parametrize("cmd", ["realism", "fit", "backgrounds", "sim2real"])
@pytest.mark.parametrize("bad", sorted(BAD_PHOTOS))
def test_a_bad_photo_stops_every_command_naming_it(cmd, bad, command, tmp_path):
    frames = frames_folder(tmp_path, {bad: BAD_PHOTOS[bad]})
    labels = coco_labels(frames, tmp_path / "labels.json")
    rc, err = run(command, cmd, frames, labels, tmp_path / "out")
    assert_refused(rc, err, tmp_path / "out", bad)
    if bad.startswith("truncated"):
        assert "truncated" in err


@pytest.mark.parametrize("odd", sorted(ODD_PHOTOS))
def test_odd_photos_are_read_as_shown(odd, tmp_path):
    """16-bit, grey, CMYK, EXIF-rotated photos and a PNG named .jpg: read as 8-bit RGB at the
    size a viewer shows them, the same size their header check lists (labels are scaled by
    it), and close to what Pillow shows."""
    frames = frames_folder(tmp_path, {odd: ODD_PHOTOS[odd]}, n=0)
    (src,) = list_sources(frames, "--real")
    rgb = read_source(src, VideoReader(), "--real")
    assert rgb.dtype == np.uint8 and rgb.shape == (src.height, src.width, 3)
    with Image.open(frames / odd) as im:
        from PIL import ImageOps
        shown = np.asarray(ImageOps.exif_transpose(im).convert("RGB"), np.float64)
    if odd.startswith("png16"):
        shown = np.asarray(scene()[..., ::-1], np.float64)  # Pillow has no 16-bit RGB mode
    assert shown.shape == rgb.shape
    assert np.abs(shown - rgb).mean() < 3.0, odd
    expected = (H, W) if odd != "exif.jpg" else (W, H)
    assert rgb.shape[:2] == expected


@pytest.mark.parametrize("cmd", ["realism", "fit", "backgrounds", "sim2real"])
def test_an_exif_rotated_frame_works_in_every_command(cmd, command, tmp_path):
    frames = frames_folder(tmp_path, {"exif.jpg": ODD_PHOTOS["exif.jpg"]})
    labels = coco_labels(frames, tmp_path / "labels.json",
                         lambda c: c["images"][-1].update(width=H, height=W))
    rc, err = run(command, cmd, frames, labels, tmp_path / "out")
    assert rc == 0, err
    assert "Traceback" not in err


# --------------------------------------------------------------------------- videos

@pytest.mark.parametrize("bad", sorted(BAD_VIDEOS))
@pytest.mark.parametrize("cmd", ["realism", "backgrounds"])
def test_a_bad_video_stops_naming_it_in_one_line(bad, cmd, command, tmp_path):
    """Also FFmpeg's own complaints (``moov atom not found``) stay off stderr."""
    frames = frames_folder(tmp_path, {bad: BAD_VIDEOS[bad]})
    labels = coco_labels(frames, tmp_path / "labels.json")
    rc, err = run(command, cmd, frames, labels, tmp_path / "out")
    assert_refused(rc, err, tmp_path / "out", bad)


def test_a_video_cut_short_is_refused_by_the_listing(tmp_path):
    """It opens and claims 30 frames but holds about 10: refused before any work, not at
    the frame that fails in the middle of a run (or after a detector was trained)."""
    frames = frames_folder(tmp_path, {"cutshort.avi": BAD_VIDEOS["cutshort.avi"]}, n=0)
    cap = cv2.VideoCapture(str(frames / "cutshort.avi"))
    assert cap.isOpened() and int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 30
    cap.release()
    with pytest.raises(UserError, match="claims 30 frames"):
        list_sources(frames, "--real")


# --------------------------------------------------------------------------- labels

@pytest.mark.parametrize("cmd", ["realism", "fit", "backgrounds", "sim2real"])
@pytest.mark.parametrize("bad", sorted(BAD_COCO))
def test_a_bad_coco_file_stops_every_command_naming_it(cmd, bad, command, tmp_path):
    frames = frames_folder(tmp_path)
    labels = coco_labels(frames, tmp_path / "labels.json", BAD_COCO[bad])
    rc, err = run(command, cmd, frames, labels, tmp_path / "out")
    assert_refused(rc, err, tmp_path / "out", "labels.json")


@pytest.mark.parametrize("bad", sorted(BAD_YOLO))
@pytest.mark.parametrize("cmd", ["realism", "sim2real"])
def test_a_bad_yolo_line_stops_naming_file_and_line(bad, cmd, command, tmp_path):
    frames = frames_folder(tmp_path)
    labels = yolo_labels(frames, tmp_path, BAD_YOLO[bad])
    rc, err = run(command, cmd, frames, labels, tmp_path / "out")
    assert_refused(rc, err, tmp_path / "out", "ok0.txt:1")


@pytest.mark.parametrize("odd", sorted(ODD_COCO))
def test_odd_coco_files_are_read(odd, tmp_path):
    """Boxes outside the frame are kept as given (each command clips what it draws); a file
    name's folders are never opened: frames are matched by the stem."""
    frames = frames_folder(tmp_path)
    lab = read_labels(coco_labels(frames, tmp_path / "labels.json", ODD_COCO[odd]))
    assert sorted(lab.frames) == ["ok0", "ok1", "ok2"]
    assert all(len(f.boxes) == 1 for f in lab.frames.values())


@pytest.mark.parametrize("cmd", ["realism", "fit", "backgrounds"])
def test_odd_labels_work_in_every_command(cmd, command, tmp_path):
    frames = frames_folder(tmp_path)

    def every_odd(c: dict) -> None:
        for change in ODD_COCO.values():
            change(c)
    rc, err = run(command, cmd, frames, coco_labels(frames, tmp_path / "l.json", every_odd),
                  tmp_path / "out")
    assert rc == 0, err
    rc, err = run(command, cmd, frames, yolo_labels(frames, tmp_path, ODD_YOLO["outside"]),
                  tmp_path / "out2")
    assert rc == 0, err


def test_sim2real_scores_only_the_clipped_part_of_boxes_outside(command, tmp_path):
    from sdcomp.bench.realdata import real_frames
    frames = frames_folder(tmp_path)
    real = real_frames(frames, coco_labels(frames, tmp_path / "l.json",
                                           ODD_COCO["box partly outside"]))
    x, y, w, h = real.coco["annotations"][0]["bbox"]
    assert (x, y, x + w, y + h) == (150, 110, W, H)
    assert len(real.coco["annotations"]) == 3
    assert json.dumps(real.coco)  # a COCO ground truth pycocotools can take


def test_ffmpeg_says_nothing_of_its_own_on_a_damaged_video(tmp_path):
    """FFmpeg writes its complaints (``moov atom not found``) to the process's stderr
    itself, past Python: only a subprocess sees them. sdcomp's one line is all there is."""
    import subprocess
    import sys

    from .datasets import REPO
    frames = frames_folder(tmp_path, {"truncated.mp4": BAD_VIDEOS["truncated.mp4"]}, n=0)
    code = ("import sys; from sdcomp.errors import run_cli; from sdcomp.cli.fit import "
            "main; sys.exit(run_cli(main, sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", code, str(frames), "--out",
                           str(tmp_path / "out" / "fitted.toml")],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    one_line_error(proc.stderr)
    assert "truncated.mp4" in proc.stderr


@pytest.mark.parametrize("name", ["ok0.jpg", "v.mp4"])
def test_a_frame_larger_than_the_machine_can_hold_is_refused_with_its_size(name, tmp_path,
                                                                         monkeypatch):
    """On a machine of 200 kB (SDCOMP_MEMORY_BYTES), a 160 x 120 frame (16 bytes a pixel
    while it is read: 300 kB) is refused before it is decoded, its size named."""
    from .user_inputs import write_video
    frames = frames_folder(tmp_path, n=1 if name.endswith("jpg") else 0)
    if name.endswith("mp4"):
        write_video(frames / name, 3)
    monkeypatch.setenv("SDCOMP_MEMORY_BYTES", "200000")
    with pytest.raises(UserError, match=rf"{name} \(160 x 120 pixel.*more than this machine"):
        list_sources(frames, "--real")
    monkeypatch.setenv("SDCOMP_MEMORY_BYTES", "400000")
    assert len(list_sources(frames, "--real")) in (1, 3)
