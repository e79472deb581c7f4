"""sdcomp video: flights, tracked identities, MOTChallenge / COCO-video ground truth,
determinism across workers, resume, bad input."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli import main as cli_main
from sdcomp.errors import run_cli
from sdcomp.io.clip_layout import ClipLayout
from sdcomp.io.mot import read_gt, read_seqinfo
from sdcomp.io.png import decode_png16
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.flight import FLIGHTS, MAX_ACCEL, draw_flight
from sdcomp.scene.sequence import frame_scene, sample_sequence
from sdcomp.scene.video import VideoConfig

ARGS = ["--size", "160", "--frames", "16", "--fps", "10", "--seed", "3", "--count", "3-5",
        "--altitude", "12-20", "--quiet", "--val-fraction", "0.34"]  # sequence 2 is val
SPRITES: list[Path] = []  # the session's sprite folder (set by the clips fixture)


def sdcomp_main(argv: list[str]) -> int:
    """``sdcomp ARGV`` as the console script runs it (exit status 2 for user errors)."""
    return run_cli(cli_main, argv)


def _run(out: Path, *extra: str) -> int:
    return sdcomp_main(["video", "--out", str(out), "--sprites", str(SPRITES[0]), *ARGS,
                        *extra])


def _hashes(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def clips(tmp_path_factory, sprites_dir) -> Path:
    SPRITES[:] = [sprites_dir]
    out = tmp_path_factory.mktemp("v") / "clips"
    assert _run(out, "--sequences", "3", "--flight", "pass", "lawnmower", "hover",
                "--workers", "1", "--format", "coco,yolo") == 0
    return out


# ---------------------------------------------------------------- flights
@pytest.mark.parametrize("kind", FLIGHTS)
def test_flights_are_smooth_and_stay_in_range(kind):
    for seed in range(6):
        rng = np.random.default_rng(seed)
        f = draw_flight(rng, kind, 30.0, 70.0, 40.0, 12.0, (20.0, 40.0), (60.0, 90.0), 50.0)
        fps = 30.0
        st = f.state(np.arange(0, 1800) / fps)  # a minute
        # bounded acceleration (second differences of the position), never teleporting
        ax = np.diff(st.x, 2) * fps * fps
        ay = np.diff(st.y, 2) * fps * fps
        assert np.hypot(ax, ay).max() <= MAX_ACCEL * 1.05, (kind, seed)
        step = np.hypot(np.diff(st.x), np.diff(st.y)).max()
        assert step <= (max(f.speed, 0.5) * 1.6 + 1.0) / fps
        # the reported velocity is the position's derivative
        vx = np.gradient(st.x, 1 / fps)
        assert np.abs(vx[1:-1] - st.vx[1:-1]).max() < 0.05 * max(1.0, f.speed)
        assert 20.0 <= st.altitude.min() and st.altitude.max() <= 40.0
        assert 60.0 <= st.pitch.min() and st.pitch.max() <= 90.0
        # the state at a time does not depend on which other times are asked for
        one = f.state(np.array([12.3]))
        assert float(one.x[0]) == float(f.state(np.array([0.0, 12.3])).x[1])


def test_hover_holds_station_and_pass_travels():
    rng = np.random.default_rng(0)
    hover = draw_flight(rng, "hover", 30.0, 90.0, 0.0, 8.0, (30, 30), (90, 90), 40.0)
    st = hover.state(np.linspace(0, 60, 600))
    assert np.hypot(st.x, st.y).max() < 1.0
    run = draw_flight(np.random.default_rng(0), "pass", 30.0, 90.0, 0.0, 8.0, (30, 30),
                      (90, 90), 40.0)
    st = run.state(np.array([0.0, 10.0]))
    assert np.hypot(st.x[1] - st.x[0], st.y[1] - st.y[0]) == pytest.approx(80.0, abs=1.0)


def test_orbit_keeps_its_centre_in_view():
    f = draw_flight(np.random.default_rng(1), "orbit", 30.0, 45.0, 10.0, 6.0, (30, 30),
                    (45, 45), 40.0)
    st = f.state(np.linspace(0, 40, 200))
    # the point the camera looks at (its centre ray on the sea) stays put
    h = np.radians(st.heading)
    reach = st.altitude / np.tan(np.radians(st.pitch))
    cx, cy = st.x + reach * np.cos(h), st.y + reach * np.sin(h)
    assert np.hypot(cx - cx[0], cy - cy[0]).max() < 2.0
    assert np.ptp(np.unwrap(h)) > 1.0  # it does go round


def test_frame_depends_only_on_sequence_and_frame():
    v = VideoConfig(GeneratorConfig(seed=5, width=160, height=160), frames=40, flight="pass")
    longer = VideoConfig(GeneratorConfig(seed=5, width=160, height=160), frames=40,
                         sequences=9, flight="pass")
    a, _ = frame_scene(sample_sequence(v, 2), 17)
    b, _ = frame_scene(sample_sequence(longer, 2), 17)
    assert a == b
    c, _ = frame_scene(sample_sequence(v, 3), 17)
    assert c != a


# ---------------------------------------------------------------- ground truth
def test_layout_and_seqinfo(clips):
    layout = ClipLayout(clips)
    meta = json.loads(layout.meta.read_text())
    assert meta["status"] == "complete" and meta["counts"]["sequences"] == 3
    for s in range(3):
        info = read_seqinfo(layout.seqinfo(s))
        assert info["name"] == layout.name(s) and info["seqLength"] == "16"
        assert info["frameRate"] == "10" and info["imWidth"] == "160"
        assert len(list((layout.seq(s) / "img1").glob("*.jpg"))) == 16
        flight = json.loads(layout.flight(s).read_text())
        assert len(flight) == 16
        for key in ("latitude", "longitude", "altitude(meter)", "gimbal_pitch(degrees)",
                    "speed(m/s)", "compass_heading(degrees)", "timestamp"):
            assert key in flight[0]
        assert [m["timestamp"] for m in flight] == [k * 100 for k in range(16)]
        # GPS-like positions from the default start (Lake Constance) and the flight
        assert abs(flight[0]["latitude"] - 47.6715) < 1e-4
        assert abs(flight[0]["longitude"] - 9.2706) < 1e-4


def test_gt_agrees_with_the_masks(clips):
    layout = ClipLayout(clips)
    seen_partial = seen_ignored = False
    for s in range(3):
        gt = read_gt(layout.gt(s))
        assert len(gt) > 0
        for k in range(16):
            mask = decode_png16(layout.mask(s, k).read_bytes())
            frame = gt[gt[:, 0] == k + 1]
            rows = frame[frame[:, 6] == 1]
            assert sorted(rows[:, 1].astype(int)) == sorted(set(np.unique(mask)) - {0})
            ignore_path = layout.ignore_mask(s, k)
            ignore = (cv2.imread(str(ignore_path), cv2.IMREAD_UNCHANGED) > 0
                      if ignore_path.exists() else np.zeros(mask.shape, bool))
            assert not (ignore & (mask > 0)).any()
            for _, _tid, left, top, w, h, _conf, cls, _vis in frame[frame[:, 6] == 0]:
                # an ignore row: its box is on the ignore mask, its track visible but tiny
                x, y = int(left) - 1, int(top) - 1
                assert ignore[y:y + int(h), x:x + int(w)].any() and cls == 1
                seen_ignored = True
            assert len(rows) + int((frame[:, 6] == 0).sum()) == len(frame)
            for _, tid, left, top, w, h, conf, cls, vis in rows:
                ys, xs = np.nonzero(mask == tid)
                assert (xs.min() + 1, ys.min() + 1) == (left, top)
                assert (xs.max() - xs.min() + 1, ys.max() - ys.min() + 1) == (w, h)
                assert conf == 1 and cls == 1 and 0 < vis <= 1
                seen_partial |= vis < 0.9
    assert seen_partial  # objects cut by the frame's edge (entering, leaving) or occluded
    assert seen_ignored  # tracks stay accounted for to their last visible pixel


def test_identities_persist_and_never_jump(clips):
    layout = ClipLayout(clips)
    for s in range(3):
        gt = read_gt(layout.gt(s))
        flight = json.loads(layout.flight(s).read_text())
        part = json.loads(layout.part(s).read_text())
        cats = {a["instance_id"]: a["category_id"] for a in part["annotations"]}
        assert all(cats[a["instance_id"]] == a["category_id"] for a in part["annotations"])
        for tid in np.unique(gt[:, 1]):
            rows = gt[gt[:, 1] == tid]
            frames = rows[:, 0].astype(int)
            for a, b in zip(rows[:-1], rows[1:], strict=True):
                if b[0] != a[0] + 1:
                    continue
                m = flight[int(a[0]) - 1]
                gsd = m["gsd(m/px)"]
                # the camera's and the object's motion in one frame, and the box's size
                move = (m["speed(m/s)"] + 3.0) / 10.0 / gsd + 0.5 * max(a[4], a[5], b[4],
                                                                        b[5]) + 3
                ca = (a[2] + a[4] / 2, a[3] + a[5] / 2)
                cb = (b[2] + b[4] / 2, b[3] + b[5] / 2)
                assert np.hypot(cb[0] - ca[0], cb[1] - ca[1]) <= move, (s, tid, a, b)
            assert len(frames) == len(set(frames))


def test_objects_enter_and_leave_a_pass(clips, tmp_path):
    out = tmp_path / "c"
    assert _run(out, "--sequences", "1", "--flight", "pass", "--speed", "12", "--frames",
                "40", "--workers", "1") == 0
    gt = read_gt(ClipLayout(out).gt(0))
    spans = [(gt[gt[:, 1] == t][:, 0].min(), gt[gt[:, 1] == t][:, 0].max())
             for t in np.unique(gt[:, 1])]
    assert any(a > 1 for a, _ in spans)  # one came into view
    assert any(b < 40 for _, b in spans)  # one left it


def _iou_distance(a: np.ndarray, b: np.ndarray, max_d: float = 0.5) -> np.ndarray:
    """1 - IoU of (N, 4) and (M, 4) left, top, width, height boxes; NaN (no match) above
    ``max_d`` (motmetrics' iou_matrix, which calls np.asfarray, gone in NumPy 2)."""
    x0 = np.maximum(a[:, None, 0], b[None, :, 0])
    y0 = np.maximum(a[:, None, 1], b[None, :, 1])
    x1 = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2])
    y1 = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    d = 1.0 - inter / union
    return np.where(d > max_d, np.nan, d)


