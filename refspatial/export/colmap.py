"""Each scene as a COLMAP reconstruction: known cameras and poses, 3-D points from depth.

No structure from motion runs: the poses and intrinsics are the renderer's, and the points
are back-projected from the metric depth. A point seeds from one view's pixel centre
(every ``stride``-th pixel with a surface) and its track also gets every other view that
sees it: it projects inside that image and that view's depth there agrees within
``depth_tolerance_m`` (so occluded points are not added). Output per scene:
``<scene_id>/images/<view>.png`` and ``<scene_id>/sparse/0/`` (binary, or text with ``text``),
the layout COLMAP, nerfstudio and gsplat read.

Conventions: refspatial's K has its origin at the top-left pixel corner, as COLMAP's
(pixel centres at +0.5), so K maps to a PINHOLE camera unchanged; T_world_cam is already an
OpenCV camera, so cam_from_world is its inverse.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pycolmap

from .common import (
    ExportError,
    ExportSummary,
    backproject,
    finish,
    open_dataset,
    project,
    scenes,
    staged,
    valid_depth,
    write_png,
)


def export_colmap(dataset_dir: Path, out_dir: Path, *, stride: int = 4, depth_tolerance_m: float = 0.01,
                  text: bool = False, overwrite: bool = False) -> ExportSummary:
    """Write one reconstruction folder per scene."""
    if stride < 1 or depth_tolerance_m <= 0:
        raise ExportError(f"--stride must be >= 1 and --depth-tolerance-m > 0; got {stride}, {depth_tolerance_m}")
    dataset = open_dataset(dataset_dir, ("rgb", "depth"))
    records = points = observations = 0
    with staged(out_dir, overwrite) as tmp:
        for views in scenes(dataset):
            records += len(views)
            root = tmp / views[0]["scene"]["scene_id"]
            for s in views:
                write_png(root / "images" / f"{s['scene']['view']}.png", s["rgb"])
            rec = build_reconstruction(views, stride, depth_tolerance_m)
            (root / "sparse" / "0").mkdir(parents=True)
            (rec.write_text if text else rec.write_binary)(str(root / "sparse" / "0"))
            points += rec.num_points3D()
            observations += rec.compute_num_observations()
        counts = {"points3D": points, "observations": observations}
        options = {"stride": stride, "depth_tolerance_m": depth_tolerance_m, "text": text}
        return finish("colmap", tmp, out_dir, dataset_dir, records, counts, options)


def build_reconstruction(views: list[dict], stride: int, depth_tolerance_m: float) -> pycolmap.Reconstruction:
    """A reconstruction of one scene's views (samples with rgb and depth_m)."""
    xyz, rgb, tracks = _points(views, stride, depth_tolerance_m)
    keypoints: list[list[np.ndarray]] = [[] for _ in views]
    elements: list[list[tuple[int, int]]] = [[] for _ in range(len(xyz))]
    for j, (point_index, xy) in enumerate(tracks):
        for p, uv in zip(point_index, xy):
            elements[p].append((j + 1, len(keypoints[j])))
            keypoints[j].append(uv)
    rec = pycolmap.Reconstruction()
    for j, s in enumerate(views):
        _add_view(rec, j + 1, s, np.array(keypoints[j], dtype=np.float64).reshape(-1, 2))
    for p in range(len(xyz)):
        if not elements[p]:
            continue  # only when rounding loses a point in its own view; never seen so far
        track = pycolmap.Track([pycolmap.TrackElement(i, k) for i, k in elements[p]])
        rec.add_point3D(xyz[p], track, rgb[p])
    return rec


def _add_view(rec: pycolmap.Reconstruction, image_id: int, s: dict, keypoints: np.ndarray) -> None:
    K, T = s["K"], s["T_world_cam"]
    camera = pycolmap.Camera(model="PINHOLE", width=s["scene"]["width"], height=s["scene"]["height"],
                             params=[K[0, 0], K[1, 1], K[0, 2], K[1, 2]], camera_id=image_id)
    rec.add_camera_with_trivial_rig(camera)
    image = pycolmap.Image(name=f"{s['scene']['view']}.png", keypoints=keypoints, camera_id=image_id,
                           image_id=image_id)
    cam_from_world = np.linalg.inv(T)[:3, :]
    rec.add_image_with_trivial_frame(image, pycolmap.Rigid3d(cam_from_world))


def _points(views: list[dict], stride: int, tol: float) -> tuple[np.ndarray, np.ndarray, list]:
    """All points (N, 3), colours (N, 3) uint8, and per view (point indices, pixel xy) seen."""
    xyz, rgb = [], []
    for s in views:
        mask = valid_depth(s["depth_m"])
        grid = np.zeros_like(mask)
        grid[stride // 2::stride, stride // 2::stride] = True
        world, rc = backproject(s["depth_m"], s["K"], s["T_world_cam"], mask & grid)
        xyz.append(world)
        rgb.append(s["rgb"][rc[:, 0], rc[:, 1]])
    xyz_all, rgb_all = np.concatenate(xyz), np.concatenate(rgb).astype(np.uint8)
    seen = [_seen_by(xyz_all, s, tol) for s in views]
    return xyz_all, rgb_all, seen


def _seen_by(xyz: np.ndarray, s: dict, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the points this view sees unoccluded, and where (continuous pixel xy)."""
    depth = s["depth_m"]
    h, w = depth.shape
    uv, z = project(xyz, s["K"], s["T_world_cam"])
    inside = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    idx = np.flatnonzero(inside)
    cols, rows = uv[idx, 0].astype(np.int64), uv[idx, 1].astype(np.int64)
    d = depth[rows, cols]
    ok = valid_depth(d) & (np.abs(d - z[idx]) <= tol)
    return idx[ok], uv[idx[ok]]
