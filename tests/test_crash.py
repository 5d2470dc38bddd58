"""Crash safety of a real run: kill -9 at several moments, Ctrl-C, a worker that segfaults.
Each time, running the same command again must give the bytes of an uninterrupted run
(the session's ``tiny_dataset``: 8 tiny scenes, seed 7, 3 per shard, 2 workers)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from refspatial.executors import ProcessExecutor
from refspatial.shards import RunFailed, generate, run_shard

from conftest import TINY
from test_executors import complete_shards_only, same_files

COMMAND = ["generate", "--recipe", str(TINY), "--scenes", "8", "--seed", "7", "--scenes-per-shard", "3",
           "--workers", "2"]


def start(out: Path, command: list[str] = COMMAND) -> subprocess.Popen:
    """`refspatial generate` in its own process group, as a shell would start it in the foreground."""
    return subprocess.Popen([sys.executable, "-m", "refspatial.cli", *command, "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_sigint_as_in_a_terminal)


def _sigint_as_in_a_terminal() -> None:
    # A suite started in the background (`make test &`) inherits SIGINT ignored, and Python keeps
    # an ignored SIGINT ignored, so the Ctrl-C test would see no Ctrl-C at all.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def wait_for(proc: subprocess.Popen, ready) -> None:
    """Poll the output folder until ``ready()``; the run must still be going then."""
    stop = threading.Event()
    while not ready():
        assert proc.poll() is None, f"the run ended before the moment to stop it: {proc.stderr.read()}"
        stop.wait(0.005)


def partial_exists(out: Path) -> bool:
    return any((out / "shards").glob(".shard-*.mcap.partial"))


def sidecars(out: Path) -> int:
    return len(list((out / "shards").glob("shard-*.json")))


def rerun(out: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "refspatial.cli", *COMMAND, "--out", str(out)],
                          capture_output=True, text=True, timeout=300)


def kill_9(proc: subprocess.Popen) -> None:
    os.killpg(proc.pid, signal.SIGKILL)  # the main process and its workers, all at once
    proc.communicate()


def test_kill_9_at_any_moment_then_the_same_command_finishes_identically(tiny_dataset, tmp_path):
    out = tmp_path / "ds"
    proc = start(out)
    wait_for(proc, lambda: partial_exists(out))  # mid-shard, before any shard is complete
    kill_9(proc)
    assert sidecars(out) == 0 and partial_exists(out)
    proc = start(out)  # the same command, killed again once a shard is complete
    wait_for(proc, lambda: sidecars(out) >= 1 and partial_exists(out))
    kill_9(proc)
    survivors = {p.name: p.stat().st_mtime_ns for p in (out / "shards").glob("shard-*.mcap")
                 if p.with_suffix(".json").exists()}
    assert survivors and partial_exists(out)
    again = rerun(out)
    assert again.returncode == 0, again.stderr
    assert f"{len(survivors)} of 3 shards already complete" in again.stderr
    same_files(out, tiny_dataset)  # stale partials gone, nothing extra, every byte the same
    for name, mtime in survivors.items():  # complete shards were checked, not redone
        assert (out / "shards" / name).stat().st_mtime_ns == mtime


def test_ctrl_c_keeps_complete_shards_and_says_how_to_finish(tmp_path):
    out = tmp_path / "ds"
    # Four shards on two workers: when the first is complete at most two more are under way and
    # the fourth waits, so Ctrl-C always leaves work undone (with three, both shards still under
    # way could finish before the signal landed, and did once).
    proc = start(out, [*COMMAND[:COMMAND.index("--scenes") + 1], "12", *COMMAND[COMMAND.index("--scenes") + 2:]])
    wait_for(proc, lambda: sidecars(out) >= 1 and partial_exists(out))
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal sends the whole group
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "complete shards are kept, run the same command to finish" in err
    assert err.rstrip().splitlines()[-2].startswith("stopped: ")  # the summary, then main's line
    assert 1 <= len(complete_shards_only(out)) < 4  # and no partial file left behind


def segfault_in_shard_1(job, on_scene):
    """run_shard, but shard 1's worker dies of SIGSEGV after its first scene (mid-file)."""
    def tick(t):
        on_scene(t)
        if job.index == 1:
            os.kill(os.getpid(), signal.SIGSEGV)

    return run_shard(job, tick)


def test_a_worker_that_segfaults_costs_one_shard_and_a_rerun_finishes(tiny_dataset, tiny, catalogue, tmp_path):
    out = tmp_path / "ds"
    with pytest.raises(RunFailed) as failed:
        generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3,
                 executor=ProcessExecutor(2, segfault_in_shard_1))
    message = str(failed.value)
    assert message.startswith("shard-00001 (scenes 3-6) failed: its worker process died (SIGSEGV")
    assert "2 of 3 shards are complete" in message and message.endswith("run the same command again to finish")
    assert complete_shards_only(out) == ["shard-00000", "shard-00002"]
    assert not (out / "manifest.json").exists()
    generate(out, tiny, catalogue, n_scenes=8, base_seed=7, scenes_per_shard=3, workers=2)
    same_files(out, tiny_dataset)
