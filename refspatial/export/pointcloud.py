"""Coloured point clouds (PLY, through open3d): every record's depth lifted into the world.

Each pixel centre with a surface is back-projected with K and T_world_cam into the world
frame (metres, +z up), so the clouds of a scene's views overlay without any alignment.
Sky pixels (depth at the far plane) are dropped unless ``keep_background``; with
``objects_only`` the table and floor go too (segmentation id -1). ``voxel_size_m`` > 0
averages the points of each voxel (open3d's ``voxel_down_sample``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import ExportError, ExportSummary, backproject, finish, open_dataset, samples, staged, valid_depth


def _open3d():
    """open3d, or an error that says how to fix the usual cause (libusb missing)."""
    try:
        import open3d
    except ImportError as e:  # OSError for missing shared libraries surfaces as ImportError
        raise ExportError(f"open3d does not import ({e}); on Debian/Ubuntu run "
                          "'apt-get install -y libusb-1.0-0' (make sysdeps)") from None
    return open3d


def export_pointcloud(dataset_dir: Path, out_dir: Path, *, voxel_size_m: float = 0.0, keep_background: bool = False,
                      objects_only: bool = False, ascii: bool = False, overwrite: bool = False) -> ExportSummary:
    """Write ``<scene_id>/<view>.ply`` for every record."""
    if voxel_size_m < 0:
        raise ExportError(f"--voxel-size-m must be >= 0 (0 keeps every point); got {voxel_size_m}")
    o3d = _open3d()
    fields = ("rgb", "depth", "seg") if objects_only else ("rgb", "depth")
    dataset = open_dataset(dataset_dir, fields)
    records = points = 0
    with staged(out_dir, overwrite) as tmp:
        for s in samples(dataset):
            records += 1
            cloud = _cloud(o3d, s, keep_background, objects_only)
            if voxel_size_m > 0:
                cloud = cloud.voxel_down_sample(voxel_size_m)
            path = tmp / s["scene"]["scene_id"] / f"{s['scene']['view']}.ply"
            path.parent.mkdir(parents=True, exist_ok=True)
            if not o3d.io.write_point_cloud(str(path), cloud, write_ascii=ascii):
                raise ExportError(f"open3d could not write {path.name}; check free space in OUT's folder")
            points += len(cloud.points)
        options = {"voxel_size_m": voxel_size_m, "keep_background": keep_background,
                   "objects_only": objects_only, "ascii": ascii}
        return finish("pointcloud", tmp, out_dir, dataset_dir, records, {"points": points}, options)


def _cloud(o3d, s: dict, keep_background: bool, objects_only: bool):
    depth = s["depth_m"]
    mask = (np.isfinite(depth) & (depth > 0)) if keep_background else valid_depth(depth)
    if objects_only:
        mask &= s["seg"] >= 0
    world, rc = backproject(depth, s["K"], s["T_world_cam"], mask)
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(world)
    cloud.colors = o3d.utility.Vector3dVector(s["rgb"][rc[:, 0], rc[:, 1]].astype(np.float64) / 255.0)
    return cloud
