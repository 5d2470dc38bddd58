"""What every exporter shares: reading a dataset, staging the output, images and geometry.

An export is written into a hidden sibling folder and renamed into place only when it is
complete, so OUT either holds a whole export or nothing of this run. Files are written in
manifest order with sorted JSON keys and no timestamps, so the same dataset gives the same
bytes on every run.
"""

from __future__ import annotations

import itertools
import json
import re
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Sequence

import cv2
import numpy as np

from refspatial import __version__
from refspatial.data import MANIFEST, RefSpatialDataset
from refspatial.staging import staged_folder

from .base import ExportError, ExportSummary

# MuJoCo's far clipping plane in this project: mjcf.py sets stat.extent = 2 m and keeps
# the default visual.map.zfar = 50, so sky pixels read 100 m. Depth at or beyond this
# share of it is "no surface" (sky / background), never a measurement.
FAR_PLANE_M = 100.0
FAR_FRACTION = 0.99
SUMMARY_FILE = "export.json"


# --- reading --------------------------------------------------------------------------------


def open_dataset(dataset_dir: Path, fields: Sequence[str]) -> RefSpatialDataset:
    """The dataset with only ``fields`` decoded; its load errors become one-line ExportErrors."""
    try:
        return RefSpatialDataset(dataset_dir, fields=tuple(fields))
    except (FileNotFoundError, ValueError) as e:
        raise ExportError(f"DIR {dataset_dir}: {' '.join(str(e).split())}") from None


def read_manifest(dataset_dir: Path) -> dict:
    """manifest.json as written by ``refspatial generate`` (recipe text, hashes, seeds)."""
    return json.loads((Path(dataset_dir) / MANIFEST).read_text(encoding="utf-8"))


def samples(dataset: RefSpatialDataset) -> Iterator[dict]:
    """Every record in manifest order (the dataset's unshuffled rank-0 list)."""
    for i in range(len(dataset)):
        yield dataset[i]


def scenes(dataset: RefSpatialDataset) -> Iterator[list[dict]]:
    """Records grouped by scene, views in order. A scene's views are written one after
    another (pipeline.generate_scene), so holding one group at a time suffices."""
    for _, group in itertools.groupby(samples(dataset), key=lambda s: s["scene"]["scene_id"]):
        yield list(group)


def format_points(points: list[list[float]]) -> str:
    """'[(x1, y1), ...]' with 3 decimals: the text form of stored point answers."""
    return "[" + ", ".join(f"({x:.3f}, {y:.3f})" for x, y in points) + "]"


def file_stem(key: str) -> str:
    """A record key as a file name: 'tiny-1a2b3c4d-42/view0' -> 'tiny-1a2b3c4d-42_view0'."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", key)


# --- staging ----------------------------------------------------------------------------------


@contextmanager
def staged(out_dir: Path, overwrite: bool) -> Iterator[Path]:
    """A temporary sibling of ``out_dir`` that becomes ``out_dir`` when the block ends cleanly;
    on any error it is deleted and ``out_dir`` is left as it was."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ExportError(f"OUT {out_dir} is a file; choose another OUT")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not overwrite:
        raise ExportError(f"OUT {out_dir} exists and is not empty; pass --overwrite to replace it "
                          "or choose another OUT")
    cannot = lambda why: ExportError(f"cannot write next to OUT {out_dir} ({why}); choose another OUT")  # noqa: E731
    with staged_folder(out_dir, cannot) as tmp:
        yield tmp


def finish(fmt: str, staging: Path, out_dir: Path, dataset_dir: Path, records: int,
           counts: dict[str, int], options: dict[str, Any]) -> ExportSummary:
    """Write export.json (provenance, no timestamps) and total the staged files."""
    manifest = read_manifest(dataset_dir)
    info = {
        "format": fmt,
        "options": options,
        "refspatial": __version__,
        "source": {k: manifest.get(k) for k in ("recipe", "recipe_hash", "catalogue_sha256",
                                                 "base_seed", "format", "format_version")},
        "source_shards": [{"file": s["file"], "sha256": s.get("sha256")} for s in manifest["shards"]],
        "records": records,
        "counts": counts,
    }
    write_json(staging / SUMMARY_FILE, info)
    files = [p for p in staging.rglob("*") if p.is_file()]
    return ExportSummary(fmt, Path(out_dir), records, len(files), sum(p.stat().st_size for p in files),
                         dict(counts))


