"""The ``refspatial`` command line."""

from __future__ import annotations

import argparse
import io
import json
import os
import sys
from pathlib import Path

from .argtypes import at_least

EXIT_USAGE = 2


_nonnegative = at_least(0)
_positive = at_least(1)


class _Parser(argparse.ArgumentParser):
    """Usage errors in one line, as every other failure: the error and where the help is (the
    full usage of `generate` alone is eight lines of flags in front of the one that matters)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="refspatial", description=__doc__ or "")
    parser.description = "Generate, inspect and audit multi-step spatial-referring QA data."
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    g = sub.add_parser("generate", help="compose, render and write a sharded dataset",
                       description="Generate a dataset, or finish one: re-running the same command after a "
                       "crash, kill or full disk skips complete shards and redoes the rest.")
    g.add_argument("--scenes", type=_nonnegative, required=True, help="number of scenes to generate")
    g.add_argument("--recipe", default="tabletop", help="recipe name in recipes/ or a .yaml path (default: tabletop)")
    g.add_argument("--out", type=Path, default=Path("data"), help="output folder (default: ./data)")
    g.add_argument("--seed", type=int, default=0,
                   help="base seed; scene i uses a seed hashed from (seed, i) (default: 0)")
    g.add_argument("--workers", type=_positive,
                   default=len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1,
                   help="worker processes, or CPUs of a local Ray instance (default: all cores)")
    g.add_argument("--scenes-per-shard", type=_positive, default=25, help="scenes per MCAP shard (default: 25)")
    g.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="local worker processes (default), or Ray tasks (pip install -e '.[ray]' in the checkout)")
    g.add_argument("--address", help="Ray cluster to join, e.g. head-node:6379 (default: $RAY_ADDRESS, "
                   "else a Ray instance started for this run)")
    g.add_argument("--gpus-per-task", type=float, default=0.0,
                   help="GPU share each Ray task asks for, e.g. 0.25; > 0 renders through NVIDIA EGL (default: 0)")
    g.add_argument("--dry-run", action="store_true",
                   help="print the plan with size and time estimates, write nothing")
    g.add_argument("--calibrate", type=_nonnegative, default=3,
                   help="scenes made in a temporary folder to calibrate --dry-run estimates (default: 3)")
    g.add_argument("--quiet", action="store_true", help="no progress on stderr")
    _library_args(g)

    s = sub.add_parser("stats", help="print counts of scenes, records, QA, predicates, steps and categories")
    s.add_argument("dir", type=Path, nargs="+",
                   help="dataset folder; several folders (one per scene family, say) are counted as one")
    s.add_argument("--json", action="store_true", help="print JSON instead of text")
    s.add_argument("--report", type=Path, metavar="HTML",
                   help="also write a self-contained HTML audit report (plots, balance warnings) to this .html path")

    c = sub.add_parser("scene", help="write one composed, settled scene as MJCF (meshes beside it)")
    c.add_argument("--recipe", default="tabletop", help="recipe name in recipes/ or a .yaml path (default: tabletop)")
    c.add_argument("--seed", type=int, required=True, help="the scene seed (a record's scene.seed)")
    c.add_argument("--mjcf", type=Path, required=True, help="output .xml path")
    _library_args(c)

    a = sub.add_parser("assets", help="build an asset library from your own annotated meshes")
    actions = a.add_subparsers(dest="action", metavar="ACTION", required=True)
    ai = actions.add_parser("import", help="import a folder of meshes (+ YAML beside each, or annotations.csv/.jsonl)")
    ai.add_argument("src", type=Path, help="folder of meshes (GLB/GLTF, OBJ+MTL, STL, PLY, USD)")
    ai.add_argument("--out", type=Path, required=True, help="library folder to write (replaced whole when complete)")
    ai.add_argument("--workers", type=_positive, default=1, help="import processes (default: 1)")

    v = sub.add_parser("verify", help="re-execute every stored program and check every answer and checksum")
    v.add_argument("dir", type=Path, help="dataset folder (holds manifest.json)")
    v.add_argument("--max-failures", type=_nonnegative, default=50,
                   help="failures to list; all are counted (default: 50)")

    from .export import add_cli as add_export_cli
    from .show import add_cli as add_show_cli

    add_export_cli(sub)
    add_show_cli(sub)

    sub.add_parser("recipes", help="list the recipes shipped in recipes/, each with its description")
    return parser


def _library_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--assets", type=Path, action="append", metavar="LIB", default=[],
                        help="asset library made by `refspatial assets import` (repeat for several)")
    parser.add_argument("--asset-share", type=float, metavar="F",
                        help="share of each scene's objects drawn from the libraries, 0..1 (default: the "
                        "recipe's libraries.share, else 0.5)")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except KeyboardInterrupt:
        print("refspatial: interrupted; complete shards are kept, run the same command to finish", file=sys.stderr)
        return 130
    except _user_errors() as exc:
        print(f"refspatial: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


def _user_errors() -> tuple[type[BaseException], ...]:
    from .assets import CatalogueError
    from .export import ExportError
    from .report import ReportError
    from .show import ShowError
    from .recipe import RecipeError
    from .records import ShardError
    from .shards import RunError
    from .library import LibraryError
    from .manifest import ManifestError

    return (LibraryError, RecipeError, CatalogueError, RunError, ShardError, ExportError, ReportError, ShowError,
            ManifestError, FileNotFoundError, NotADirectoryError)


def _generate(args: argparse.Namespace) -> int:
    """Exit 0 when the dataset is complete, 1 when some shard failed (message says how to
    finish), 2 for a usage error; Ctrl-C or SIGTERM keeps complete shards (main says so)."""
    from .assets import load_catalogue
    from .compose import category_pool
    from .executors import choose_executor, sigterm_as_interrupt
    from .progress import RunProgress, dry_run, format_plan
    from .recipe import load_recipe
    from .shards import RunError, RunFailed, generate

    executor = choose_executor(args.executor, args.address, args.workers, args.gpus_per_task)
    from .library import attach

    recipe, catalogue = attach(load_recipe(args.recipe), load_catalogue(), args.assets, args.asset_share)
    try:
        category_pool(recipe, catalogue)
    except ValueError as exc:
        raise RunError(str(exc)) from None
    if args.dry_run:
        if args.workers > 1 or args.executor == "ray":
            os.environ["LP_NUM_THREADS"] = "1"  # calibrate at a worker's speed (set before any GL)
        print(format_plan(dry_run(args.out, recipe, catalogue, args.scenes, args.seed, args.workers,
                                  args.scenes_per_shard, args.calibrate, None if executor else os.cpu_count())))
        return 0
    damaged = _damaged_manifest(args.out)
    # Quiet runs keep their progress off the terminal but still count what they made.
    progress, manifest, failed = RunProgress(io.StringIO() if args.quiet else None), None, None
    with sigterm_as_interrupt():
        try:
            manifest = generate(args.out, recipe, catalogue, args.scenes, args.seed, args.workers,
                                args.scenes_per_shard, progress=progress, executor=executor)
        except RunFailed as exc:
            failed = exc
        finally:
            progress.close(finished=manifest is not None)
    if failed:
        print(f"refspatial: error: {failed}", file=sys.stderr)
        return 1
    if damaged:
        print(f"refspatial: {args.out / 'manifest.json'} was damaged ({damaged}); rebuilt it from the shards' sidecars",
              file=sys.stderr)
    print(_outcome(manifest, progress.scenes, args.out))
    return 0


def _outcome(manifest: dict, made: int, out: Path) -> str:
    """What the folder holds now, and how much of it this run made."""
    from .counted import counted

    holds = (f"{counted(manifest['records'], 'record')}, {manifest['qa']} QA from {counted(manifest['scenes'], 'scene')} "
             f"({manifest['rejected']['count']} rejected)")
    if made == manifest["scenes"]:
        return f"wrote {holds} to {out}"
    if made == 0:
        return f"nothing to do: {out} already holds {holds}"
    return f"made {made} of {counted(manifest['scenes'], 'scene')}; {out} now holds {holds}"


def _damaged_manifest(out: Path) -> str | None:
    """What is wrong with ``out``'s manifest when one is there but unusable (a run rebuilds it)."""
    from .manifest import MANIFEST, manifest_problem

    try:
        text = (out / MANIFEST).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None  # none there (or unreadable: the run's own checks say so)
    try:
        return manifest_problem(json.loads(text))
    except json.JSONDecodeError:
        return "not valid JSON"