def test_motmetrics_on_the_ground_truth(clips):
    mm = pytest.importorskip("motmetrics")
    gt = read_gt(ClipLayout(clips).gt(0))
    gt = gt[gt[:, 6] == 1]  # ignore rows (flag 0) are no ground truth, as TrackEval reads
    rng = np.random.default_rng(0)

    def scores(hyp: np.ndarray) -> tuple[float, float]:
        acc = mm.MOTAccumulator(auto_id=True)
        for k in range(1, 17):
            g, h = gt[gt[:, 0] == k], hyp[hyp[:, 0] == k]
            dist = _iou_distance(g[:, 2:6], h[:, 2:6])
            acc.update(g[:, 1].astype(int), h[:, 1].astype(int), dist)
        summary = mm.metrics.create().compute(acc, metrics=["mota", "idf1"])
        return float(summary["mota"].iloc[0]), float(summary["idf1"].iloc[0])

    assert scores(gt.copy()) == (1.0, 1.0)
    shuffled = gt.copy()
    for k in range(1, 17):  # ids swapped at random in every frame
        rows = shuffled[:, 0] == k
        shuffled[rows, 1] = rng.permutation(shuffled[rows, 1])
    while np.array_equal(shuffled[:, 1], gt[:, 1]):
        shuffled[:, 1] = rng.permutation(shuffled[:, 1])
    mota, idf1 = scores(shuffled)
    assert idf1 < 1.0 and mota <= 1.0


