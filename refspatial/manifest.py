"""manifest.json: what a run made, assembled from its shards' sidecars, and read back.

``generate`` writes it last, from the sidecars, so it can always be made again: a damaged
or missing manifest is never the only copy of anything. Readers (stats, verify, show) get it
through ``read_manifest``, which turns any damage into one line that says which command
rebuilds it.
"""

from __future__ import annotations

import json
import shlex
import sys
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable

from . import __version__
from .shard_job import FORMAT, FORMAT_VERSION, read_sidecar

if TYPE_CHECKING:
    from .assets import Catalogue
    from .recipe import Recipe

MANIFEST = "manifest.json"
VERSIONED_PACKAGES = ("mujoco", "numpy", "trimesh", "manifold3d", "mcap", "opencv-python-headless")
# What readers rely on, with its type: checked so that damage is one message, not a KeyError later.
_FIELDS: dict[str, type | tuple[type, ...]] = {"recipe": str, "scenes": int, "records": int, "qa": int,
                                                "shards": list, "rejected": dict}
_SHARD_FIELDS: dict[str, type | tuple[type, ...]] = {"file": str, "records": int, "sha256": str, "scenes": list}


class ManifestError(ValueError):
    """manifest.json is missing, unreadable or not a refspatial manifest; the message says how to rebuild it."""


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
        "recipe_resolved_yaml": recipe.resolved_yaml,  # loads on its own, parents and all
        "catalogue_sha256": catalogue.sha256,
        **({"libraries": catalogue.libraries.manifest()} if catalogue.libraries is not None else {}),
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


def read_manifest(root: Path | str, fields: Iterable[str] = tuple(_FIELDS),
                  shard_fields: Iterable[str] = tuple(_SHARD_FIELDS)) -> dict:
    """``root/manifest.json``, checked: a dict of the refspatial format with ``fields`` (the loader
    needs fewer than stats and verify) and ``shard_fields`` in each shard entry."""
    path = Path(root) / MANIFEST
    if not path.is_file():
        if any((Path(root) / "shards").glob("shard-*.json")):
            raise ManifestError(f"{path} not found: the run that wrote {root} did not finish; "
                                f"{rebuild_hint(Path(root))}")
        raise FileNotFoundError(f"{path} not found; pass a dataset folder that `refspatial generate --out` wrote")
    try:
        problem = manifest_problem(json.loads(path.read_text(encoding="utf-8")), fields, shard_fields)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        problem = f"not readable as JSON: {' '.join(str(exc).split())}"
    if problem:
        raise ManifestError(f"{path} is damaged ({problem}); {rebuild_hint(Path(root))}")
    return json.loads(path.read_text(encoding="utf-8"))


def manifest_problem(manifest: Any, fields: Iterable[str] = tuple(_FIELDS),
                     shard_fields: Iterable[str] = tuple(_SHARD_FIELDS)) -> str | None:
    """What makes ``manifest`` unusable, in a few words; None when it is a usable manifest."""
    if not isinstance(manifest, dict):
        return f"a JSON {type(manifest).__name__}, not an object"
    if (manifest.get("format"), manifest.get("format_version")) != (FORMAT, FORMAT_VERSION):
        return (f"format {manifest.get('format')!r} format_version {manifest.get('format_version')!r}, "
                f"expected {FORMAT!r} {FORMAT_VERSION}")
    wrong = _wrong_fields(manifest, {k: _FIELDS[k] for k in fields}, "")
    shards = manifest.get("shards") if isinstance(manifest.get("shards"), list) else []
    for i, shard in enumerate(shards):
        wrong += (_wrong_fields(shard, {k: _SHARD_FIELDS[k] for k in shard_fields}, f"shards[{i}].")
                  if isinstance(shard, dict) else [f"shards[{i}]"])
    return f"missing or mistyped: {', '.join(wrong[:3])}{' ...' if len(wrong) > 3 else ''}" if wrong else None


def _wrong_fields(obj: dict, fields: dict[str, type | tuple[type, ...]], prefix: str) -> list[str]:
    return [prefix + k for k, kind in fields.items()
            if not isinstance(obj.get(k), kind) or isinstance(obj.get(k), bool)]


def rebuild_hint(root: Path) -> str:
    """The command that rebuilds ``root``'s manifest from its sidecars, re-making only shards
    that are missing or changed, as far as the sidecars and the first shard can tell it."""
    from .recipe import available
    from .records import ShardReader

    sides = sorted((p, s) for p in (root / "shards").glob("shard-*.json") if (s := read_sidecar(p)) is not None)
    sides = [(p, s) for p, s in sides if isinstance(s.get("scenes"), list) and len(s["scenes"]) == 2]
    if not sides:
        return ("run the `refspatial generate` command that made it again (same --recipe, --seed, --scenes, "
                "--scenes-per-shard and --out): it rebuilds manifest.json and redoes only what is missing")
    first_path, first = sides[0]
    # Shard i starts at i * size; shard 0 alone only bounds the size from below, and then the
    # command line's default is the likely one.
    later = [s["scenes"][0] // i for p, s in sides if (i := int(p.stem.split("-")[1]))]
    per_shard = later[0] if later else max(first["scenes"][1] - first["scenes"][0], 25)
    try:
        meta = ShardReader(first_path.with_suffix(".mcap")).metadata()["refspatial"]
        recipe, libraries = meta["recipe"], json.loads(meta.get("libraries", "[]"))
    except Exception:  # noqa: BLE001 - a damaged shard only costs the hint its recipe name
        recipe, libraries = "RECIPE", []
    args = ["refspatial", "generate", "--scenes", str(max(s["scenes"][1] for _, s in sides)), "--recipe", recipe,
            "--seed", str(first.get("base_seed")), "--scenes-per-shard", str(per_shard), "--out", str(root)]
    args += [a for lib in libraries for a in ("--assets", str(lib.get("path")))]
    notes = [] if recipe in available() else [f"--recipe the path of recipe {recipe!r}"]
    notes += ["the same --asset-share"] if libraries else []
    note = f" ({'; '.join(notes)})" if notes else ""
    return (f"run `{shlex.join(args)}`{note}, the command that made it: "
            "it rebuilds manifest.json from the shards' sidecars and redoes only what is missing")
