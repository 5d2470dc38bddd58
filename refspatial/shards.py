"""Running a dataset: seed ranges -> shards -> manifest.

The run is planned as shards of consecutive scene indices, fixed by the scene
count and shard size alone, so the bytes never depend on how many workers ran
or in which order they finished. A shard becomes visible only when complete:
its MCAP file is renamed into place, then a small JSON sidecar with its counts
and checksum; the manifest is rebuilt from the sidecars at the end. Running the
same command again skips complete shards and redoes the rest.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import sys
import time
from dataclasses import dataclass
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import Callable

from . import __version__
from .assets import Catalogue
from .recipe import Recipe
from .records import ShardWriter, sha256_file
from .seeding import scene_seed

FORMAT = "refspatial-shards"
FORMAT_VERSION = 1
VERSIONED_PACKAGES = ("mujoco", "numpy", "trimesh", "manifold3d", "mcap", "opencv-python-headless")


class RunError(RuntimeError):
    """A run that cannot start or continue; the message says what to change."""


@dataclass(frozen=True)
class ShardJob:
    index: int
    start: int  # first scene index
    stop: int  # one past the last scene index
    out_dir: Path
    recipe: Recipe
    catalogue: Catalogue
    base_seed: int

    @property
    def name(self) -> str:
        return f"shard-{self.index:05d}"

    @property
    def mcap_path(self) -> Path:
        return self.out_dir / "shards" / f"{self.name}.mcap"

    @property
    def sidecar_path(self) -> Path:
        return self.out_dir / "shards" / f"{self.name}.json"


def plan(n_scenes: int, scenes_per_shard: int) -> list[tuple[int, int]]:
    """Scene index ranges [start, stop) of each shard."""
    return [(s, min(s + scenes_per_shard, n_scenes)) for s in range(0, n_scenes, scenes_per_shard)]


def run_shard(job: ShardJob) -> dict:
    """Generate one shard's scenes and write them; returns its summary (with timings)."""
    from .pipeline import generate_scene

    seconds: dict[str, float] = {}
    skipped, qa, records = [], 0, 0
    with ShardWriter(job.mcap_path, _shard_metadata(job)) as writer:
        for index in range(job.start, job.stop):
            seed = scene_seed(job.base_seed, index)
            outcome = generate_scene(job.recipe, job.catalogue, seed)
            for stage, s in outcome.seconds.items():
                seconds[stage] = seconds.get(stage, 0.0) + s
            if outcome.rejected:
                skipped.append({"index": index, "seed": seed, "reason": outcome.rejected, "detail": outcome.detail})
            for record in outcome.records:
                writer.write(record)
                records += 1
                qa += len(record.qa)
    summary = {
        "file": f"shards/{job.name}.mcap",
        "scenes": [job.start, job.stop],
        "records": records,
        "qa": qa,
        "sha256": sha256_file(job.mcap_path),
        "skipped": skipped,
    }
    _write_json(job.sidecar_path, summary)
    return {**summary, "seconds": seconds}


def _shard_metadata(job: ShardJob) -> dict[str, dict[str, str]]:
    return {
        "refspatial": {
            "version": __version__,
            "format": FORMAT,
            "format_version": str(FORMAT_VERSION),
            "recipe": job.recipe.name,
            "recipe_hash": job.recipe.hash,
            "catalogue_sha256": job.catalogue.sha256,
            "base_seed": str(job.base_seed),
            "scenes": f"{job.start}-{job.stop}",
        },
        "recipe": {"name": job.recipe.name, "yaml": job.recipe.text,
                   "resolved_json": json.dumps(job.recipe.data, sort_keys=True)},
    }


