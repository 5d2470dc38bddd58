"""Compare the CPU-side stages of two checkouts under the same machine conditions.

    python benchmarks/ab_pair.py BEFORE_DIR AFTER_DIR [--scenes 16] [--recipe tabletop]

On a shared machine one run's CPU time differs from the next by tens of per cent (the same
code read 82 and 99 ms a record a few minutes apart, its bare render 121 and 143 ms), so runs
one after the other cannot tell a 5 % change. Here ``cpu_profile.py`` of each checkout runs at
the same time, one on each of two cores, and then again with the cores swapped: both meet the
same slowdowns, and neither core's own speed favours one side. Each checkout runs its own code
(``PYTHONPATH`` set to it) with this environment's packages. Needs two cores.

Make a checkout of an earlier commit with ``git worktree add /tmp/before <commit>``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

STAGES = ("compose", "physics", "camera", "render", "relations", "questions", "write")
CPU_SIDE = "CPU-side stages (all but render)"


def profile(tree: Path, core: int, recipe: str, scenes: int) -> dict[str, float]:
    """One cpu_profile.py run of ``tree``'s code on ``core``: ms a record by stage."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = ["taskset", "-c", str(core), sys.executable, str(tree / "benchmarks" / "cpu_profile.py"),
           "--recipe", recipe, "--scenes", str(scenes), "--passes", "2"]
    out = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, check=True).stdout
    found = {}
    for name in (*STAGES, CPU_SIDE):
        m = re.search(rf"^\s+{re.escape(name)}\s+([0-9.]+)", out, re.MULTILINE)
        if m:
            found[name] = float(m.group(1))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--scenes", type=int, default=16)
    parser.add_argument("--recipe", default="tabletop")
    args = parser.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2:
        parser.error("needs two cores: it runs both checkouts at once")
    for tree in (args.before, args.after):
        if not (tree / "benchmarks" / "cpu_profile.py").is_file():
            parser.error(f"{tree} is not a refspatial checkout (no benchmarks/cpu_profile.py); give two checkouts")
    rounds = []
    with ThreadPoolExecutor(2) as pool:
        for before_core, after_core in ((cores[0], cores[1]), (cores[1], cores[0])):
            jobs = [pool.submit(profile, args.before.resolve(), before_core, args.recipe, args.scenes),
                    pool.submit(profile, args.after.resolve(), after_core, args.recipe, args.scenes)]
            rounds.append([j.result() for j in jobs])
    print(f"recipe {args.recipe}, {args.scenes} scenes, CPU time, ms a record: before / after "
          f"(run together; cores swapped in the second round)")
    for name in (*STAGES, CPU_SIDE):
        cells = [f"{b.get(name, float('nan')):6.1f} / {a.get(name, float('nan')):6.1f}" for b, a in rounds]
        print(f"  {name:<34} " + "    ".join(cells))
    change = [100 * (a[CPU_SIDE] / b[CPU_SIDE] - 1) for b, a in rounds]
    print("  CPU-side change: " + ", ".join(f"{c:+.1f} %" for c in change))


if __name__ == "__main__":
    main()
