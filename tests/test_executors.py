"""Executors: every shard comes back exactly once, a dying worker costs only its own shard,
closing a run stops its workers, and Ray writes the same bytes as local workers."""

from __future__ import annotations

import errno
import json
import os
import signal
import sys
import threading
from pathlib import Path

import pytest

from refspatial.executors import InlineExecutor, ProcessExecutor, RayExecutor, choose_executor, exit_text
from refspatial.records import sha256_file
from refspatial.run_errors import RunError
from refspatial.shard_job import SceneTick, ShardJob
from refspatial.shards import generate

# Worker processes import this module to unpickle the shard functions below: keep its
# imports light (no conftest, which loads the asset catalogue) so that workers start fast.


class Recorder:
    """A Progress that remembers what it was told."""

    def __init__(self) -> None:
        self.ticks: list[SceneTick] = []
        self.shards: list[str] = []
        self.failures: list[tuple[str, str]] = []

    def start(self, *counts: int) -> None:
        self.counts = counts

    def scene(self, tick: SceneTick) -> None:
        self.ticks.append(tick)

    def shard(self, summary: dict) -> None:
        self.shards.append(summary["file"])

    def failed(self, name: str, reason: str) -> None:
        self.failures.append((name, reason))

    def close(self) -> None:
        pass


def same_files(a: Path, b: Path) -> None:
    """Every file of dataset ``a`` equals ``b``'s, byte for byte, and neither has extras.
    Shards are compared first, and a shard that differs is named down to its first differing
    record and field: a rare difference is then a finding, not a mystery."""
    names = sorted(str(p.relative_to(a)) for p in a.rglob("*") if p.is_file())
    assert names == sorted(str(p.relative_to(b)) for p in b.rglob("*") if p.is_file())
    for name in sorted(names, key=lambda n: not n.endswith(".mcap")):
        if (a / name).read_bytes() != (b / name).read_bytes():
            raise AssertionError(f"{name} differs: {first_difference(a / name, b / name)}")


def first_difference(a: Path, b: Path) -> str:
    """Where two shards' records first differ (record index, key, field), or why they cannot be read."""
    if a.suffix != ".mcap":
        return "not a shard"
    import numpy as np

    from refspatial.records import ShardReader

    ra, rb = ShardReader(a), ShardReader(b)
    if len(ra) != len(rb):
        return f"{len(ra)} records against {len(rb)}"
    for i in range(len(ra)):
        x, y = ra.read(i), rb.read(i)
        for field in sorted(set(x) | set(y)):
            u, v = x.get(field), y.get(field)
            same = np.array_equal(u, v) if isinstance(u, np.ndarray) else json.dumps(u, sort_keys=True, default=str) == \
                json.dumps(v, sort_keys=True, default=str)
            if not same:
                return f"record {i} ({x.get('key')}) field {field!r}"
    return "same records, different bytes"


def complete_shards_only(out: Path) -> list[str]:
    """Names of the shards on disk, after checking each against its sidecar checksum."""
    assert not list(out.rglob("*.partial")), "stale partial files"
    names = []
    for mcap in sorted((out / "shards").glob("*.mcap")):
        side = json.loads(mcap.with_suffix(".json").read_text())
        assert side["sha256"] == sha256_file(mcap), mcap
        names.append(mcap.stem)
    return names


def fake_shard(job: ShardJob, on_scene) -> dict:
    """Makes no scenes: one tick per scene index, then a summary naming the worker."""
    for i in range(job.start, job.stop):
        if on_scene:
            on_scene(SceneTick(job.index, i, 1, 2, None))
    return {"index": job.index, "pid": os.getpid()}


def crashing_shard(job: ShardJob, on_scene) -> dict:
    """Shard 1 exits, 2 segfaults, 3 meets a full disk, 4 raises; the others succeed."""
    if job.index == 1:
        os._exit(3)
    if job.index == 2:
        os.kill(os.getpid(), signal.SIGSEGV)
    if job.index == 3:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), "/full/.shard-00003.mcap.partial")
    if job.index == 4:
        raise ValueError("bad\n  value")
    return fake_shard(job, on_scene)


def blocking_shard(job: ShardJob, on_scene) -> dict:
    """Shard 0 writes its pid to a file, then never ends; shard 1 ends once that file exists."""
    flag = job.out_dir / "blocked.pid"
    if job.index == 0:
        flag.write_text(str(os.getpid()))
        threading.Event().wait()
    while not flag.exists():
        threading.Event().wait(0.01)
    return fake_shard(job, on_scene)


def jobs(n: int, tmp_path: Path) -> list[ShardJob]:
    return [ShardJob(i, 2 * i, 2 * i + 2, tmp_path, None, None, 0) for i in range(n)]  # type: ignore[arg-type]


def run_all(executor, todo, ticks=None) -> list:
    """All results, or a failure (not a hung test run) if the executor never finishes."""
    out: list = []
    t = threading.Thread(target=lambda: out.extend(executor.run(todo, ticks.append if ticks is not None else None)))
    t.start()
    t.join(120)
    assert not t.is_alive(), "the executor hung"
    return out


