"""Running a dataset: seed ranges -> shards -> manifest.

The run is planned as shards of consecutive scene indices, fixed by the scene
count and shard size alone, so the bytes never depend on how many workers ran
or in which order they finished. A shard becomes visible only when complete:
its MCAP file is renamed into place, then a small JSON sidecar with its counts
and checksum; the manifest is rebuilt from the sidecars at the end. Running the
same command again, after a crash, ``kill -9`` or a full disk, skips complete
shards (checked against their checksum), deletes stale ``.partial`` files and
redoes the rest. How one shard is made is ``shard_job.py``'s business, and where
the shards run (this process, worker processes, a Ray cluster) the executor's
(``executors.py``); neither imports this module.
"""

from __future__ import annotations

import errno
import fcntl
import os
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Iterator, Protocol

from .executors import Executor, ShardResult, local_executor
from .manifest import MANIFEST, ManifestError, build_manifest, read_manifest
from .run_errors import RunError, RunFailed
from .atomic import file_in_the_way, write_json
from .counted import counted
from .shard_job import SceneTick, ShardJob, complete, read_sidecar
# Also importable from here, where they lived before one shard's code moved to shard_job.
from .shard_job import FORMAT, FORMAT_VERSION, OnScene, WriterFactory, one_line, run_shard  # noqa: F401

if TYPE_CHECKING:  # kept out of worker start-up: assets imports trimesh (~2 s)
    from .assets import Catalogue
    from .recipe import Recipe

RERUN = "run the same command again to finish"
# Writing can fail this way for every shard alike: stop at once rather than burn the whole plan.
FATAL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG})


class Progress(Protocol):
    """What ``generate`` tells whoever watches a run (see ``progress.py``)."""

    def start(self, total_scenes: int, done_scenes: int, total_shards: int, done_shards: int) -> None: ...
    def scene(self, tick: SceneTick) -> None: ...
    def shard(self, summary: dict) -> None: ...
    def failed(self, name: str, reason: str) -> None: ...


def plan(n_scenes: int, scenes_per_shard: int) -> list[tuple[int, int]]:
    """Scene index ranges [start, stop) of each shard."""
    return [(s, min(s + scenes_per_shard, n_scenes)) for s in range(0, n_scenes, scenes_per_shard)]


def plan_jobs(out_dir: Path, recipe: Recipe, catalogue: Catalogue, n_scenes: int, base_seed: int,
              scenes_per_shard: int) -> list[ShardJob]:
    return [ShardJob(i, a, b, out_dir, recipe, catalogue, base_seed)
            for i, (a, b) in enumerate(plan(n_scenes, scenes_per_shard))]


def remove_partials(out_dir: Path) -> list[Path]:
    """Delete the ``.partial`` files a killed run leaves behind (never complete files)."""
    stale = [*out_dir.glob(".*.partial"), *(out_dir / "shards").glob(".*.partial")]
    for path in stale:
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass  # a read-only disk: the next run, with the disk fixed, removes it
    return stale