def _stats(args: argparse.Namespace) -> int:
    from .stats import collect, format_text, load_manifest

    if args.report is not None and args.report.suffix != ".html":
        raise FileNotFoundError(f"--report {args.report}: expected a path ending in .html")
    stats = collect(*args.dir)
    print(json.dumps(stats, indent=1) if args.json else format_text(stats))
    if args.report:
        from .report import write_report
        from .stats import merge_manifests

        manifest = merge_manifests([load_manifest(d) for d in args.dir])
        print(f"wrote {write_report(stats, manifest, args.report)}", file=sys.stderr)
    return 0


def _scene(args: argparse.Namespace) -> int:
    from .assets import load_catalogue
    from .compose import SceneRejected
    from .physics import write_mjcf
    from .pipeline import build_scene
    from .recipe import load_recipe
    from .shards import RunError

    from .library import attach

    recipe, catalogue = attach(load_recipe(args.recipe), load_catalogue(), args.assets, args.asset_share)
    if args.mjcf.suffix != ".xml":
        raise RunError(f"--mjcf {args.mjcf}: expected a path ending in .xml")
    try:
        scene = build_scene(recipe, catalogue, args.seed)
    except SceneRejected as exc:
        raise RunError(f"scene {args.seed} of recipe {recipe.name} was rejected ({exc}); try another --seed") from None
    try:
        args.mjcf.parent.mkdir(parents=True, exist_ok=True)
        path = write_mjcf(scene, catalogue.materials, args.mjcf)
    except OSError as exc:
        raise RunError(f"cannot write {args.mjcf} ({exc.strerror}); choose another --mjcf path") from None
    print(f"wrote {path} ({len(scene.objects)} objects)")
    return 0


