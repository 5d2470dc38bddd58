"""Scene-family recipes: YAML data, validated once, hashed, read by every stage.

A recipe may name another with ``extends: NAME`` (a recipe in recipes/, or a .yaml file
beside the child); the child's keys override the parent's, section by section. The recipe hash is the sha256 of the resolved
recipe's canonical JSON, so reformatting the YAML does not change any scene.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import yaml

from .paths import recipes_dir


class RecipeError(ValueError):
    """A recipe that cannot be used; the message names the file, key and fix."""


@dataclass(frozen=True)
class Recipe:
    name: str
    path: Path
    data: dict[str, Any]  # resolved (extends applied) and validated
    text: str  # the YAML text of this recipe's own file, stored in the records
    hash: str

    def __getitem__(self, section: str) -> dict[str, Any]:
        return self.data[section]

    def option(self, section: str, key: str) -> Any:
        """An optional key's value, or its default. Defaults are not written into ``data``, so
        recipes that leave a key out keep the hash (and the scenes) they had before it existed."""
        return self.data.get(section, {}).get(key, OPTIONAL[section][key][1])

    @property
    def resolved_yaml(self) -> str:
        """The resolved recipe as standalone YAML: loads without its parents, to the same hash."""
        return yaml.safe_dump(self.data, sort_keys=True)


# --- the schema: section -> key -> checker -------------------------------------------------


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _range(lo: float = float("-inf"), hi: float = float("inf"), integer: bool = False) -> Callable:
    def check(v: Any) -> str | None:
        kind = "integers" if integer else "numbers"
        ok_type = (lambda x: isinstance(x, int) and not isinstance(x, bool)) if integer else _number
        if not (isinstance(v, list) and len(v) == 2 and all(ok_type(x) for x in v)):
            return f"expected [min, max] of {kind}"
        if not (lo <= v[0] <= v[1] <= hi):
            return f"expected {lo} <= min <= max <= {hi}"
        return None

    return check


def _scalar(lo: float, hi: float, integer: bool = False) -> Callable:
    def check(v: Any) -> str | None:
        if integer and not (isinstance(v, int) and not isinstance(v, bool)):
            return "expected an integer"
        if not _number(v):
            return "expected a number"
        return None if lo <= v <= hi else f"expected a value in [{lo}, {hi}]"

    return check


def _weights(keys: Callable[[Any], bool], what: str) -> Callable:
    def check(v: Any) -> str | None:
        if not isinstance(v, dict) or not v:
            return "expected a non-empty mapping of weights"
        bad = [k for k in v if not keys(k)]
        if bad:
            return f"unknown {what} {bad[0]!r}"
        if any(not _number(w) or w < 0 for w in v.values()) or sum(v.values()) <= 0:
            return "weights must be non-negative numbers with a positive sum"
        return None

    return check


def _categories(v: Any) -> str | None:
    if v == "all" or (isinstance(v, list) and v and all(isinstance(c, str) for c in v)):
        return None
    return 'expected "all" or a list of catalogue category keys'


def _textures(v: Any) -> str | None:
    allowed = {"checker", "gradient", "flat"}
    if isinstance(v, list) and v and set(v) <= allowed:
        return None
    return f"expected a non-empty list drawn from {sorted(allowed)}"


def _colors(v: Any) -> str | None:
    if isinstance(v, list) and v and all(
        isinstance(c, list) and len(c) == 3 and all(_number(x) and 0 <= x <= 1 for x in c) for c in v
    ):
        return None
    return "expected a non-empty list of [r, g, b] with components in [0, 1]"


def _levels(v: Any) -> str | None:
    if isinstance(v, list) and all(_number(x) and 0.1 <= x <= 3 for x in v) and v == sorted(set(v)):
        return None
    return "expected a list of increasing shelf-board heights above the top, each in [0.1, 3] m ([] for none)"


def _folder(v: Any) -> str | None:
    return None if v is None or (isinstance(v, str) and v.strip()) else "expected a path or null"


def _paths(v: Any) -> str | None:
    if isinstance(v, list) and all(isinstance(p, str) and p.strip() for p in v):
        return None
    return "expected a list of asset-library folders"


def _hashes(v: Any) -> str | None:
    hexdigits = set("0123456789abcdef")
    if isinstance(v, list) and all(isinstance(h, str) and len(h) == 64 and set(h) <= hexdigits for h in v):
        return None
    return "expected a list of sha256 hex digests (leave it out: runs fill it in)"


def _one_of(*allowed: str) -> Callable:
    def check(v: Any) -> str | None:
        return None if v in allowed else f"expected one of {list(allowed)}"

    return check


def _size_ranges(v: Any) -> str | None:
    if isinstance(v, list) and len(v) == 2 and all(_range(0.05, 20)(r) is None for r in v):
        return None
    return "expected [[xmin, xmax], [ymin, ymax]] in metres"


FAMILIES = ("location", "placement", "identify", "choice", "quantitative", "multiview", "visual_choice")
MAX_STEPS = 5

SCHEMA: dict[str, dict[str, Callable[[Any], str | None]]] = {
    "objects": {
        "count": _range(1, 40, integer=True),
        "categories": _categories,
        "repeat_category": _scalar(0, 1),
        "fill": _scalar(0, 1),
        "stack": _scalar(0, 1),
        "min_gap_m": _scalar(0, 0.5),
        "drop_height_m": _scalar(0, 0.2),
    },
    "table": {
        "size_m": _size_ranges,
        "top_z_m": _scalar(0, 3),  # 0 for a floor
        "colors": _colors,
        "textures": _textures,
        "region_m": _range(0.1, 5),
        "levels_m": _levels,
    },
    "camera": {
        "views": _scalar(1, 16, integer=True),
        "width": _scalar(16, 8192, integer=True),
        "height": _scalar(16, 8192, integer=True),
        "yaw_deg": _range(-360, 360),
        "pitch_deg": _range(-89, -1),
        "height_above_table_m": _range(0.05, 10),
        "fovy_deg": _range(10, 120),
        "margin_px": _scalar(0, 1000, integer=True),
        "fill": _range(0, 1),
        "attempts": _scalar(1, 1000, integer=True),
    },
    "light": {
        "intensity": _range(0, 5),
        "azimuth_deg": _range(-360, 720),
        "elevation_deg": _range(1, 90),
    },
    "physics": {
        "timestep_s": _scalar(1e-4, 0.02),
        "settle_s": _scalar(0.01, 10),
        "max_speed_m_s": _scalar(0, 10),
        "max_tilt_deg": _scalar(0, 180),
        "max_shift_m": _scalar(0, 10),
    },
    "questions": {
        "per_view": _scalar(0, 200, integer=True),
        "attempts_per_question": _scalar(1, 1000, integer=True),
        "answer_points": _scalar(1, 32, integer=True),
        "families": _weights(lambda k: k in FAMILIES, "question family"),
        "steps": _weights(lambda k: isinstance(k, int) and 1 <= k <= MAX_STEPS, "step count"),
    },
}
# Keys a recipe may leave out: section -> key -> (checker, default).
OPTIONAL: dict[str, dict[str, tuple[Callable[[Any], str | None], Any]]] = {
    "table": {
        # "floor": the surface is a room's floor (no legs, no edge in view): at_edge/at_corner are not asked
        "surface": (_one_of("table", "floor"), "table"),
    },
    "light": {
        "count": (_range(1, 3, integer=True), [1, 3]),  # a sun, then lamps under the ceiling
        "kelvin": (_range(1500, 12000), [2700, 6500]),  # colour temperature of each light
        "soft_m": (_range(0, 0.5), [0.02, 0.08]),  # the sun's radius: the softness of shadow edges
    },
    "objects": {
        "on_furniture": (_scalar(0, 1), 0.0),  # chance that an object goes on top of a piece of furniture
        # fixed shapes per procedural category, built once per process (shape_bank.py); 0: a fresh shape per object
        "shape_variants": (_scalar(0, 100000, integer=True), 0),
    },
    "room": {  # walls, floor and background around the scene (room.py); a floor scene's walls stand at its edges
        "size_m": (_size_ranges, [[6.0, 8.0], [6.0, 8.0]]),
        "height_m": (_range(2.0, 6.0), [2.6, 3.0]),
        "props": (_range(0, 8, integer=True), [1, 3]),  # background furniture along the walls
        "images": (_folder, None),  # a folder of .png/.jpg images that floors, walls and tops may use
        "sky": (_folder, None),  # an equirectangular .png/.jpg: the world outside, seen through the window
    },
    "furniture": {  # pieces standing on the surface before the objects come (catalogue group "furniture")
        "count": (_range(0, 20, integer=True), [0, 0]),
        "categories": (_categories, "all"),
    },
    "libraries": {  # asset libraries made by `refspatial assets import` (refspatial/library.py)
        "paths": (_paths, []),  # folders, relative to this recipe's folder; --assets adds more
        "share": (_scalar(0, 1), 0.5),  # share of each scene's objects drawn from them
        "sha256": (_hashes, []),  # written by the run: the libraries' content hashes (paths are dropped)
    },
}
TOP_LEVEL = {"name", "description", "extends", *SCHEMA, *OPTIONAL}


# --- loading ----------------------------------------------------------------------------------


def resolve_path(name_or_path: str) -> Path:
    """A recipe given as a file path, or as the name of a file in recipes/."""
    p = Path(name_or_path)
    # A folder that happens to share a recipe's name (an --out folder called "tabletop") is not a recipe.
    if p.suffix in (".yaml", ".yml") or p.is_file():
        if not p.is_file():
            raise RecipeError(f"recipe file {p} does not exist; pass an existing .yaml file or a recipe name")
        return p
    candidate = recipes_dir() / f"{name_or_path}.yaml"
    if not candidate.is_file():
        known = ", ".join(available()) or "none"
        raise RecipeError(f"unknown recipe {name_or_path!r}; choose one of: {known}, or pass a .yaml path")
    return candidate


def available() -> list[str]:
    return sorted(p.stem for p in recipes_dir().glob("*.yaml"))


def load_recipe(name_or_path: str) -> Recipe:
    path = resolve_path(name_or_path)
    text = path.read_text(encoding="utf-8")
    data = _resolve(path, seen=())
    _validate(path, data)
    _locate_files(path, data)
    return Recipe(name=data["name"], path=path, data=data, text=text, hash=recipe_hash(data))


def recipe_hash(data: dict[str, Any]) -> str:
    """The sha256 of the resolved recipe's canonical JSON."""
    return hashlib.sha256(json.dumps(data, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _read_yaml(path: Path) -> dict[str, Any]:
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        raise RecipeError(f"{path}:{where} is not valid YAML ({getattr(exc, 'problem', exc)}); fix the syntax") from None
    if not isinstance(raw, dict):
        raise RecipeError(f"{path}: expected a mapping of sections at the top level")
    return raw


def _resolve(path: Path, seen: tuple[Path, ...]) -> dict[str, Any]:
    if path in seen:
        raise RecipeError(f"{path}: 'extends' forms a cycle through {', '.join(p.name for p in seen)}")
    own = _read_yaml(path)
    parent_name = own.pop("extends", None)
    if parent_name is None:
        return own
    if not isinstance(parent_name, str):
        raise RecipeError(f"{path}: extends: expected the name of another recipe")
    # A parent given as a file is found beside the recipe that names it (as its room images are),
    # wherever the command runs from; a bare name is one of recipes/.
    as_file = Path(parent_name)
    if as_file.suffix in (".yaml", ".yml") and not as_file.is_absolute():
        parent_name = str(path.parent / as_file)
    try:
        parent_path = resolve_path(parent_name)
    except RecipeError as exc:  # say which file asks for the missing parent
        raise RecipeError(f"{path}: extends: {exc}") from None
    parent = _resolve(parent_path, seen + (path,))
    merged = dict(parent)
    for key, value in own.items():
        if isinstance(value, dict) and isinstance(parent.get(key), dict):
            merged[key] = {**parent[key], **value}
        else:
            merged[key] = value
    return merged


def _locate_files(path: Path, data: dict[str, Any]) -> None:
    """Make the room's image paths absolute (relative ones are read from the recipe's folder) and
    check they exist, so a wrong path fails here in one line rather than in every scene."""
    room = data.get("room", {})
    for key, want_dir in (("images", True), ("sky", False)):
        if room.get(key) is None:
            continue
        target = Path(room[key]).expanduser()
        target = target if target.is_absolute() else (path.parent / target).resolve()
        if want_dir and not target.is_dir():
            raise RecipeError(f"{path}: room.images: {target} is not a folder; point it at a folder of .png/.jpg images")
        if not want_dir and not target.is_file():
            raise RecipeError(f"{path}: room.sky: {target} is not a file; point it at an equirectangular .png or .jpg")
        room[key] = str(target)


def _validate(path: Path, data: dict[str, Any]) -> None:
    unknown = sorted(set(data) - TOP_LEVEL)
    if unknown:
        raise RecipeError(f"{path}: unknown section {unknown[0]!r}; sections are {sorted(TOP_LEVEL)}")
    if not isinstance(data.get("name"), str) or not data["name"].replace("_", "").isalnum():
        raise RecipeError(f"{path}: name: expected a short identifier such as 'tabletop'")
    for section in [*SCHEMA, *(s for s in OPTIONAL if s not in SCHEMA)]:
        required, optional = SCHEMA.get(section, {}), {k: c for k, (c, _) in OPTIONAL.get(section, {}).items()}
        values = data.get(section, {} if section not in SCHEMA else None)
        if not isinstance(values, dict):
            what = "missing section" if values is None else "expected a mapping"
            raise RecipeError(f"{path}: {section}: {what} (expected keys {sorted(required)})")
        known = {**required, **optional}
        for key in sorted(set(values) - set(known)):
            raise RecipeError(f"{path}: {section}.{key}: unknown key; known keys are {sorted(known)}")
        for key, check in known.items():
            if key not in values:
                if key in optional:
                    continue
                raise RecipeError(f"{path}: {section}.{key}: missing")
            problem = check(values[key])
            if problem:
                raise RecipeError(f"{path}: {section}.{key}: {problem}, got {values[key]!r}")
