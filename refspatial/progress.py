"""What a run will do (``--dry-run``) and what it is doing (stderr only, never in the data).

On a terminal the progress is one live line, redrawn as scenes finish (workers send a
tick per scene through their pipe or Ray queue); elsewhere (CI logs, ``nohup``) it is one
plain line per finished shard, so logs stay readable. Either way a summary line ends it.
Timing comes from an injectable clock, so tests check the text without sleeping.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, TextIO

from .counted import counted
from .shards import SceneTick, ShardJob, check_args, check_existing, complete, plan_jobs, run_shard

if TYPE_CHECKING:
    from .assets import Catalogue
    from .recipe import Recipe

BAR_WIDTH = 24


def duration(seconds: float) -> str:
    """12s, 6m58s, 2h05m: precise enough for an estimate, short enough for one line."""
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


def size(n_bytes: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n_bytes < 1000 or unit == "GB":
            return f"{n_bytes:.0f} {unit}" if unit == "B" else f"{n_bytes:.1f} {unit}"
        n_bytes /= 1000
    return ""  # unreachable


@dataclass
class _Shard:
    scenes: int = 0
    records: int = 0
    qa: int = 0


class RunProgress:
    """Implements ``shards.Progress`` for a person watching stderr."""

    def __init__(self, stream: TextIO | None = None, tty: bool | None = None,
                 clock: Callable[[], float] = time.monotonic, redraw_s: float = 0.2) -> None:
        # sys.stderr is looked up now, not at import: it may have been replaced since (tests, notebooks).
        stream = sys.stderr if stream is None else stream
        self.stream, self.clock, self.redraw_s = stream, clock, redraw_s
        self.tty = stream.isatty() if tty is None else tty
        self.total = self.before = self.shards_total = self.shards_done = 0
        self.scenes = self.records = self.qa = 0
        self.skipped: Counter[str] = Counter()
        self.open: dict[int, _Shard] = {}
        self.failures: list[str] = []
        self.t0 = self.drawn = 0.0
        self.live = False  # a bar line is on screen, unfinished
        self.started = False  # a run refused before it starts has nothing to sum up

    def start(self, total_scenes: int, done_scenes: int, total_shards: int, done_shards: int) -> None:
        self.total, self.before = total_scenes, done_scenes
        self.shards_total, self.shards_done = total_shards, done_shards
        self.t0, self.started = self.clock(), True
        if done_shards:
            rest = "doing the rest" if done_shards < total_shards else "nothing left to do"
            self._line(f"{done_shards} of {counted(total_shards, 'shard')} already complete ({counted(done_scenes, 'scene')}); {rest}")

    def scene(self, tick: SceneTick) -> None:
        shard = self.open.setdefault(tick.shard, _Shard())
        shard.scenes, shard.records, shard.qa = shard.scenes + 1, shard.records + tick.records, shard.qa + tick.qa
        self._count(1, tick.records, tick.qa)
        if tick.skipped:
            self.skipped[tick.skipped] += 1
        if self.tty and self.clock() - self.drawn >= self.redraw_s:
            self._draw()

    def shard(self, summary: dict) -> None:
        """Credit what no tick reported (executors without ticks), then report the shard."""
        seen = self.open.pop(_shard_index(summary), _Shard())
        a, b = summary["scenes"]
        self._count(b - a - seen.scenes, summary["records"] - seen.records, summary["qa"] - seen.qa)
        if seen.scenes == 0:
            self.skipped.update(x["reason"] for x in summary["skipped"])
        self.shards_done += 1
        if self.tty:
            self._draw()
        else:
            self._line(f"{Path(summary['file']).stem}: {counted(b - a, 'scene')}, {counted(summary['records'], 'record')}, "
                       f"{summary['qa']} QA, {len(summary['skipped'])} skipped | {self._status()}")

    def failed(self, name: str, reason: str) -> None:
        self.failures.append(name)
        self._line(f"{name} FAILED: {reason}")

    def close(self, finished: bool = True) -> None:
        """The summary line; call it however the run ended (a run that never started has none)."""
        if not self.started:
            return
        elapsed = max(self.clock() - self.t0, 1e-9)
        skipped = ", ".join(f"{n} {r}" for r, n in sorted(self.skipped.items()))
        text = (f"{'done' if finished else 'stopped'}: {counted(self.scenes, 'scene')}"
                f"{f' ({skipped} skipped)' if skipped else ''}, {counted(self.records, 'record')}, {self.qa} QA "
                f"in {duration(elapsed)} ({self.scenes / elapsed:.2f} scenes/s, {self.qa / elapsed:.1f} QA/s)")
        if self.before:
            text += f"; {counted(self.before, 'scene')} {'was' if self.before == 1 else 'were'} already on disk"
        self._line(text, redraw=False)
        if self.skipped.get("error"):
            self._line(f"warning: {counted(self.skipped['error'], 'scene')} raised an error; their messages are in "
                       "manifest.json under rejected.scenes", redraw=False)

    def _count(self, scenes: int, records: int, qa: int) -> None:
        self.scenes, self.records, self.qa = self.scenes + scenes, self.records + records, self.qa + qa

    def _status(self) -> str:
        elapsed = self.clock() - self.t0
        rate = self.scenes / elapsed if elapsed > 0 else 0.0
        left = self.total - self.before - self.scenes
        eta = duration(left / rate) if rate > 0 else "?"
        return (f"{self.before + self.scenes}/{self.total} scenes, {self.shards_done}/{self.shards_total} "
                f"shards, {rate:.2f} scenes/s, {self.qa / elapsed if elapsed > 0 else 0.0:.1f} QA/s, ETA {eta}")

    def _draw(self) -> None:
        done = (self.before + self.scenes) / self.total if self.total else 1.0
        fill = int(done * BAR_WIDTH)
        bar = "#" * fill + "." * (BAR_WIDTH - fill)
        self.stream.write(f"\r[{bar}] {self._status()}\x1b[K")
        self.stream.flush()
        self.drawn, self.live = self.clock(), True

    def _line(self, text: str, redraw: bool = True) -> None:
        """A permanent line; on a terminal it goes above the bar, which is redrawn below."""
        prefix = "\r\x1b[K" if self.live else ""  # wipe the bar first
        self.stream.write(f"{prefix}{text}\n")
        self.live = False
        if self.tty and redraw:
            self._draw()
        self.stream.flush()


def _shard_index(summary: dict) -> int:
    return int(Path(summary["file"]).stem.split("-")[1])


@dataclass(frozen=True)
class Calibration:
    """Per-scene figures measured by making a few scenes of the run (``--dry-run``)."""

    scenes: int
    seconds_per_scene: float  # after the first scene, which pays for imports and GL start-up
    records_per_scene: float
    qa_per_scene: float
    bytes_per_scene: float  # of shard file, MCAP framing included
    rejected: float  # share of scenes skipped


@dataclass(frozen=True)
class DryRun:
    out_dir: Path
    recipe: str
    base_seed: int
    scenes: int
    scenes_per_shard: int
    shards: int
    complete_shards: int
    complete_scenes: int
    parallel: int
    estimate: Calibration | None

    @property
    def todo_scenes(self) -> int:
        return self.scenes - self.complete_scenes


def dry_run(out_dir: Path, recipe: Recipe, catalogue: Catalogue, n_scenes: int, base_seed: int = 0,
            workers: int = 1, scenes_per_shard: int = 25, calibrate_scenes: int = 3,
            cores: int | None = os.cpu_count()) -> DryRun:
    """The plan, what an existing folder already holds, and calibrated estimates; writes
    nothing into ``out_dir`` (calibration scenes go to a temporary folder). ``cores`` caps
    the parallelism of local workers; None for a cluster."""
    check_args(n_scenes, workers, scenes_per_shard)
    out_dir = Path(out_dir)
    if out_dir.is_dir():
        check_existing(out_dir, recipe, base_seed, scenes_per_shard, n_scenes)
    jobs = plan_jobs(out_dir, recipe, catalogue, n_scenes, base_seed, scenes_per_shard)
    done = [s for job in jobs if (s := complete(job)) is not None]
    n_cal = min(calibrate_scenes, n_scenes)
    parallel = min(workers, len(jobs) - len(done), cores or workers)
    return DryRun(out_dir, recipe.name, base_seed, n_scenes, scenes_per_shard, len(jobs), len(done),
                  sum(b - a for a, b in (s["scenes"] for s in done)), parallel,
                  calibrate(recipe, catalogue, base_seed, n_cal) if n_cal else None)


def calibrate(recipe: Recipe, catalogue: Catalogue, base_seed: int, n: int) -> Calibration:
    """Make the run's first ``n`` scenes for real, into a temporary folder, and measure."""
    stamps: list[float] = []
    with tempfile.TemporaryDirectory(prefix="refspatial-calibrate-") as tmp:
        job = ShardJob(0, 0, n, Path(tmp), recipe, catalogue, base_seed)
        job.mcap_path.parent.mkdir()
        t0 = time.perf_counter()
        summary = run_shard(job, on_scene=lambda tick: stamps.append(time.perf_counter()))
        n_bytes = job.mcap_path.stat().st_size
    per_scene = (stamps[-1] - stamps[0]) / (n - 1) if n > 1 else stamps[0] - t0
    return Calibration(n, per_scene, summary["records"] / n, summary["qa"] / n, n_bytes / n,
                       len(summary["skipped"]) / n)