def _verify(args: argparse.Namespace) -> int:
    from .counted import counted
    from .verify import verify

    report = verify(args.dir)
    for line in report.failures[: args.max_failures]:
        print(f"FAIL {line}")
    if len(report.failures) > args.max_failures:
        print(f"... and {counted(len(report.failures) - args.max_failures, 'more failure')}")
    print(f"verified {counted(report.shards, 'shard')}, {counted(report.records, 'record')}, {report.qa} QA: "
          f"{counted(len(report.failures), 'failure')}")
    return 1 if report.failures else 0


def _show(args: argparse.Namespace) -> int:
    from .show import run

    return run(args)


def _export(args: argparse.Namespace) -> int:
    return args.func(args)


def _assets(args: argparse.Namespace) -> int:
    """Exit 0 when a library was written (skipped meshes are listed, one line each), 2 when
    nothing could be imported or the input is unusable."""
    from .library_import import import_library

    summary = import_library(args.src, args.out, args.workers,
                             on_skip=lambda rel, reason: print(f"skipped {rel}: {reason}", file=sys.stderr))
    print(f"imported {summary.imported} assets ({summary.cached} from the cache), skipped {len(summary.skipped)}, "
          f"into {summary.out} (library sha256 {summary.sha256[:16]})")
    return 0


def _recipes(args: argparse.Namespace) -> int:
    """Each recipe with the description its own file gives (not one inherited through
    ``extends``, which would describe the parent); loading checks every recipe too."""
    import yaml

    from .recipe import available, load_recipe

    names = available()
    width = max(map(len, names), default=0)
    for name in names:
        own = yaml.safe_load(load_recipe(name).text) or {}
        print(f"{name:<{width}}  {own.get('description') or '(no description)'}")
    return 0


COMMANDS = {"generate": _generate, "stats": _stats, "scene": _scene, "verify": _verify, "export": _export,
            "show": _show, "assets": _assets,
            "recipes": _recipes}

if __name__ == "__main__":
    raise SystemExit(main())
