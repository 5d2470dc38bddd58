"""Where shards run: this process, local worker processes, or a Ray cluster.

Every executor has one method, ``run(jobs, on_scene) -> iterator of ShardResult``, yielding
each shard as it finishes, in any order: ``generate`` assembles the manifest in plan order,
so the bytes never depend on the executor. A shard that fails (an exception, a worker
killed by a segfault or the OOM killer) comes back as a ShardResult with an error, never
as a hang and never as the loss of another worker's shard. That is why the local pool is
our own: each worker owns a pipe and a process sentinel, so the parent knows at once which
worker, and so which shard, died. (``multiprocessing.Pool`` hangs when a worker dies;
``ProcessPoolExecutor`` breaks the whole pool and cannot say which task killed it.)
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import signal
import socket
import threading
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator, Protocol, Sequence

from .run_errors import RunError
from .shard_job import OnScene, SceneTick, ShardJob, one_line, run_shard

ShardFn = Callable[[ShardJob, "OnScene | None"], dict]
RAY_EXTRA = "pip install -e '.[ray]' in the refspatial checkout"


@dataclass(frozen=True)
class ShardResult:
    job: ShardJob
    summary: dict | None = None  # run_shard's summary when the shard is on disk
    error: str | None = None  # one line, when it is not
    errno: int | None = None  # of an OSError, so that generate() can stop on a full disk


class Executor(Protocol):
    def run(self, jobs: Sequence[ShardJob], on_scene: OnScene | None = None) -> Iterator[ShardResult]:
        """Yield one result per job as each finishes; closing the iterator stops all work."""
        ...


def attempt(shard_fn: ShardFn, job: ShardJob, on_scene: OnScene | None) -> ShardResult:
    """Run one shard; its exception becomes the result's error."""
    try:
        return ShardResult(job, summary=shard_fn(job, on_scene))
    except Exception as exc:  # noqa: BLE001 - reported per shard, the run goes on
        return ShardResult(job, error=one_line(exc), errno=exc.errno if isinstance(exc, OSError) else None)


def local_executor(workers: int, shard_fn: ShardFn = run_shard) -> Executor:
    """This process for one worker (no start-up cost), worker processes otherwise."""
    return InlineExecutor(shard_fn) if workers == 1 else ProcessExecutor(workers, shard_fn)


@dataclass(frozen=True)
class InlineExecutor:
    """Shards one after another in this process."""

    shard_fn: ShardFn = run_shard

    def run(self, jobs: Sequence[ShardJob], on_scene: OnScene | None = None) -> Iterator[ShardResult]:
        for job in jobs:
            yield attempt(self.shard_fn, job, on_scene)


@dataclass(frozen=True)
class ProcessExecutor:
    """``workers`` spawned processes, each rendering single-threaded (two processes with
    LP_NUM_THREADS=1 beat one with two rasteriser threads; see platform.md). A dead worker
    is replaced, so the remaining shards still run."""

    workers: int
    shard_fn: ShardFn = run_shard

    def run(self, jobs: Sequence[ShardJob], on_scene: OnScene | None = None) -> Iterator[ShardResult]:
        pending, pool = deque(jobs), []
        ctx = mp.get_context("spawn")  # GL contexts do not survive fork
        try:
            while pending or any(w.job is not None for w in pool):
                pool = [w for w in pool if not w.dead]
                self._fill(ctx, pool, pending)
                busy = [w for w in pool if w.job is not None]
                if not busy:
                    continue  # every idle worker had died: start fresh ones
                ready = set(wait([h for w in busy for h in (w.conn, w.process.sentinel)]))
                for w in busy:
                    if ready & {w.conn, w.process.sentinel}:
                        result = w.collect(on_scene, w.process.sentinel in ready)
                        if result is not None:
                            yield result
        finally:
            for w in pool:
                w.stop()

    def _fill(self, ctx: Any, pool: list[_Worker], pending: deque[ShardJob]) -> None:
        """Start workers for waiting jobs (at most ``workers``) and hand each idle one a job."""
        idle = [w for w in pool if w.job is None]
        while len(pending) > len(idle) and len(pool) < self.workers:
            pool.append(_Worker(ctx, self.shard_fn))
            idle.append(pool[-1])
        for w in idle:
            if pending and w.give(pending[0]):  # a worker that died while idle keeps no job
                pending.popleft()


