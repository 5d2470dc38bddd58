"""The annotation that says what an imported mesh is: read from a YAML file beside the mesh or
from one row of an annotation table, and validated, every problem naming the file and the key
(the keys are listed in ``refspatial.mesh_import``'s docstring)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

COACD_DEFAULTS: dict[str, Any] = {  # CoACD's own defaults, with the part count capped for MuJoCo
    "threshold": 0.05,
    "max_convex_hull": 32,
    "preprocess_mode": "auto",
    "preprocess_resolution": 50,
    "resolution": 2000,
    "mcts_nodes": 20,
    "mcts_iterations": 150,
    "mcts_max_depth": 3,
    "seed": 0,
}
_REQUIRED = ("category", "name", "plural", "color", "up", "front", "licence", "source")
_OPTIONAL = ("front_side", "scale", "size_m", "collision")
_AXIS = re.compile(r"^([+-]?)([xyz])$")


class MeshImportError(ValueError):
    """A mesh or annotation that cannot be imported; one line naming the file, key and fix."""


@dataclass(frozen=True)
class MeshAnnotation:
    category: str
    name: str
    plural: str
    color: str
    up: tuple[float, float, float]  # the file's up axis, unit, file frame
    front: tuple[float, float, float]  # the semantic front, file frame
    licence: str
    source: str
    front_side: str = "front"
    scale: float | None = None  # metres per file unit
    size_m: float | None = None  # or: the longest extent after import
    collision: dict[str, Any] = field(default_factory=lambda: {"method": "coacd"})

    @property
    def licence_text(self) -> str:
        """What an Asset records: the licence and, for attribution, where the mesh came from."""
        return f"{self.licence}; source: {self.source}"


# ---------------------------------------------------------------- annotation


def annotation_path_for(mesh_path: Path) -> Path:
    return Path(mesh_path).with_suffix(".yaml")


def load_annotation(path: Path) -> MeshAnnotation:
    """Read and validate an annotation file; every problem names the file and the key."""
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise MeshImportError(f"{path}: cannot read the annotation ({' '.join(str(exc).split())})") from exc
    return annotation_from_dict(doc, path)


def annotation_from_dict(doc: Any, path: Path | str) -> MeshAnnotation:
    """Validate an annotation given as a mapping; `path` names where it came from in errors."""
    if not isinstance(doc, dict):
        raise MeshImportError(f"{path}: expected a mapping of {', '.join(_REQUIRED)}")
    for key in (k for k in _REQUIRED if k not in doc):
        raise MeshImportError(f"{path}: missing key {key!r}; add it (required: {', '.join(_REQUIRED)})")
    for key in (k for k in doc if k not in _REQUIRED + _OPTIONAL):
        raise MeshImportError(f"{path}: {key}: unknown key; remove it or use one of {', '.join(_REQUIRED + _OPTIONAL)}")
    texts = {k: _text(path, k, doc[k]) for k in ("category", "name", "plural", "color", "licence", "source")}
    if ("scale" in doc) == ("size_m" in doc):
        raise MeshImportError(
            f"{path}: give exactly one of scale (metres per file unit) or size_m (longest extent, metres)"
        )
    size_key = "scale" if "scale" in doc else "size_m"
    return MeshAnnotation(
        **texts,
        up=_axis(path, doc["up"]),
        front=_vector(path, doc["front"]),
        front_side=_text(path, "front_side", doc.get("front_side", "front")),
        **{size_key: _positive(path, size_key, doc[size_key])},
        collision=_collision(path, doc.get("collision")),
    )


def _text(path: Path, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise MeshImportError(f"{path}: {key}: expected a non-empty word or phrase, got {value!r}")
    return value


def _positive(path: Path, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise MeshImportError(f"{path}: {key}: expected a positive number, got {value!r}")
    return float(value)


def _axis(path: Path, value: Any) -> tuple[float, float, float]:
    match = _AXIS.match(str(value).strip().lower())
    if not match:
        raise MeshImportError(f"{path}: up: expected one of +x, -x, +y, -y, +z, -z, got {value!r}")
    vector = np.zeros(3)
    vector["xyz".index(match.group(2))] = -1.0 if match.group(1) == "-" else 1.0
    return tuple(vector)  # type: ignore[return-value]


def _vector(path: Path, value: Any) -> tuple[float, float, float]:
    ok = (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )
    if not ok or np.linalg.norm(value) < 1e-9:
        raise MeshImportError(f"{path}: front: expected a non-zero vector [x, y, z] in the file's axes, got {value!r}")
    v = np.asarray(value, dtype=float)
    return tuple(v / np.linalg.norm(v))  # type: ignore[return-value]


def _collision(path: Path, value: Any) -> dict[str, Any]:
    if isinstance(value, str):  # "collision: hull" reads as {method: hull} in YAML, JSON lines and CSV alike
        value = {"method": value.strip()}
    if value is not None and not isinstance(value, dict):
        raise MeshImportError(f"{path}: collision: expected hull, coacd or a mapping of CoACD settings")
    settings = dict(value or {"method": "coacd"})
    method = settings.pop("method", "coacd")
    if method == "hull" and not settings:
        return {"method": "hull"}
    if method != "coacd":
        raise MeshImportError(f"{path}: collision.method: expected coacd or hull, got {method!r}")
    for key in (k for k in settings if k not in COACD_DEFAULTS):
        raise MeshImportError(f"{path}: collision.{key}: unknown CoACD setting; use {', '.join(COACD_DEFAULTS)}")
    return {"method": "coacd", **COACD_DEFAULTS, **settings}


