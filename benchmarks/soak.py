"""Memory soak: many scenes in one worker process, RSS sampled as it goes.

    python benchmarks/soak.py [--scenes 5000] [--every 250] [--recipe tests/data/tiny.yaml]

Runs the real worker code path (``run_shard``: compose, settle, frame, render,
relations, questions, MCAP write) shard after shard in this one process, as a
long-lived worker of ``refspatial generate`` does, with ``LP_NUM_THREADS=1``.
Every ``--every`` scenes it prints the resident set size, open file descriptors
and the rate. Finished shards are deleted as it goes (disk stays small) unless
``--keep DIR``. Flat memory means the RSS column stops growing after warm-up;
the last lines give the slope after the first 10 % of scenes.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ["LP_NUM_THREADS"] = "1"  # as in a worker process
os.environ.setdefault("MUJOCO_GL", "egl")

import refspatial  # noqa: E402,F401
from refspatial.assets import load_catalogue  # noqa: E402
from refspatial.recipe import load_recipe  # noqa: E402
from refspatial.shards import SceneTick, plan_jobs, run_shard  # noqa: E402

TINY = Path(__file__).resolve().parent.parent / "tests" / "data" / "tiny.yaml"


def rss_mib() -> float:
    """Current (not peak) resident set size, from /proc (Linux)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


class Sampler:
    """Called after every scene; prints one table row every ``every`` scenes."""

    def __init__(self, every: int) -> None:
        self.every, self.scenes, self.rows = every, 0, []
        self.start = self.last = time.perf_counter()

    def __call__(self, tick: SceneTick) -> None:
        self.scenes += 1
        if self.scenes % self.every:
            return
        now = time.perf_counter()
        row = (self.scenes, now - self.start, self.every / (now - self.last), rss_mib(), open_fds())
        self.last = now
        self.rows.append(row)
        print(f"{row[0]:>7} {row[1]:>9.0f} {row[2]:>9.2f} {row[3]:>9.1f} {row[4]:>5}", flush=True)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", type=int, default=5000)
    p.add_argument("--every", type=int, default=250, help="sample RSS every this many scenes")
    p.add_argument("--recipe", default=str(TINY), help="recipe name or .yaml path (default: the tiny test recipe)")
    p.add_argument("--scenes-per-shard", type=int, default=25)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--keep", type=Path, help="write the shards here and keep them")
    args = p.parse_args()
    recipe, catalogue = load_recipe(args.recipe), load_catalogue()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.keep or Path(tmp)
        (out / "shards").mkdir(parents=True, exist_ok=True)
        print(f"# {args.scenes} scenes of {recipe.name}, one process, pid {os.getpid()}, "
              f"start RSS {rss_mib():.1f} MiB", flush=True)
        print(f"{'scenes':>7} {'elapsed_s':>9} {'scenes/s':>9} {'rss_MiB':>9} {'fds':>5}", flush=True)
        sample = Sampler(args.every)
        for job in plan_jobs(out, recipe, catalogue, args.scenes, args.seed, args.scenes_per_shard):
            run_shard(job, on_scene=sample)
            if not args.keep:
                job.mcap_path.unlink()
                job.sidecar_path.unlink()
    report(sample.rows)
    return 0


def report(rows: list[tuple]) -> None:
    """Growth after warm-up: the first tenth of the run builds caches and GL state."""
    if len(rows) < 3:
        return
    base = rows[max(1, len(rows) // 10) - 1]
    end = rows[-1]
    slope = (end[3] - base[3]) / max(end[0] - base[0], 1) * 1000
    print(f"# RSS {base[3]:.1f} MiB at {base[0]} scenes -> {end[3]:.1f} MiB at {end[0]}: "
          f"{slope:+.2f} MiB per 1000 scenes; peak {max(r[3] for r in rows):.1f} MiB; "
          f"fds {base[4]} -> {end[4]}; mean {end[0] / end[1]:.2f} scenes/s", flush=True)


if __name__ == "__main__":
    sys.exit(main())
