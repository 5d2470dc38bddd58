"""One shard of a run: its job (a range of scene indices), how it is made, and its sidecar.

Workers, local or on a cluster, need only this module to make a shard (``executors.py``
hands it the jobs); planning the run, resuming it and writing its manifest is
``shards.py``'s business. A shard is written by ``ShardWriter`` under a hidden partial name
and renamed into place when complete; then its JSON sidecar records the counts and
checksum that ``complete`` checks on a re-run.
"""

from __future__ import annotations

import gc
import json
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator

from . import __version__
from .atomic import write_json
from .records import ShardWriter, sha256_file
from .seeding import scene_seed

if TYPE_CHECKING:  # kept out of worker start-up: assets imports trimesh (~2 s)
    from .assets import Catalogue
    from .pipeline import SceneOutcome
    from .recipe import Recipe

FORMAT = "refspatial-shards"
FORMAT_VERSION = 1
# The garbage collector's thresholds while a shard is made (see ``rarer_collections``):
# net new container objects between young collections (Python's default is 700), and gen-1
# collections between full passes (default 10).
YOUNG_PASS_AFTER = 20_000
FULL_PASS_EVERY = 100


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


@dataclass(frozen=True)
class SceneTick:
    """One scene finished inside a shard still being written: progress only, never stored."""

    shard: int
    index: int
    records: int
    qa: int
    skipped: str | None  # reason slug, None when the scene made records


OnScene = Callable[[SceneTick], None]
WriterFactory = Callable[[Path, dict], ShardWriter]


def run_shard(job: ShardJob, on_scene: OnScene | None = None,
              open_writer: WriterFactory = ShardWriter) -> dict:
    """Generate one shard's scenes and write them; returns its summary (with timings).

    A scene that fails in any way is recorded as skipped with its reason and the shard
    goes on; only writing errors (a full disk) end the shard, leaving no file behind.
    ``open_writer`` exists so that tests can make the disk fail.
    """
    seconds: dict[str, float] = {}
    skipped, qa, records = [], 0, 0
    with rarer_collections(), open_writer(job.mcap_path, _shard_metadata(job)) as writer:
        for index in range(job.start, job.stop):
            outcome = _scene(job, index)
            for record in outcome.records:
                writer.write(record)
            n_qa = sum(len(r.qa) for r in outcome.records)
            records, qa = records + len(outcome.records), qa + n_qa
            for stage, s in outcome.seconds.items():
                seconds[stage] = seconds.get(stage, 0.0) + s
            if outcome.rejected:
                skipped.append({"index": index, "seed": outcome.seed, "reason": outcome.rejected,
                                "detail": outcome.detail})
            if on_scene:
                on_scene(SceneTick(job.index, index, len(outcome.records), n_qa, outcome.rejected))
    summary = {
        "file": f"shards/{job.name}.mcap",
        "scenes": [job.start, job.stop],
        "records": records,
        "qa": qa,
        "sha256": writer.sha256,
        "skipped": skipped,
        "recipe_hash": job.recipe.hash,
        "base_seed": job.base_seed,
    }
    write_json(job.sidecar_path, summary)
    return {**summary, "seconds": seconds}


@contextmanager
def rarer_collections() -> Iterator[None]:
    """Python's garbage collector with rarer passes, for the shard's duration.

    A scene's facts and caches live long enough to reach the oldest generation, and at the
    default thresholds they set off a full pass every scene or two, each walking every object
    in the process (banks, modules, the scene): 3.6-4.2 ms a record of one core in collections,
    against 0.9-1.0 with full passes ten times rarer. Young passes every 20,000 net new objects
    instead of 700 take that to 0.1: a scene makes almost no cyclic garbage (reference counts
    free the rest at once; the 171 young passes of 48 records freed 81 objects in all), and
    peak memory is the same (BENCHMARKS.md, fifteenth and sixteenth sessions).

    What the process holds when the shard starts (banks, modules, caches: some 200,000 tracked
    objects) is frozen for the shard: a full pass that still comes, as one did after a
    benchmark's set-up left the oldest generation's count high, walks the shard's own objects
    (0.3 ms) instead of the whole heap (95-145 ms, 4-6 ms a record of a 12-scene shard). Freezing
    and thawing move whole lists, and cyclic garbage made before the shard waits until after it.
    A heap some caller froze stays frozen. Records are unaffected: no result depends on when
    garbage is collected."""
    old = gc.get_threshold()
    gc.set_threshold(YOUNG_PASS_AFTER, old[1], FULL_PASS_EVERY)
    ours = gc.get_freeze_count() == 0
    gc.freeze()
    try:
        yield
    finally:
        if ours:
            gc.unfreeze()
        gc.set_threshold(*old)


def _scene(job: ShardJob, index: int) -> SceneOutcome:
    """generate_scene, with any exception turned into a skipped scene: one bad scene
    (a physics blow-up, a renderer error, a bug hit by one seed) must not cost the run."""
    from .pipeline import SceneOutcome, generate_scene

    seed = scene_seed(job.base_seed, index)
    try:
        return generate_scene(job.recipe, job.catalogue, seed)
    except Exception as exc:  # noqa: BLE001 - recorded with type and message, never hidden
        return SceneOutcome(seed, rejected="error", detail=one_line(exc))


def one_line(exc: BaseException) -> str:
    """``Type: message`` on one line, the form errors take in sidecars and messages."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


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
            **({"libraries": json.dumps(job.catalogue.libraries.manifest(), sort_keys=True)}
               if job.catalogue.libraries is not None else {}),
        },
        "recipe": {"name": job.recipe.name, "yaml": job.recipe.text, "resolved_yaml": job.recipe.resolved_yaml,
                   "resolved_json": json.dumps(job.recipe.data, sort_keys=True)},
    }


def read_sidecar(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None  # missing or torn: the shard is simply redone


def complete(job: ShardJob) -> dict | None:
    """The sidecar of a shard already on disk whose checksum still matches, else None."""
    if not (job.sidecar_path.is_file() and job.mcap_path.is_file()):
        return None
    summary = read_sidecar(job.sidecar_path)
    if (summary is None or summary.get("scenes") != [job.start, job.stop]
            or summary.get("recipe_hash") != job.recipe.hash or summary.get("base_seed") != job.base_seed):
        return None
    return summary if summary.get("sha256") == sha256_file(job.mcap_path) else None
