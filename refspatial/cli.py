"""The ``refspatial`` command line."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

EXIT_USAGE = 2


def _nonnegative(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a count >= 0, got {value}")
    return value


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="refspatial", description=__doc__ or "")
    parser.description = "Generate, inspect and audit multi-step spatial-referring QA data."
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    g = sub.add_parser("generate", help="compose, render and write a sharded dataset")
    g.add_argument("--scenes", type=_nonnegative, required=True, help="number of scenes to generate")
    g.add_argument("--recipe", default="tabletop", help="recipe name in recipes/ or a .yaml path (default: tabletop)")
    g.add_argument("--out", type=Path, default=Path("data"), help="output folder (default: ./data)")
    g.add_argument("--seed", type=int, default=0, help="base seed; scene i uses a seed hashed from (seed, i)")
    g.add_argument("--workers", type=_positive, default=os.cpu_count() or 1, help="worker processes (default: all cores)")
    g.add_argument("--scenes-per-shard", type=_positive, default=25, help="scenes per MCAP shard (default: 25)")
    g.add_argument("--quiet", action="store_true", help="no progress lines")

    s = sub.add_parser("stats", help="print counts of scenes, records, QA, predicates, steps and categories")
    s.add_argument("dir", type=Path)
    s.add_argument("--json", action="store_true", help="print JSON instead of text")

    c = sub.add_parser("scene", help="write one composed, settled scene as MJCF (meshes beside it)")
    c.add_argument("--recipe", default="tabletop")
    c.add_argument("--seed", type=int, required=True, help="the scene seed (a record's scene.seed)")
    c.add_argument("--mjcf", type=Path, required=True, help="output .xml path")

    sub.add_parser("recipes", help="list the recipes shipped in recipes/")
    return parser


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
    from .recipe import RecipeError
    from .records import ShardError
    from .shards import RunError

    return (RecipeError, CatalogueError, RunError, ShardError, FileNotFoundError, NotADirectoryError)


def _generate(args: argparse.Namespace) -> int:
    from .assets import load_catalogue
    from .compose import category_pool
    from .recipe import load_recipe
    from .shards import Progress, RunError, generate

    recipe = load_recipe(args.recipe)
    catalogue = load_catalogue()
    try:
        category_pool(recipe, catalogue)
    except ValueError as exc:
        raise RunError(str(exc)) from None
    manifest = generate(args.out, recipe, catalogue, args.scenes, args.seed, args.workers,
                        args.scenes_per_shard, progress=None if args.quiet else Progress())
    print(f"wrote {manifest['records']} records, {manifest['qa']} QA from {manifest['scenes']} scenes "
          f"({manifest['rejected']['count']} rejected) to {args.out}")
    return 0


def _stats(args: argparse.Namespace) -> int:
    from .stats import collect, format_text

    stats = collect(args.dir)
    print(json.dumps(stats, indent=1) if args.json else format_text(stats))
    return 0


def _scene(args: argparse.Namespace) -> int:
    from .assets import load_catalogue
    from .compose import SceneRejected
    from .physics import write_mjcf
    from .pipeline import build_scene
    from .recipe import load_recipe
    from .shards import RunError

    recipe = load_recipe(args.recipe)
    catalogue = load_catalogue()
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


def _recipes(args: argparse.Namespace) -> int:
    from .recipe import available

    print("\n".join(available()))
    return 0


COMMANDS = {"generate": _generate, "stats": _stats, "scene": _scene, "recipes": _recipes}

if __name__ == "__main__":
    raise SystemExit(main())