@dataclass(eq=False)
class _Worker:
    """One worker process, its end of the pipe and the shard it holds."""

    ctx: Any
    shard_fn: ShardFn
    job: ShardJob | None = None
    dead: bool = False
    conn: Connection = field(init=False)
    process: Any = field(init=False)

    def __post_init__(self) -> None:
        self.conn, child = self.ctx.Pipe()
        self.process = self.ctx.Process(target=_worker_main, args=(child, self.shard_fn, os.getpid()),
                                        daemon=True, name="refspatial-worker")
        self.process.start()
        child.close()

    def give(self, job: ShardJob) -> bool:
        """Send a job; False when this (idle) worker turns out to be dead."""
        try:
            self.conn.send(job)
        except OSError:
            self.stop()
            return False
        self.job = job
        return True

    def collect(self, on_scene: OnScene | None, exited: bool) -> ShardResult | None:
        """Pass on scene ticks; the result once the shard ended or the worker died."""
        try:
            while self.conn.poll():
                kind, payload = self.conn.recv()
                if kind == "result":
                    self.job = None
                    if exited:  # sent its result, then died: replace it
                        self.stop()
                    return payload
                if on_scene is not None:
                    on_scene(payload)
        except (EOFError, OSError):
            exited = True  # the pipe closed: the process is gone or going
        return self._died() if exited else None

    def _died(self) -> ShardResult:
        self.process.join(timeout=10)
        if self.process.is_alive():  # closed its pipe but hangs on exit
            self.process.kill()
            self.process.join()
        job, self.job, self.dead = self.job, None, True
        self.conn.close()
        return ShardResult(job, error=f"its worker process died ({exit_text(self.process.exitcode)})")

    def stop(self) -> None:
        """Ask an idle worker to leave; stop a busy one (its partial file is removed by generate)."""
        if self.dead:
            return
        try:
            if self.job is None:
                self.conn.send(None)
        except OSError:
            pass
        self.process.join(timeout=5 if self.job is None else 0)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()
        self.dead = True


def exit_text(code: int | None) -> str:
    """A process exit code in words, with the usual cause of a fatal signal."""
    if code is None or code >= 0:
        return f"exit code {code}"
    name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else f"signal {-code}"
    hint = {"SIGKILL": ": killed, often by the kernel for lack of memory",
            "SIGSEGV": ": a crash in native code (renderer or physics)"}.get(name, "")
    return f"{name}{hint}"


def _worker_main(conn: Connection, shard_fn: ShardFn, parent: int) -> None:
    """Receive jobs, send scene ticks and one result per job, until told to stop."""
    _die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group; the parent decides
    os.environ["LP_NUM_THREADS"] = "1"  # read by Mesa when the first GL context is made, later

    def tick(t: SceneTick) -> None:
        conn.send(("scene", t))

    try:
        while (job := conn.recv()) is not None:
            conn.send(("result", attempt(shard_fn, job, tick)))
    except (EOFError, OSError):
        pass  # the parent is gone: nobody is left to tell


def _die_with_parent(parent: int) -> None:
    """An orphan must not go on writing into a folder a re-run may already own (Linux)."""
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # not Linux: an orphan stops at its next scene, when its pipe write fails
    if os.getppid() != parent:
        os._exit(1)


