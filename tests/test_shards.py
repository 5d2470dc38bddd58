"""Shards: the plan, identical bytes whatever the completion order, failed scenes kept as
skipped, a full or read-only disk stopping the run cleanly, resume checks, progress text."""

from __future__ import annotations

import errno
import fcntl
import io
import os
import re
import shutil
import subprocess
from functools import partial
from pathlib import Path

import pytest

from refspatial.cli import main
from refspatial.executors import InlineExecutor, ProcessExecutor
from refspatial.progress import RunProgress
from refspatial.records import ShardWriter
from refspatial.seeding import scene_seed
from refspatial.shards import RunError, RunFailed, SceneTick, generate, plan, run_shard

from conftest import TINY
from test_executors import Recorder, complete_shards_only, same_files


class ReversedExecutor(ProcessExecutor):
    """Two workers, whose results are handed over in the opposite order of the plan."""

    def run(self, jobs, on_scene=None):
        return iter(sorted(super().run(jobs, on_scene), key=lambda r: -r.job.index))


@pytest.mark.parametrize("n", [0, 1, 5, 6, 7, 25])
@pytest.mark.parametrize("per_shard", [1, 3, 6])
def test_plan_covers_every_scene_once_in_order(n, per_shard):
    ranges = plan(n, per_shard)
    assert [i for a, b in ranges for i in range(a, b)] == list(range(n))
    assert all(0 < b - a <= per_shard for a, b in ranges)


def test_completion_order_does_not_change_a_byte(tiny_dataset, tiny, catalogue, tmp_path):
    out, recorder = tmp_path / "reversed", Recorder()
    generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3, progress=recorder,
             executor=ReversedExecutor(2))
    assert recorder.shards == ["shards/shard-00002.mcap", "shards/shard-00001.mcap", "shards/shard-00000.mcap"]
    same_files(out, tiny_dataset)  # made by two workers in plan order


def test_a_scene_that_raises_is_skipped_with_its_reason(tiny, catalogue, tmp_path, monkeypatch):
    import refspatial.pipeline as pipeline

    real, bad = pipeline.generate_scene, scene_seed(7, 1)

    def flaky(recipe, cat, seed):
        if seed == bad:
            raise RuntimeError("renderer\n lost its context")
        return real(recipe, cat, seed)

    monkeypatch.setattr(pipeline, "generate_scene", flaky)
    m = generate(tmp_path / "ds", tiny, catalogue, n_scenes=2, base_seed=7, scenes_per_shard=2)
    assert m["rejected"]["reasons"] == {"error": 1} and m["records"] > 0  # scene 0 went on
    assert m["rejected"]["scenes"] == [{"index": 1, "seed": bad, "reason": "error",
                                        "detail": "RuntimeError: renderer lost its context"}]


def test_a_shard_runs_with_rarer_collections_and_restores_the_collector(tiny, catalogue, tmp_path,
                                                                       monkeypatch):
    import gc

    import refspatial.pipeline as pipeline
    from refspatial.shard_job import FULL_PASS_EVERY, YOUNG_PASS_AFTER, ShardJob

    seen = []

    def record_threshold(recipe, cat, seed):
        seen.append((gc.get_threshold(), gc.get_freeze_count() > 0))
        raise RuntimeError("no scene needed")

    monkeypatch.setattr(pipeline, "generate_scene", record_threshold)
    gc.unfreeze()
    before = gc.get_threshold()
    (tmp_path / "shards").mkdir()
    summary = run_shard(ShardJob(0, 0, 2, tmp_path, tiny, catalogue, base_seed=7))
    assert len(summary["skipped"]) == 2
    # The heap held before the shard is frozen while it runs, and thawed after.
    assert seen == [((YOUNG_PASS_AFTER, before[1], FULL_PASS_EVERY), True)] * 2
    assert gc.get_threshold() == before and gc.get_freeze_count() == 0
    # A heap frozen by the caller stays frozen. Asked of one object, not of the count: a frozen
    # object that dies leaves the frozen generation (the count fell by 2 in one CI run).
    held = [object()]
    gc.freeze()
    try:
        assert not any(o is held for o in gc.get_objects())  # the collector's generations skip frozen objects
        run_shard(ShardJob(0, 0, 2, tmp_path, tiny, catalogue, base_seed=7))
        assert not any(o is held for o in gc.get_objects())
    finally:
        gc.unfreeze()
    assert any(o is held for o in gc.get_objects())

    def interrupt(tick):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):  # a shard cut short restores it too
        run_shard(ShardJob(1, 0, 2, tmp_path, tiny, catalogue, base_seed=7), interrupt)
    assert gc.get_threshold() == before and gc.get_freeze_count() == 0