# --- files --------------------------------------------------------------------------------------


def write_json(path: Path, obj: Any, indent: int | None = 1) -> None:
    """Deterministic JSON: sorted keys, UTF-8 text kept as is, trailing newline."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(obj, indent=indent, sort_keys=True, ensure_ascii=False, allow_nan=False)
    path.write_text(text + "\n", encoding="utf-8")


def png_bytes(image: np.ndarray) -> bytes:
    """PNG of an (H, W) gray or (H, W, 3) RGB uint8 image (cv2 wants BGR)."""
    if image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise ExportError(f"cv2 could not encode a {image.shape} image as PNG")
    return buf.tobytes()


def write_png(path: Path, image: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(png_bytes(image))


# --- depth and geometry -------------------------------------------------------------------


def valid_depth(depth_m: np.ndarray) -> np.ndarray:
    """True where the depth is a surface: finite, positive and short of the far plane."""
    return np.isfinite(depth_m) & (depth_m > 0) & (depth_m < FAR_FRACTION * FAR_PLANE_M)


def depth_to_png8(depth_m: np.ndarray, encoding: str = "linear") -> np.ndarray:
    """(H, W, 3) uint8 depth for the model, near bright; pixels without a surface are 0.

    ``linear``: min-max over the valid depth, nearest = 255, farthest surface = 0 (rounded).
    ``inverse``: what RoboRefer's inference path feeds its depth encoder, Depth-Anything-style
    relative inverse depth: 1 / depth, min-max normalised per image over the valid pixels,
    times 255 and truncated to uint8 as RoboRefer's API does with Depth Anything V2's output.
    Inverse depth spends the grey levels on near surfaces, where a tabletop's objects are.
    """
    if encoding not in DEPTH_ENCODINGS:
        raise ExportError(f"depth encoding {encoding!r} is unknown; choose one of {', '.join(DEPTH_ENCODINGS)}")
    valid = valid_depth(depth_m)
    out = np.zeros(depth_m.shape, np.uint8)
    if valid.any():
        d = depth_m[valid].astype(np.float64)
        out[valid] = DEPTH_ENCODINGS[encoding](d)
    return np.repeat(out[..., None], 3, axis=2)


def _linear(d: np.ndarray) -> np.ndarray:
    lo, hi = d.min(), d.max()
    near = (hi - d) / (hi - lo) if hi > lo else np.ones_like(d)  # 1 nearest, 0 farthest
    return np.round(255.0 * near).astype(np.uint8)


def _inverse(d: np.ndarray) -> np.ndarray:
    inv = 1.0 / d
    lo, hi = inv.min(), inv.max()
    near = (inv - lo) / (hi - lo) if hi > lo else np.ones_like(inv)
    return (255.0 * near).astype(np.uint8)


DEPTH_ENCODINGS = {"linear": _linear, "inverse": _inverse}


def backproject(depth_m: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray,
                mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 3) of the pixel centres under ``mask`` and their (row, col) (N, 2).

    ``depth_m`` is the distance along the optical axis, so the camera-frame point of pixel
    centre (u + 0.5, v + 0.5) is depth * K^-1 [u + 0.5, v + 0.5, 1] (OpenCV camera).
    """
    rows, cols = np.nonzero(mask)
    z = depth_m[rows, cols].astype(np.float64)
    uv1 = np.stack([cols + 0.5, rows + 0.5, np.ones_like(z)], axis=1)
    p_cam = (uv1 @ np.linalg.inv(K).T) * z[:, None]
    p_world = p_cam @ T_world_cam[:3, :3].T + T_world_cam[:3, 3]
    return p_world, np.stack([rows, cols], axis=1)


def project(points_world: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) as (x, y) with the top-left pixel corner at 0, and depths (N,)."""
    p_cam = (points_world - T_world_cam[:3, 3]) @ T_world_cam[:3, :3]
    z = p_cam[:, 2]
    uv = (p_cam @ K.T)[:, :2] / np.where(np.abs(z) > 1e-12, z, 1e-12)[:, None]
    return uv, z
