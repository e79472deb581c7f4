"""sdcomp show of a video folder: the strip (rows = sequences, evenly spaced frames, boxes of
gt.txt in one colour per track id), the animated preview, and one-line errors; still
folders keep their behaviour and refuse the video-only flags."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli import main as cli_main
from sdcomp.cli.show import main as show_main
from sdcomp.errors import run_cli
from sdcomp.io.mot import read_gt
from sdcomp.report.video_sheet import (
    GAP,
    load_video,
    strip,
    strip_frames,
    track_colour,
)

SIZE = 128
FRAMES = 10


@pytest.fixture(scope="module")
def clips(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("show_video") / "clips"
    rc = run_cli(cli_main, ["video", "--out", str(out), "--sprites", str(sprites_dir),
                            "--size", str(SIZE), "--sequences", "2", "--frames", str(FRAMES),
                            "--altitude", "4-6", "--count", "2-3", "--clutter", "0",
                            "--seed", "3", "--workers", "1", "--no-progress"])
    assert rc == 0
    return out


def show(capsys, *argv: str) -> tuple[int, str, str]:
    rc = run_cli(show_main, [str(a) for a in argv])
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


def test_strip_written_with_rows_per_sequence(clips, tmp_path, capsys):
    out = tmp_path / "strip.png"
    rc, stdout, err = show(capsys, clips, "--out", out, "--cell", SIZE)
    assert rc == 0 and err == ""
    assert "2 of 2 sequences x 6 frames" in stdout
    img = cv2.imread(str(out), cv2.IMREAD_COLOR)
    assert img.shape == (2 * SIZE + GAP, 6 * SIZE + 5 * GAP, 3)
    assert img.std() > 5 and len(np.unique(img.reshape(-1, 3), axis=0)) > 500
    assert [p.name for p in tmp_path.iterdir()] == ["strip.png"]  # no temporary left


def test_default_out_and_limits(clips, capsys):
    rc, stdout, _ = show(capsys, clips, "--sequences", "1", "--frames-per-row", "3",
                         "--cell", "64")
    assert rc == 0 and "1 of 2 sequences x 3 frames" in stdout
    img = cv2.imread(str(clips / "strip.png"), cv2.IMREAD_COLOR)
    assert img.shape == (64, 3 * 64 + 2 * GAP, 3)
    (clips / "strip.png").unlink()


def test_boxes_drawn_where_gt_says_in_the_track_colour(clips):
    seqs = load_video(clips)
    sheet, rows = strip(seqs, 2, 4, SIZE)
    checked = 0
    for r, (seq, ks) in enumerate(rows):
        assert ks == strip_frames(seq, 4) and ks[0] == 0 and ks[-1] == FRAMES - 1
        gt = read_gt(clips / seq.name / "gt" / "gt.txt")
        y0 = r * (SIZE + GAP)
        for c, k in enumerate(ks):
            x0 = c * (SIZE + GAP)
            for f, tid, left, top, w, h, *_ in gt[gt[:, 0] == k + 1]:
                assert f == k + 1
                x, y = int(left) - 1 + x0, int(top) - 1 + y0
                x1, y1 = x + int(w) - 1, y + int(h) - 1
                edge = np.concatenate([sheet[y1, x:x1 + 1], sheet[y:y1 + 1, x1],
                                       sheet[y:y1 + 1, x]])
                hits = np.all(edge == track_colour(int(tid)), axis=1).mean()
                assert hits > 0.6, (seq.name, k, tid, hits)
                checked += 1
    assert checked >= 10


def test_track_colours_stable_and_distinct():
    colours = [track_colour(i) for i in range(1, 9)]
    assert colours == [track_colour(i) for i in range(1, 9)]
    assert len(set(colours)) == 8
    assert all(max(c) == 255 for c in colours)


def test_preview_gif_and_mp4(clips, tmp_path, capsys):
    from PIL import Image

    gif = tmp_path / "seq.gif"
    rc, stdout, _ = show(capsys, clips, "--preview", gif, "--sequence", "1")
    assert rc == 0 and "sdcomp-0001" in stdout and f"{FRAMES} frames" in stdout
    assert not (clips / "strip.png").exists()  # --preview alone writes no strip
    with Image.open(gif) as im:
        assert im.n_frames == FRAMES and im.size == (SIZE, SIZE)
    mp4 = tmp_path / "seq.mp4"
    out = tmp_path / "s.png"
    rc, stdout, _ = show(capsys, clips, "--preview", mp4, "--out", out, "--cell", "64")
    assert rc == 0 and out.is_file() and "sdcomp-0000" in stdout
    cap = cv2.VideoCapture(str(mp4))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    assert n == FRAMES
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.png", "seq.gif", "seq.mp4"]


@pytest.mark.parametrize("argv, words", [
    (["--preview", "{tmp}/p.gif", "--sequence", "7"], ["--sequence 7", "has 0, 1"]),
    (["--sequence", "1"], ["--sequence", "--preview"]),
    (["--preview", "{tmp}/p.avi"], ["--preview", ".gif or .mp4"]),
    (["--preview", "{tmp}/no/p.gif"], ["--preview", "existing folder"]),
    (["--sequences", "0"], ["--sequences 0", "at least 1"]),
    (["--frames-per-row", "0"], ["--frames-per-row 0", "at least 1"]),
    (["--out", "{tmp}/s.jpg"], ["must end in .png"]),
    (["--zoom"], ["--zoom", "dataset folders"]),
])
def test_cli_errors_are_one_line(clips, tmp_path, capsys, argv, words):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    rc, stdout, err = show(capsys, clips, *argv)
    assert rc == 2 and stdout == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert list(tmp_path.iterdir()) == []


def test_sdcomp_command_exit_status(clips, tmp_path, capsys):
    assert run_cli(cli_main, ["show", str(clips), "--preview", str(tmp_path / "p.gif"),
                              "--sequence", "9"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_unfinished_and_still_folders(clips, tmp_path, capsys):
    broken = tmp_path / "v"
    broken.mkdir()
    (broken / "video.json").write_text('{"format": "sdcomp-video"}')
    rc, _, err = show(capsys, broken)
    assert rc == 2 and "no finished sequence" in err and err.count("\n") == 1
    (broken / "video.json").write_text("{")
    rc, _, err = show(capsys, broken)
    assert rc == 2 and "video.json" in err
    still = tmp_path / "still"
    still.mkdir()
    rc, _, err = show(capsys, still, "--frames-per-row", "3")
    assert rc == 2 and "--frames-per-row is for video folders" in err
    rc, _, err = show(capsys, still)  # still folders: the still command's errors
    assert rc == 2 and "not a generated dataset" in err