class FullDisk(ShardWriter):
    """A writer whose disk is full when shard 1 writes its first record."""

    def write(self, record):
        if "shard-00001" in self.path.name:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.partial_path))
        return super().write(record)


def test_a_full_disk_stops_the_run_and_a_rerun_finishes_it(tiny_dataset, tiny, catalogue, tmp_path):
    out, recorder = tmp_path / "ds", Recorder()
    full = InlineExecutor(partial(run_shard, open_writer=FullDisk))
    with pytest.raises(RunFailed) as failed:
        generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3, progress=recorder, executor=full)
    message = str(failed.value)
    assert "\n" not in message and "shard-00001 (scenes 3-6) failed" in message
    assert "No space left on device" in message and "free space" in message
    assert message.endswith("run the same command again to finish")
    assert complete_shards_only(out) == ["shard-00000"]  # stopped at once: shard 2 never started
    assert not (out / "manifest.json").exists() and recorder.failures[0][0] == "shard-00001"
    generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3, workers=2)
    same_files(out, tiny_dataset)


@pytest.fixture
def tmpfs(tmp_path):
    """mount(size): a tmpfs of that size; skipped where mounting is not allowed (not root)."""
    mounted = []

    def mount(size: str) -> Path:
        where = tmp_path / f"tmpfs-{len(mounted)}"
        where.mkdir()
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                           capture_output=True, text=True)
        if r.returncode:
            pytest.skip(f"cannot mount a tmpfs here ({r.stderr.strip() or 'not root'})")
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], check=True)


def test_a_really_full_disk_exits_1_with_one_line(tmpfs, capsys):
    small = tmpfs("100k")  # less than the whole dataset: the run must stop on ENOSPC
    code = main(["generate", "--scenes", "9", "--scenes-per-shard", "3", "--recipe", str(TINY), "--seed", "7",
                 "--out", str(small / "ds"), "--workers", "1", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 1 and err.count("\n") == 0, err
    assert "No space left on device" in err and err.endswith("run the same command again to finish")
    assert len(complete_shards_only(small / "ds")) < 3


def test_a_disk_turned_read_only_mid_run_stops_it(tmpfs, tiny, catalogue):
    disk = tmpfs("4m")

    class RemountAfterFirstShard(Recorder):
        def shard(self, summary):
            super().shard(summary)
            subprocess.run(["mount", "-o", "remount,ro", str(disk)], check=True)

    with pytest.raises(RunFailed, match="Read-only file system"):
        generate(disk / "ds", tiny, catalogue, n_scenes=4, base_seed=7, scenes_per_shard=2,
                 progress=RemountAfterFirstShard())
    assert complete_shards_only(disk / "ds") == ["shard-00000"]


def test_stale_partials_and_torn_sidecars_are_cleaned_and_redone(tiny_dataset, tiny, catalogue, tmp_path):
    out = tmp_path / "killed"
    shutil.copytree(tiny_dataset, out)
    (out / "manifest.json").unlink()  # the run was killed before the end
    (out / "shards" / ".shard-00001.mcap.partial").write_bytes(b"\x89MCAP0\r\n torn")
    (out / ".manifest.json.partial").write_text("{")
    (out / "shards" / "shard-00002.json").write_text('{"scenes": [6,')  # torn sidecar: redo shard 2
    kept = (out / "shards" / "shard-00000.mcap").stat().st_mtime_ns
    recorder = Recorder()
    generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3, progress=recorder)
    assert recorder.shards == ["shards/shard-00002.mcap"]
    assert (out / "shards" / "shard-00000.mcap").stat().st_mtime_ns == kept
    same_files(out, tiny_dataset)


def test_an_unfinished_run_of_another_seed_or_shard_size_is_refused(tiny_dataset, tiny, catalogue, tmp_path):
    out = tmp_path / "unfinished"
    shutil.copytree(tiny_dataset, out)
    (out / "manifest.json").unlink()  # only the sidecars say what made the shards
    with pytest.raises(RunError, match=r"shard-00000.json says its shard was made with --seed 7, not --seed 8; "):
        generate(out, tiny, catalogue, n_scenes=8, base_seed=8, scenes_per_shard=3)
    with pytest.raises(RunError, match="made with --scenes-per-shard 3, not --scenes-per-shard 4; .* or "
                                       "--scenes-per-shard 3 to extend or resume it"):
        generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=4)