def test_worker_processes_return_every_shard_once_with_its_scene_ticks(tmp_path):
    ticks: list[SceneTick] = []
    results = run_all(ProcessExecutor(2, fake_shard), jobs(5, tmp_path), ticks)
    assert sorted(r.job.index for r in results) == [0, 1, 2, 3, 4]
    assert all(r.error is None and r.summary["index"] == r.job.index for r in results)
    pids = {r.summary["pid"] for r in results}
    assert len(pids) == 2 and os.getpid() not in pids
    assert sorted((t.shard, t.index) for t in ticks) == [(i // 2, i) for i in range(10)]


def test_a_dying_worker_loses_only_its_own_shard(tmp_path):
    results = {r.job.index: r for r in run_all(ProcessExecutor(2, crashing_shard), jobs(7, tmp_path))}
    assert sorted(results) == list(range(7))
    assert sorted(i for i, r in results.items() if r.summary is not None) == [0, 5, 6]
    assert results[1].error == "its worker process died (exit code 3)"
    assert "SIGSEGV" in results[2].error and "native code" in results[2].error
    assert results[3].errno == errno.ENOSPC and "No space left on device" in results[3].error
    assert results[4].error == "ValueError: bad value" and results[4].errno is None


def test_inline_executor_reports_exceptions_per_shard(tmp_path):
    todo = [j for j in jobs(6, tmp_path) if j.index not in (1, 2)]  # those would end pytest itself
    results = list(InlineExecutor(crashing_shard).run(todo))
    assert [r.job.index for r in results] == [0, 3, 4, 5]
    assert [r.summary is None for r in results] == [False, True, True, False]
    assert results[1].errno == errno.ENOSPC


def test_closing_the_run_stops_busy_workers(tmp_path):
    run = ProcessExecutor(2, blocking_shard).run(jobs(2, tmp_path))
    first = next(run)  # shard 1, while shard 0 blocks forever
    assert first.job.index == 1 and first.summary is not None
    blocked = int((tmp_path / "blocked.pid").read_text())
    os.kill(blocked, 0)  # alive until the run is closed
    run.close()
    with pytest.raises(ProcessLookupError):
        os.kill(blocked, 0)  # stopped and reaped


def test_exit_codes_in_words():
    assert exit_text(3) == "exit code 3"
    assert exit_text(-signal.SIGKILL).startswith("SIGKILL: killed, often by the kernel for lack of memory")
    assert exit_text(-signal.SIGTERM) == "SIGTERM"


def test_executor_flags_that_do_not_fit_are_refused():
    with pytest.raises(RunError, match="need --executor ray"):
        choose_executor("local", "head:6379", 2, 0.0)
    with pytest.raises(RunError, match="need --executor ray"):
        choose_executor("local", None, 2, 0.5)
    with pytest.raises(RunError, match=">= 0"):
        choose_executor("ray", None, 2, -1.0)
    assert choose_executor("local", None, 2, 0.0) is None


def test_ray_task_environment():
    assert RayExecutor().env_vars() == {"LP_NUM_THREADS": "1"}
    assert RayExecutor(gpus_per_task=0.25).env_vars()["MUJOCO_GL"] == "egl"


def env_probe(job: ShardJob, on_scene) -> dict:
    """What a Ray task sees of its environment."""
    return {k: os.environ.get(k) for k in ("MUJOCO_GL", "LP_NUM_THREADS", "CUDA_VISIBLE_DEVICES")}


def test_ray_writes_the_same_bytes_as_the_local_executor(tiny, catalogue, tmp_path, monkeypatch):
    ray = pytest.importorskip("ray", reason="the ray extra is not installed: pip install -e '.[ray]'")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    generate(tmp_path / "local", tiny, catalogue, n_scenes=4, base_seed=3, workers=1, scenes_per_shard=2)
    ray.init(num_cpus=2, num_gpus=1, include_dashboard=False)  # one pretend GPU, for scheduling only
    try:
        recorder = Recorder()
        generate(tmp_path / "ray", tiny, catalogue, n_scenes=4, base_seed=3, scenes_per_shard=2,
                 progress=recorder, executor=RayExecutor())
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray workers lack tests/ on sys.path
        gpu = list(RayExecutor(gpus_per_task=0.5, shard_fn=env_probe).run(jobs(2, tmp_path)))
        with pytest.raises(RunError, match="asks for more GPU than any node of the Ray cluster has \\(1\\)"):
            list(RayExecutor(gpus_per_task=2, shard_fn=env_probe).run(jobs(2, tmp_path)))  # a hang, were it not caught
    finally:
        ray.shutdown()
    same_files(tmp_path / "ray", tmp_path / "local")
    assert sorted(t.index for t in recorder.ticks) == list(range(4)), "per-scene ticks came through Ray"
    assert [r.summary for r in gpu] == [{"MUJOCO_GL": "egl", "LP_NUM_THREADS": "1", "CUDA_VISIBLE_DEVICES": "0"}] * 2


def _imported_modules(path: Path) -> set[str]:
    """Every refspatial module ``path`` imports, at the top, inside functions or for type checking."""
    import ast

    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            names.add(node.module or "")
    return names


def test_the_run_depends_on_executors_and_never_the_other_way():
    package = Path(__file__).parent.parent / "refspatial"
    for module in ("executors.py", "shard_job.py", "run_errors.py"):
        assert "shards" not in _imported_modules(package / module), module
    assert "executors" in _imported_modules(package / "shards.py")


def test_a_ray_address_nothing_answers_at_is_one_line_not_a_hang():
    """Ray retries an unreachable head for minutes, silently (README user: 11 minutes)."""
    import socket

    from refspatial.executors import _connect

    ray = pytest.importorskip("ray", reason="the ray extra is not installed: pip install -e '.[ray]'")
    with socket.socket() as s:  # a port that was free a moment ago: nothing listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(RunError, match=rf"cannot reach the Ray cluster at 127.0.0.1:{port} \(") as refused:
        _connect(ray, f"127.0.0.1:{port}", None)
    assert "\n" not in str(refused.value) and not ray.is_initialized()