def _write_json(path: Path, obj: dict) -> None:
    tmp = path.with_name(f".{path.name}.partial")
    tmp.write_text(json.dumps(obj, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(path)


def _complete(job: ShardJob) -> dict | None:
    """The sidecar of a shard already on disk whose checksum still matches, else None."""
    if not (job.sidecar_path.is_file() and job.mcap_path.is_file()):
        return None
    try:
        summary = json.loads(job.sidecar_path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
    if summary.get("scenes") != [job.start, job.stop] or summary.get("sha256") != sha256_file(job.mcap_path):
        return None
    return summary


def prepare_out_dir(out_dir: Path, recipe: Recipe, base_seed: int, scenes_per_shard: int) -> None:
    """Create the output folder, or check that an existing one holds this same run."""
    try:
        (out_dir / "shards").mkdir(parents=True, exist_ok=True)
        probe = out_dir / ".write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise RunError(f"cannot write to {out_dir} ({exc.strerror}); choose another --out") from None
    manifest = out_dir / "manifest.json"
    if manifest.is_file():
        old = json.loads(manifest.read_text(encoding="utf-8"))
        mine = {"recipe_hash": recipe.hash, "base_seed": base_seed, "scenes_per_shard": scenes_per_shard}
        theirs = {k: old.get(k) for k in mine}
        if theirs != mine:
            raise RunError(
                f"{out_dir} already holds a dataset made with {theirs}; use another --out, "
                "or the same --recipe/--seed/--scenes-per-shard to extend or resume it"
            )


def generate(out_dir: Path, recipe: Recipe, catalogue: Catalogue, n_scenes: int, base_seed: int = 0,
             workers: int = 1, scenes_per_shard: int = 25,
             progress: Callable[[dict, int, int], None] | None = None) -> dict:
    """Generate (or finish) a dataset; returns the manifest."""
    if n_scenes < 0 or workers < 1 or scenes_per_shard < 1:
        raise RunError("--scenes must be >= 0, --workers and --scenes-per-shard >= 1")
    prepare_out_dir(out_dir, recipe, base_seed, scenes_per_shard)
    jobs = [ShardJob(i, a, b, out_dir, recipe, catalogue, base_seed)
            for i, (a, b) in enumerate(plan(n_scenes, scenes_per_shard))]
    done = {job.index: s for job in jobs if (s := _complete(job)) is not None}
    todo = [job for job in jobs if job.index not in done]
    for summary in _execute(todo, workers):
        index = int(Path(summary["file"]).stem.split("-")[1])
        done[index] = summary
        if progress:
            progress(summary, len(done), len(jobs))
    manifest = build_manifest(recipe, catalogue, base_seed, scenes_per_shard, [done[j.index] for j in jobs])
    _write_json(out_dir / "manifest.json", manifest)
    return manifest


def _execute(jobs: list[ShardJob], workers: int):
    if workers == 1 or len(jobs) <= 1:
        yield from map(run_shard, jobs)
        return
    # Each worker renders single-threaded: separate processes beat one process with
    # two rasteriser threads (platform.md), and they must not fight over cores.
    previous = os.environ.get("LP_NUM_THREADS")
    os.environ["LP_NUM_THREADS"] = "1"
    try:
        ctx = mp.get_context("spawn")  # GL contexts do not survive fork
        with ctx.Pool(processes=min(workers, len(jobs))) as pool:
            yield from pool.imap_unordered(run_shard, jobs)
    finally:
        if previous is None:
            os.environ.pop("LP_NUM_THREADS", None)
        else:
            os.environ["LP_NUM_THREADS"] = previous


def build_manifest(recipe: Recipe, catalogue: Catalogue, base_seed: int, scenes_per_shard: int,
                   summaries: list[dict]) -> dict:
    shards = [{k: s[k] for k in ("file", "scenes", "records", "qa", "sha256")} for s in summaries]
    skipped = [x for s in summaries for x in s["skipped"]]
    reasons: dict[str, int] = {}
    for x in skipped:
        reasons[x["reason"]] = reasons.get(x["reason"], 0) + 1
    scenes = sum(b - a for a, b in (s["scenes"] for s in summaries))
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "generator": {"refspatial": __version__, "python": sys.version.split()[0], "packages": package_versions()},
        "recipe": recipe.name,
        "recipe_hash": recipe.hash,
        "recipe_yaml": recipe.text,
        "catalogue_sha256": catalogue.sha256,
        "base_seed": base_seed,
        "scenes_per_shard": scenes_per_shard,
        "scenes": scenes,
        "records": sum(s["records"] for s in shards),
        "qa": sum(s["qa"] for s in shards),
        "rejected": {"count": len(skipped), "rate": round(len(skipped) / scenes, 4) if scenes else 0.0,
                     "reasons": dict(sorted(reasons.items())), "scenes": skipped},
        "shards": shards,
    }


def package_versions() -> dict[str, str]:
    out = {}
    for name in VERSIONED_PACKAGES:
        try:
            out[name] = importlib_metadata.version(name)
        except importlib_metadata.PackageNotFoundError:
            out[name] = "missing"
    return out


class Progress:
    """One line per finished shard on stderr: counts, rates and time left."""

    def __init__(self, stream=sys.stderr) -> None:
        self.stream = stream
        self.start = time.perf_counter()
        self.scenes = self.records = self.qa = 0

    def __call__(self, summary: dict, done: int, total: int) -> None:
        a, b = summary["scenes"]
        self.scenes += b - a
        self.records += summary["records"]
        self.qa += summary["qa"]
        elapsed = time.perf_counter() - self.start
        rate = self.scenes / elapsed if elapsed else 0.0
        eta = (total - done) * elapsed / max(done, 1)
        print(f"[{done}/{total} shards] {self.records} records, {self.qa} QA, "
              f"{rate:.2f} scenes/s, {self.qa / max(elapsed, 1e-9):.1f} QA/s, ETA {eta:.0f}s",
              file=self.stream, flush=True)