def test_a_run_of_another_recipe_names_both_recipes_not_the_whole_manifest(tiny_dataset, catalogue, tmp_path):
    from refspatial.recipe import load_recipe

    out = tmp_path / "theirs"
    shutil.copytree(tiny_dataset, out)
    other = tmp_path / "other.yaml"
    other.write_text(f"extends: {TINY}\nname: other\n")
    renamed = tmp_path / "renamed.yaml"  # the same name, other content: only the hashes tell
    renamed.write_text(f"extends: {TINY}\nname: tiny\nquestions: {{per_view: 5}}\n")
    for recipe, needle in ((other, "made with recipe tiny, not other; "), (renamed, "made with recipe hash ")):
        with pytest.raises(RunError) as refused:
            generate(out, load_recipe(str(recipe)), catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3)
        message = str(refused.value)
        assert needle in message and "\n" not in message and len(message) < 400, message


@pytest.mark.parametrize("n_scenes", [2, 5, 7])
def test_shrinking_a_run_is_refused_and_keeps_every_shard(tiny_dataset, tiny, catalogue, tmp_path, n_scenes):
    out = tmp_path / "shrink"
    shutil.copytree(tiny_dataset, out)
    with pytest.raises(RunError, match=f"holds 8 scenes, more than --scenes {n_scenes}; pass --scenes 8 "):
        generate(out, tiny, catalogue, n_scenes=n_scenes, base_seed=7, scenes_per_shard=3)
    same_files(out, tiny_dataset)
    (out / "manifest.json").unlink()  # an unfinished run: its sidecars tell the same
    with pytest.raises(RunError, match="holds 8 scenes"):
        generate(out, tiny, catalogue, n_scenes=n_scenes, base_seed=7, scenes_per_shard=3)


def test_two_runs_into_one_folder_are_refused(tiny, catalogue, tmp_path):
    out = tmp_path / "busy"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # as a running `refspatial generate` holds it
        with pytest.raises(RunError, match="another `refspatial generate` is writing"):
            generate(out, tiny, catalogue, n_scenes=1, base_seed=7)
    finally:
        os.close(fd)


def test_dry_run_prints_plan_and_calibrated_estimates_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["generate", "--dry-run", "--scenes", "10", "--scenes-per-shard", "4", "--recipe", str(TINY),
                 "--out", str(out), "--workers", "1", "--calibrate", "2"]) == 0
    text = capsys.readouterr().out
    assert "plan: 10 scenes of recipe tiny (seed 0) in 3 shards" in text
    assert "to do: 3 shards, 10 scenes, 1 in parallel" in text
    assert "expect: ~" in text and "estimate source: calibration, 2 scenes" in text
    assert not out.exists()