def test_coco_video_agrees_with_the_masks(clips):
    from pycocotools import mask as mask_utils

    layout = ClipLayout(clips)
    coco = json.loads(layout.coco.read_text())
    assert [v["name"] for v in coco["videos"]] == [layout.name(s) for s in range(3)]
    images = {im["id"]: im for im in coco["images"]}
    assert len(images) == 48
    tracks = {t["id"] for t in coco["tracks"]}
    for a in coco["annotations"][::7]:
        im = images[a["image_id"]]
        assert a["track_id"] in tracks and im["video_id"] == a["video_id"]
        mask = decode_png16((clips / im["mask_file"]).read_bytes())
        rle = dict(a["segmentation"])
        decoded = mask_utils.decode(rle).astype(bool)
        if a["iscrowd"]:  # an ignore region: on the frame's ignore mask
            ignore = cv2.imread(str(clips / im["ignore_file"]), cv2.IMREAD_UNCHANGED) > 0
            assert decoded.any() and not (decoded & ~ignore).any()
            continue
        assert np.array_equal(decoded, mask == a["instance_id"])
        assert im["file_name"].endswith(f"{im['frame_id'] + 1:06d}.jpg")
    assert len({a["id"] for a in coco["annotations"]}) == len(coco["annotations"])


def test_yolo_labels_per_frame(clips):
    layout = ClipLayout(clips)
    gt = read_gt(layout.gt(0))
    for k in (0, 9):
        lines = layout.label(0, k).read_text().splitlines()
        assert len(lines) == int(((gt[:, 0] == k + 1) & (gt[:, 6] == 1)).sum())
    assert (layout.seq(0) / "images" / "000001.jpg").exists()  # Ultralytics finds labels/
    assert "sdcomp-0000/images" in layout.data_yaml.read_text()