def format_plan(plan: DryRun) -> str:
    """The ``--dry-run`` text: the plan, what is already done, and the estimates with their source."""
    lines = [
        f"plan: {counted(plan.scenes, 'scene')} of recipe {plan.recipe} (seed {plan.base_seed}) in "
        f"{counted(plan.shards, 'shard')} of <= {counted(plan.scenes_per_shard, 'scene')} -> {plan.out_dir}",
        f"on disk: {counted(plan.complete_shards, 'complete shard')} ({counted(plan.complete_scenes, 'scene')}); "
        f"to do: {counted(plan.shards - plan.complete_shards, 'shard')}, {counted(plan.todo_scenes, 'scene')}, "
        f"{plan.parallel} in parallel",
    ]
    e = plan.estimate
    if e is None:
        lines.append("estimate: none (--calibrate 0)")
        return "\n".join(lines)
    n = plan.todo_scenes
    workers = (f"the time assumes {plan.parallel} parallel workers scale linearly" if plan.parallel > 1
               else "the time is one worker's")
    lines += [
        f"expect: ~{n * e.records_per_scene:.0f} records, ~{n * e.qa_per_scene:.0f} QA, "
        f"~{size(n * e.bytes_per_scene)}, ~{duration(n * e.seconds_per_scene / max(plan.parallel, 1))}",
        f"estimate source: calibration, {counted(e.scenes, 'scene')} of this run made in this process just now "
        f"({e.seconds_per_scene:.2f} s/scene per worker, {size(e.bytes_per_scene)}/scene, "
        f"{e.rejected:.0%} rejected); {workers} and leaves out start-up",
    ]
    return "\n".join(lines)