def test_dry_run_counts_what_is_already_on_disk(tiny_dataset, capsys):
    assert main(["generate", "--dry-run", "--scenes", "8", "--scenes-per-shard", "3", "--seed", "7",
                 "--recipe", str(TINY), "--out", str(tiny_dataset), "--calibrate", "0"]) == 0
    text = capsys.readouterr().out
    assert "on disk: 3 complete shards (8 scenes); to do: 0 shards, 0 scenes" in text
    assert "estimate: none" in text


class Clock:
    def __init__(self, step: float) -> None:
        self.t, self.step = 0.0, step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


def summary(index: int, a: int, b: int, skipped: int = 0) -> dict:
    return {"file": f"shards/shard-{index:05d}.mcap", "scenes": [a, b], "records": b - a - skipped,
            "qa": 5 * (b - a - skipped), "skipped": [{"reason": "crowded"}] * skipped}


def test_progress_without_a_terminal_is_one_line_per_shard_then_a_summary():
    stream = io.StringIO()
    p = RunProgress(stream, tty=False, clock=Clock(1.0))
    p.start(6, 0, 3, 0)
    for i in range(3):
        p.scene(SceneTick(0, i, 1, 5, None))
    p.shard(summary(0, 0, 3))
    p.shard(summary(1, 3, 6, skipped=1))  # no ticks (an executor without them): credited here
    p.failed("shard-00002", "its worker process died (SIGSEGV)")
    p.close(finished=False)
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue() and len(lines) == 4
    assert lines[0].startswith("shard-00000: 3 scenes, 3 records, 15 QA, 0 skipped | 3/6 scenes, 1/3 shards")
    assert "scenes/s" in lines[0] and "QA/s" in lines[0] and "ETA" in lines[0]
    assert lines[1].startswith("shard-00001: 3 scenes, 2 records, 10 QA, 1 skipped | 6/6 scenes")
    assert lines[2] == "shard-00002 FAILED: its worker process died (SIGSEGV)"
    assert lines[3].startswith("stopped: 6 scenes (1 crowded skipped), 5 records, 25 QA in ")


def test_progress_on_a_terminal_redraws_one_bar_as_scenes_finish():
    stream = io.StringIO()
    p = RunProgress(stream, tty=True, clock=Clock(0.1), redraw_s=0.25)
    p.start(100, 40, 4, 2)
    for i in range(10):
        p.scene(SceneTick(2, 40 + i, 1, 3, "error" if i == 0 else None))
    p.close()
    text = stream.getvalue()
    assert text.startswith("2 of 4 shards already complete (40 scenes); doing the rest\n")
    counts = [int(n) for n in re.findall(r"\r\[[#.]+\] (\d+)/100 scenes", text)]
    assert 2 <= len(counts) < 10, "redrawn as scenes finish, but not for every one"
    assert counts == sorted(counts) and 40 < counts[-1] <= 50 and "ETA" in text
    assert "\r\x1b[Kdone: 10 scenes (1 error skipped)" in text and "40 scenes were already on disk" in text
    assert text.rstrip("\n").splitlines()[-1].startswith("warning: 1 scene raised an error")


def test_progress_counts_one_of_a_thing_in_the_singular_and_a_run_never_started_says_nothing():
    stream = io.StringIO()
    RunProgress(stream, tty=False, clock=Clock(1.0)).close(finished=False)  # refused before it started
    assert stream.getvalue() == ""
    p = RunProgress(stream, tty=False, clock=Clock(1.0))
    p.start(3, 1, 3, 1)
    p.shard(summary(1, 1, 2))
    p.scene(SceneTick(2, 2, 0, 0, "error"))
    p.shard(summary(2, 2, 3, skipped=1))
    p.close()
    lines = stream.getvalue().splitlines()
    assert lines[0] == "1 of 3 shards already complete (1 scene); doing the rest"
    assert lines[1].startswith("shard-00001: 1 scene, 1 record, 5 QA, 0 skipped")
    assert lines[3].startswith("done: 2 scenes (1 error skipped), 1 record, 5 QA in ")
    assert lines[3].endswith("; 1 scene was already on disk")
    assert lines[4].startswith("warning: 1 scene raised an error;")