@contextmanager
def run_lock(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on the output folder: two runs into one folder would delete
    each other's partial files. The kernel drops it when the process dies, even by kill -9."""
    fd = os.open(out_dir, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunError(f"another `refspatial generate` is writing to {out_dir}; wait for it "
                           "to end or choose another --out") from None
        except OSError:
            pass  # a filesystem without flock (some NFS): run unlocked
        yield
    finally:
        os.close(fd)


def prepare_out_dir(out_dir: Path, recipe: Recipe, base_seed: int, scenes_per_shard: int, n_scenes: int) -> None:
    """Create the output folder, or check that an existing one holds this same run."""
    if (out_dir / "shards").is_file():
        raise RunError(f"--out {out_dir} holds a file named shards where the shards folder goes; "
                       "move it away or choose another --out")
    if (path := file_in_the_way(out_dir)) is not None:
        where = "" if path == out_dir else f": {path}"
        raise RunError(f"--out {out_dir}{where} is a file, not a folder; choose another --out")
    try:
        (out_dir / "shards").mkdir(parents=True, exist_ok=True)
        probe = out_dir / ".write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise RunError(f"cannot write to {out_dir} ({exc.strerror}); choose another --out") from None
    check_existing(out_dir, recipe, base_seed, scenes_per_shard, n_scenes)


def check_existing(out_dir: Path, recipe: Recipe, base_seed: int, scenes_per_shard: int, n_scenes: int) -> None:
    """Refuse a folder that holds (part of) a run with another recipe, seed or shard size, or
    more scenes than asked for (shards beyond the plan would be left outside the manifest)."""
    mine = {"recipe_hash": recipe.hash, "base_seed": base_seed, "scenes_per_shard": scenes_per_shard}
    for theirs in _existing_runs(out_dir, scenes_per_shard):
        for key in (k for k in mine if theirs.get(k) != mine[k]):
            what, fix = _differs(key, theirs, mine[key], recipe)
            raise RunError(f"{out_dir / theirs['source']} says its {theirs['what']} was made with {what}; "
                           f"use another --out, or {fix} to extend or resume it")
    beyond = _scenes_on_disk(out_dir, scenes_per_shard)
    if beyond > n_scenes:
        raise RunError(f"{out_dir} already holds {counted(beyond, 'scene')}, more than --scenes {n_scenes}; pass "
                       f"--scenes {beyond} (or more) to resume or extend it, or use another --out for fewer")


def _differs(key: str, theirs: dict, mine: object, recipe: Recipe) -> tuple[str, str]:
    """One setting of an existing run that differs from this run's: (both values, the flag that fits)."""
    if key == "base_seed":
        return f"--seed {theirs[key]}, not --seed {mine}", f"--seed {theirs[key]}"
    if key == "scenes_per_shard":
        if theirs[key] == -1:  # a sidecar whose range fits no single size
            return f"another --scenes-per-shard than {mine}", "its --scenes-per-shard"
        return (f"--scenes-per-shard {theirs[key]}, not --scenes-per-shard {mine}",
                f"--scenes-per-shard {theirs[key]}")
    fix = "the recipe (and --assets, --asset-share) that made it"
    if theirs.get("recipe") and theirs["recipe"] != recipe.name:
        return f"recipe {theirs['recipe']}, not {recipe.name}", fix
    return (f"recipe hash {str(theirs[key])[:12]}, not {str(mine)[:12]} (recipe {recipe.name}'s file, a recipe it "
            "extends, --assets or --asset-share differ)", fix)


def _existing_runs(out_dir: Path, scenes_per_shard: int) -> Iterator[dict]:
    """What the manifest, or failing that each sidecar of an unfinished run, says made them.
    A damaged manifest counts as none: the sidecars say the same, and the run rewrites it."""
    try:
        yield {**read_manifest(out_dir), "source": MANIFEST, "what": "dataset"}
        return
    except (ManifestError, FileNotFoundError):
        pass
    for path in sorted((out_dir / "shards").glob("shard-*.json")):
        side = read_sidecar(path)
        if side is None or "scenes" not in side:
            continue
        spp = _shard_size(int(path.stem.split("-")[1]), *side["scenes"], scenes_per_shard)
        yield {"recipe_hash": side.get("recipe_hash"), "base_seed": side.get("base_seed"), "scenes_per_shard": spp,
               "source": f"shards/{path.name}", "what": "shard"}


def _scenes_on_disk(out_dir: Path, scenes_per_shard: int) -> int:
    """One past the last scene any shard file in ``out_dir`` holds, as far as sidecars and names tell."""
    stops = [0]
    for path in (out_dir / "shards").glob("shard-*.*"):
        index = path.stem.split("-")[1]
        if path.suffix == ".json" and (side := read_sidecar(path)) and isinstance(side.get("scenes"), list):
            stops.append(int(side["scenes"][1]))
        elif path.suffix == ".mcap" and index.isdigit():
            stops.append(int(index) * scenes_per_shard + 1)  # its first scene, at least
    return max(stops)


def _shard_size(index: int, start: int, stop: int, expected: int) -> int:
    """--scenes-per-shard of the run that wrote shard ``index`` = [start, stop): shard i
    starts at i * size; shard 0 only bounds the size from below."""
    if index:
        return start // index if start % index == 0 else -1
    return expected if stop - start <= expected else stop - start


def check_args(n_scenes: int, workers: int, scenes_per_shard: int) -> None:
    if n_scenes < 0 or workers < 1 or scenes_per_shard < 1:
        raise RunError("--scenes must be >= 0, --workers and --scenes-per-shard >= 1")


def generate(out_dir: Path, recipe: Recipe, catalogue: Catalogue, n_scenes: int, base_seed: int = 0,
             workers: int = 1, scenes_per_shard: int = 25, progress: Progress | None = None,
             executor: Executor | None = None) -> dict:
    """Generate (or finish) a dataset; returns the manifest.

    Raises RunFailed, after every shard that could be made is on disk, when some shard
    could not be; running the same call again finishes the dataset.
    """
    check_args(n_scenes, workers, scenes_per_shard)
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir, recipe, base_seed, scenes_per_shard, n_scenes)
    jobs = plan_jobs(out_dir, recipe, catalogue, n_scenes, base_seed, scenes_per_shard)
    with run_lock(out_dir):
        remove_partials(out_dir)  # of a run killed before it could clean up
        done = {job.index: s for job in jobs if (s := complete(job)) is not None}
        todo = [job for job in jobs if job.index not in done]
        if progress:
            progress.start(n_scenes, sum(b - a for a, b in (s["scenes"] for s in done.values())),
                           len(jobs), len(done))
        try:
            failures = _run(executor or local_executor(workers), todo, done, progress)
        finally:
            remove_partials(out_dir)  # of workers stopped mid-shard by a failure or Ctrl-C
        if failures:
            raise RunFailed(_failure_message(failures, len(done), len(jobs)))
        manifest = build_manifest(recipe, catalogue, base_seed, scenes_per_shard, [done[j.index] for j in jobs])
        try:
            write_json(out_dir / MANIFEST, manifest)
        except OSError as exc:  # every shard is on disk: only the manifest is left to write
            fix = "free space or fix the folder's permissions, then " if exc.errno in FATAL_ERRNOS else ""
            raise RunFailed(f"the shards are complete but {out_dir / MANIFEST} could not be written "
                            f"({exc.strerror or one_line(exc)}); {fix}{RERUN}") from None
    return manifest


def _run(executor: Executor, todo: list[ShardJob], done: dict[int, dict],
         progress: Progress | None) -> list[tuple[ShardJob, str, bool]]:
    """Feed the executor, collect summaries; stop early only on a fatal (disk) error."""
    failures = []
    with _closing(executor.run(todo, progress.scene if progress else None)) as results:
        for result in results:
            failure = _check_result(result)
            if failure is None:
                done[result.job.index] = result.summary
                if progress:
                    progress.shard(result.summary)
                continue
            failures.append((result.job, *failure))
            if progress:
                progress.failed(result.job.name, failure[0])
            if failure[1]:
                break
    return failures


@contextmanager
def _closing(results: Iterator[ShardResult]) -> Iterator[Iterator[ShardResult]]:
    """Close a generator executor's iterator (stopping its workers) however the loop ends."""
    try:
        yield results
    finally:
        close = getattr(results, "close", None)
        if close is not None:
            close()


def _check_result(result: ShardResult) -> tuple[str, bool] | None:
    """(reason, fatal) for a failed shard; None when its file really is on disk, complete."""
    if result.error is not None:
        return result.error, result.errno in FATAL_ERRNOS
    if complete(result.job) is None:
        return (f"its worker reported success but {result.job.mcap_path} is missing or differs from "
                "its checksum; with a cluster, --out must be a folder every node mounts at the same path", True)
    return None


def _failure_message(failures: list[tuple[ShardJob, str, bool]], complete: int, total: int) -> str:
    job, reason, fatal = failures[0]
    what = f"{job.name} (scenes {job.start}-{job.stop}) failed: {reason}"
    more = f"; {len(failures) - 1} more shard(s) failed" if len(failures) > 1 else ""
    fix = "free space or fix the folder's permissions (or choose another --out), then " if fatal else ""
    return f"{what}{more}; {complete} of {total} shards are complete; {fix}{RERUN}"