@dataclass(frozen=True)
class RayExecutor:
    """Each shard is one Ray task, ``shard_fn(job)``, on any node with a free CPU (and GPU
    share). Tasks write straight into the output folder, which must be one every node
    mounts at the same path; generate() checks each shard's checksum from the driver."""

    address: str | None = None  # None: RAY_ADDRESS, else a Ray instance started here
    num_cpus: int | None = None  # CPUs of a Ray instance started here
    gpus_per_task: float = 0.0
    shard_fn: ShardFn = run_shard
    max_retries: int = 2  # a shard whose node died is redone elsewhere: same seeds, same bytes

    def env_vars(self) -> dict[str, str]:
        """The task's environment: single-threaded CPU rendering, or EGL on the GPU Ray
        assigned (MuJoCo orders EGL devices by the CUDA_VISIBLE_DEVICES Ray sets)."""
        env = {"LP_NUM_THREADS": "1"}
        if self.gpus_per_task > 0:
            env |= {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}
        return env

    def run(self, jobs: Sequence[ShardJob], on_scene: OnScene | None = None) -> Iterator[ShardResult]:
        if not jobs:
            return
        ray = import_ray()
        started = _connect(ray, self.address, self.num_cpus)
        try:
            self._check_gpus(ray)
            yield from self._run(ray, jobs, on_scene)
        finally:
            if started:
                ray.shutdown()

    def _check_gpus(self, ray: Any) -> None:
        """Ray queues a task no node can hold and waits for ever: a GPU share on a cluster
        without one is a hang, not an error, unless it is caught here."""
        if self.gpus_per_task <= 0:
            return
        most = max((n.get("Resources", {}).get("GPU", 0.0) for n in ray.nodes() if n.get("Alive")), default=0.0)
        if most < self.gpus_per_task:
            raise RunError(f"--gpus-per-task {self.gpus_per_task:g} asks for more GPU than any node of the Ray "
                           f"cluster has ({most:g}); drop --gpus-per-task to render on CPUs, or add GPU nodes")

    def _run(self, ray: Any, jobs: Sequence[ShardJob], on_scene: OnScene | None) -> Iterator[ShardResult]:
        from ray.util.queue import Queue

        queue = Queue(actor_options={"num_cpus": 0}) if on_scene else None
        # MuJoCo binds a process to one EGL device for good: on GPUs a fresh worker per shard
        # renders on the GPU Ray assigned to that shard, not on the first one it ever had.
        remote = ray.remote(max_calls=1)(_ray_task) if self.gpus_per_task > 0 else ray.remote(_ray_task)
        task = remote.options(num_cpus=1, num_gpus=self.gpus_per_task, max_retries=self.max_retries,
                              retry_exceptions=False, runtime_env={"env_vars": self.env_vars()})
        running = {task.remote(self.shard_fn, job, queue): job for job in jobs}
        try:
            while running:
                ready, _ = ray.wait(list(running), num_returns=len(running), timeout=0.25)
                _drain(queue, on_scene)
                for ref in ready:
                    yield _ray_result(ray, ref, running.pop(ref))
        finally:
            for ref in running:
                ray.cancel(ref, force=True)
            if queue is not None:
                queue.shutdown()


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (a scheduler, ``kill``) stops a run the way Ctrl-C does: workers stopped,
    partial files removed, complete shards kept. Only the main thread may set handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def choose_executor(kind: str, address: str | None, workers: int, gpus_per_task: float) -> Executor | None:
    """The executor ``refspatial generate`` flags ask for; None is generate()'s local default."""
    if gpus_per_task < 0:
        raise RunError(f"--gpus-per-task must be >= 0, got {gpus_per_task}")
    if kind == "local":
        if address or gpus_per_task:
            raise RunError("--address and --gpus-per-task need --executor ray; local workers render "
                           "through MUJOCO_GL (set MUJOCO_GL=egl on a GPU machine)")
        return None
    import_ray()  # fail before any work when Ray is missing
    return RayExecutor(address, workers, gpus_per_task)


def import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise RunError(f"--executor ray needs Ray on this machine and every node: {RAY_EXTRA}") from None
    return ray


def _connect(ray: Any, address: str | None, num_cpus: int | None) -> bool:
    """Join the cluster (or start a local instance); True when this call started Ray."""
    if ray.is_initialized():
        return False
    if address is None and not os.environ.get("RAY_ADDRESS"):
        os.environ.setdefault("RAY_AUTH_MODE", "disabled")  # a throw-away local instance
        # "local": a new instance even when `ray start --head` runs on this machine (Ray would
        # join that one, and refuse num_cpus there).
        ray.init(address="local", num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
    else:
        where = address or os.environ["RAY_ADDRESS"]
        _check_reachable(where)
        try:
            ray.init(address=address)
        except (ConnectionError, RuntimeError) as exc:
            raise RunError(f"cannot reach the Ray cluster at {address or os.environ['RAY_ADDRESS']} "
                           f"({one_line(exc)[:200]}); check --address and that `ray status` works there") from None
    return True


REACH_TIMEOUT_S = 10.0


def _check_reachable(address: str) -> None:
    """A head address nothing answers at is one line now: Ray itself retries it for minutes."""
    host_port = address.removeprefix("ray://")
    host, _, port = host_port.rpartition(":")
    if not host or not port.isdigit():
        return  # "auto" and other forms Ray resolves itself
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=REACH_TIMEOUT_S).close()
    except OSError as exc:
        raise RunError(f"cannot reach the Ray cluster at {address} ({exc.strerror or exc}); check --address "
                       "and that `ray status` works there") from None


def _ray_task(shard_fn: ShardFn, job: ShardJob, queue: Any) -> dict:
    def tick(t: SceneTick) -> None:
        try:
            queue.put_nowait(t)
        except Exception:  # noqa: BLE001 - progress must never cost a shard
            pass

    return shard_fn(job, tick if queue is not None else None)


def _drain(queue: Any, on_scene: OnScene | None) -> None:
    if queue is None or on_scene is None:
        return
    n = queue.qsize()
    for t in queue.get_nowait_batch(n) if n else ():
        on_scene(t)


def _ray_result(ray: Any, ref: Any, job: ShardJob) -> ShardResult:
    try:
        return ShardResult(job, summary=ray.get(ref))
    except ray.exceptions.RayTaskError as exc:  # the shard function raised
        cause = exc.cause if isinstance(exc.cause, BaseException) else exc
        return ShardResult(job, error=one_line(cause)[:500],
                           errno=cause.errno if isinstance(cause, OSError) else None)
    except ray.exceptions.RayError as exc:  # the worker or its node died, retries used up
        return ShardResult(job, error=f"its Ray task failed ({one_line(exc)[:300]})")