def test_val_fraction_splits_whole_sequences(clips):
    """--val-fraction 0.34 of 3 sequences: sequence 2 is val, in data.yaml, the COCO-video
    file and the clips dataset; train and val share no sequence."""
    import yaml

    from sdcomp.scene.video import sequence_split

    layout = ClipLayout(clips)
    data = yaml.safe_load(layout.data_yaml.read_text())
    assert data["train"] == [f"{layout.name(s)}/images" for s in (0, 1)]
    assert data["val"] == [f"{layout.name(2)}/images"]
    assert not set(data["train"]) & set(data["val"])
    coco = json.loads(layout.coco.read_text())
    assert [v["split"] for v in coco["videos"]] == ["train", "train", "val"]
    assert [sequence_split(s, 0.2) for s in range(10)].count("val") == 2
    assert [s for s in range(10) if sequence_split(s, 0.2) == "val"] == [4, 9]
    assert {sequence_split(s, 0.0) for s in range(50)} == {"train"}


# ---------------------------------------------------------------- runs
def test_same_bytes_with_any_workers_and_after_resume(clips, tmp_path):
    two = tmp_path / "two"
    assert _run(two, "--sequences", "3", "--flight", "pass", "lawnmower", "hover",
                "--workers", "2", "--format", "coco,yolo") == 0
    assert _hashes(two) == _hashes(clips)
    # a run stopped in its second sequence: its folder half written, no seqinfo.ini
    resumed = tmp_path / "resumed"
    shutil.copytree(clips, resumed, symlinks=True)
    layout = ClipLayout(resumed)
    layout.seqinfo(1).unlink()
    for k in range(8, 16):
        layout.image(1, k, "jpg").unlink()
    shutil.rmtree(layout.seq(2))
    assert _run(resumed, "--sequences", "3", "--flight", "pass", "lawnmower", "hover",
                "--workers", "1", "--format", "coco,yolo", "--resume") == 0
    assert _hashes(resumed) == _hashes(clips)


def test_resume_with_other_options_is_refused(clips, tmp_path, capsys):
    other = tmp_path / "o"
    shutil.copytree(clips, other, symlinks=True)
    before = _hashes(other)
    assert _run(other, "--sequences", "3", "--fps", "25", "--resume") == 2
    assert "--resume" in capsys.readouterr().err
    assert _hashes(other) == before


@pytest.mark.parametrize("flag,value,words", [
    ("--frames", "0", "frames"), ("--fps", "0", "fps"), ("--fps", "-3", "fps"),
    ("--flight", "zigzag", "flight"), ("--sequences", "0", "sequences")])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, flag, value, words):
    out = tmp_path / "bad"
    code = sdcomp_main(["video", "--out", str(out), flag, value])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and words in err
    assert "Traceback" not in err
    assert not out.exists()


def test_shards_merge_to_the_same_bytes(clips, tmp_path):
    common = ["--sequences", "3", "--flight", "pass", "lawnmower", "hover", "--workers", "1",
              "--format", "coco,yolo"]
    for k in (1, 0):
        assert _run(tmp_path / f"s{k}", *common, "--shard", f"{k}/2") == 0
    meta = json.loads((tmp_path / "s1" / "video.json").read_text())
    assert meta["shard"] == "1/2" and meta["counts"]["sequences"] < 3
    merged = tmp_path / "merged"
    assert sdcomp_main(["merge", str(tmp_path / "s0"), str(tmp_path / "s1"), "--out",
                        str(merged)]) == 0
    assert _hashes(merged) == _hashes(clips)
    # a missing shard is one line, and nothing is written
    assert sdcomp_main(["merge", str(tmp_path / "s0"), "--out", str(tmp_path / "m2")]) == 2
    assert not (tmp_path / "m2").exists()


def test_dask_engine_gives_the_same_bytes(clips, tmp_path):
    pytest.importorskip("dask.distributed")
    out = tmp_path / "dask"
    assert _run(out, "--sequences", "3", "--flight", "pass", "lawnmower", "hover",
                "--workers", "2", "--format", "coco,yolo", "--engine", "dask") == 0
    assert not (out / ".shards").exists()
    assert _hashes(out) == _hashes(clips)
