"""Beyond one machine: ``--shard K/N`` + ``python -m sdcomp.merge``, and ``--engine dask``.

Every way of splitting the work must give the bytes of one plain local run with the same
seed: 3 shards merged, a 2-worker Dask LocalCluster; a shard (or Dask task) that failed is
finished by re-running it with ``--resume`` alone.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from sdcomp.cli import merge as merge_mod
from sdcomp.run import local as writer
from sdcomp.run.shards import parse_shard, shard_folder, shard_range

from .datasets import (
    assert_identical,
    by_name,
    check_intact,
    cli,
    files,
    generate,
    one_line_error,
)

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

BASE = ["--n", "40", "--size", "64", "--clutter", "0", "--altitude", "3-6", "--count", "0-2",
        "--seed", "5"]


def gen(out: Path, sprites: Path, *extra, workers: int = 1) -> tuple[int, str, str]:
    return generate(BASE, out, sprites, *extra, workers=workers)


def merge(*argv) -> tuple[int, str, str]:
    return cli(list(argv), entry=merge_mod.main)


@pytest.fixture(scope="module")
def plain(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("shards") / "plain"
    rc, _, err = gen(out, sprites_dir)
    assert rc == 0, err
    return out


def test_shard_ranges_cover_every_index_once():
    for n_images in (1, 2, 7, 40, 1001):
        for n in (1, 2, 3, 8, 50):
            got = [i for k in range(n) for i in shard_range(n_images, k, n)]
            assert got == list(range(n_images))
            sizes = [len(shard_range(n_images, k, n)) for k in range(n)]
            assert max(sizes) - min(sizes) <= 1
    assert parse_shard("2/3") == (2, 3) and parse_shard(" 0 / 1 ") == (0, 1)
    assert shard_folder(3, 16) == "shard-003-of-016"


def test_three_shards_merged_equal_a_plain_run(plain, tmp_path, sprites_dir):
    dirs = []
    for k in range(3):
        d = tmp_path / f"part{k}"
        rc, _, err = gen(d, sprites_dir, "--shard", f"{k}/3", workers=2 if k == 1 else 1)
        assert rc == 0, err
        meta = json.loads((d / "dataset.json").read_text())
        assert meta["shard"] == f"{k}/3" and meta["status"] == "complete"
        rng = shard_range(40, k, 3)
        assert [p.name for p in by_name(d / "images")] == [f"{i:06d}.jpg" for i in rng]
        assert check_intact(d) == len(rng)  # each shard is a valid dataset of its images
        dirs.append(d)
    out = tmp_path / "merged"
    rc, stdout, err = merge(dirs[2], dirs[0], dirs[1], "--out", out, "--no-progress")
    assert rc == 0, err
    assert "merged 3 shards: 40 images" in stdout
    assert_identical(plain, out)
    before = files(dirs[0])
    # refusals: one line, the merged dataset untouched
    snapshot = files(out)
    for argv, words in [
        ([dirs[0], dirs[1], "--out", tmp_path / "m2"], "shard 2/3 missing"),
        ([dirs[0], dirs[0], dirs[1], dirs[2], "--out", tmp_path / "m3"], "given twice"),
        ([*dirs, "--out", out], "--overwrite"),
        ([plain, "--out", tmp_path / "m4"], "not a shard"),
        ([tmp_path / "nothing", "--out", tmp_path / "m5"], "not an sdcomp dataset"),
    ]:
        rc, _, err = merge(*argv, "--no-progress")
        assert rc == 2, (argv, err)
        one_line_error(err)
        assert words in err, err
    assert files(out) == snapshot
    # --overwrite redoes a merge; --remove-shards deletes the shard folders afterwards
    rc, _, err = merge(*dirs, "--out", out, "--overwrite", "--remove-shards", "--no-progress")
    assert rc == 0, err
    assert_identical(plain, out)
    assert not any(d.exists() for d in dirs) and before


def test_failed_shard_is_finished_by_resume_alone(plain, tmp_path, sprites_dir, monkeypatch):
    dirs = [tmp_path / f"s{k}" for k in range(3)]
    for k in (0, 2):
        assert gen(dirs[k], sprites_dir, "--shard", f"{k}/3")[0] == 0
    real = writer.make_record

    def dies(gen_, index, *rest):
        if index == 20:
            raise KeyboardInterrupt  # the job was stopped (SLURM sends SIGTERM: the same)
        return real(gen_, index, *rest)

    monkeypatch.setattr(writer, "make_record", dies)
    rc, _, err = gen(dirs[1], sprites_dir, "--shard", "1/3")
    assert rc == 130
    monkeypatch.undo()
    check_intact(dirs[1])
    rc, _, err = merge(*dirs, "--out", tmp_path / "early", "--no-progress")
    assert rc == 2
    one_line_error(err)
    assert "shard 1/3" in err and "incomplete" in err and "--resume" in err
    # a resume with another shard, or none, is refused
    for other in (["--shard", "0/3"], []):
        rc, _, err = gen(dirs[1], sprites_dir, *other, "--resume")
        assert rc == 2 and "--shard 1/3" in err, err
    rc, _, err = gen(dirs[1], sprites_dir, "--shard", "1/3", "--resume")
    assert rc == 0, err
    out = tmp_path / "merged"
    assert merge(*dirs, "--out", out, "--no-progress")[0] == 0
    assert_identical(plain, out)


def test_shards_with_yolo_labels_merge_to_a_plain_run(tmp_path, sprites_dir):
    small = ["--n", "7", "--format", "coco,yolo"]
    plain = tmp_path / "plain"
    assert gen(plain, sprites_dir, *small)[0] == 0
    dirs = [tmp_path / f"s{k}" for k in range(2)]
    for k, d in enumerate(dirs):
        assert gen(d, sprites_dir, *small, "--shard", f"{k}/2")[0] == 0
    out = tmp_path / "merged"
    rc, _, err = merge(*dirs, "--out", out, "--no-progress")
    assert rc == 0, err
    assert len(by_name(out / "labels")) == 7
    assert_identical(plain, out)


def test_merge_refuses_shards_of_other_runs(tmp_path, sprites_dir):
    a, b = tmp_path / "a", tmp_path / "b"
    assert gen(a, sprites_dir, "--shard", "0/2", "--n", "6")[0] == 0
    assert gen(b, sprites_dir, "--shard", "1/2", "--n", "6", "--seed", "6")[0] == 0
    rc, _, err = merge(a, b, "--out", tmp_path / "m", "--no-progress")
    assert rc == 2
    one_line_error(err)
    assert "seed" in err
    c = tmp_path / "c"
    assert gen(c, sprites_dir, "--shard", "1/3", "--n", "6")[0] == 0
    rc, _, err = merge(a, c, "--out", tmp_path / "m", "--no-progress")
    assert rc == 2 and "the same N" in err


@pytest.mark.parametrize("value", ["3/3", "x", "1/0", "-1/2", "1/2/3"])
def test_bad_shard_value(value, tmp_path, sprites_dir):
    rc, _, err = gen(tmp_path / "o", sprites_dir, f"--shard={value}")
    assert rc == 2
    one_line_error(err)
    assert "--shard" in err
    assert not (tmp_path / "o").exists()


def test_scheduler_without_dask_engine_is_refused(tmp_path, sprites_dir):
    rc, _, err = gen(tmp_path / "o", sprites_dir, "--scheduler", "tcp://127.0.0.1:1")
    assert rc == 2
    one_line_error(err)
    assert "--engine dask" in err


# --------------------------------------------------------------------------- dask

def test_dask_local_cluster_of_two_workers_equals_a_plain_run(plain, tmp_path, sprites_dir):
    pytest.importorskip("dask.distributed")
    out = tmp_path / "dask"
    rc, _, err = gen(out, sprites_dir, "--engine", "dask", workers=2)
    assert rc == 0, err
    assert_identical(plain, out)  # and OUT/.shards is gone

    # a shard task that fails (here: its folder is taken by a file) fails the run with one
    # line naming the shard; the others are kept, and --resume alone finishes the dataset
    out2 = tmp_path / "dask_fault"
    work = out2 / ".shards"
    work.mkdir(parents=True)
    (work / shard_folder(1, 4)).write_text("in the way")
    rc, _, err = gen(out2, sprites_dir, "--engine", "dask", "--resume", workers=2)
    assert rc == 2, err
    one_line_error(err)
    assert "shard 1/4 failed" in err and "--resume" in err
    done = sorted(p.name for p in work.iterdir())
    assert done == [shard_folder(k, 4) for k in range(4)]
    for k in (0, 2, 3):
        check_intact(work / shard_folder(k, 4))
    (work / shard_folder(1, 4)).unlink()
    rc, _, err = gen(out2, sprites_dir, "--engine", "dask", "--resume", workers=2)
    assert rc == 0, err
    assert_identical(plain, out2)
    # resuming a finished dataset changes nothing
    rc, _, err = gen(out2, sprites_dir, "--engine", "dask", "--resume", workers=2)
    assert rc == 0, err
    assert_identical(plain, out2)
    shutil.rmtree(out2)


def test_dask_on_an_existing_scheduler(plain, tmp_path, sprites_dir):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        out = tmp_path / "remote"
        rc, _, err = gen(out, sprites_dir, "--engine", "dask", "--scheduler",
                         cluster.scheduler_address)
        assert rc == 0, err
    assert_identical(plain, out)
