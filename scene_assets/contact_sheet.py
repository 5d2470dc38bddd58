"""Render every catalogue category with MuJoCo into one labelled grid (``docs/assets.png``).

The sheet is how a person checks that each procedural shape reads as the thing it is named:
every tile shows one instance from a three-quarter view of its semantic front (+x), lit like
the tabletop recipe, with its catalogue key, colour and size. Usage:

    python scene_assets/contact_sheet.py [--out docs/assets.png] [--seed 0] [--only mug,pan]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import refspatial  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
import cv2  # noqa: E402
import mujoco  # noqa: E402

from refspatial.assets import Catalogue, MaterialSpec, build_asset, load_catalogue  # noqa: E402
from refspatial.mjcf import ROOM_GROUP, SpecOptions, add_objects  # noqa: E402
from refspatial.render import room_casts_no_shadow  # noqa: E402
from refspatial.scene import Asset, PlacedObject, Pose  # noqa: E402

TILE = (240, 180)  # width, height of one tile in pixels
AZIMUTH_DEG = 215.0  # camera on the front (+x) side, a little to the left of the front
ELEVATION_DEG = -28.0
LABEL_PX = 16


def asset_spec(asset: Asset, materials: dict[str, MaterialSpec]) -> mujoco.MjSpec:
    """A floor, a sun and the asset, added by the generator's own code (textures and all)."""
    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth, spec.visual.global_.offheight = TILE
    spec.visual.quality.shadowsize = 1024
    spec.visual.headlight.ambient = [0.3, 0.3, 0.3]
    spec.visual.headlight.diffuse = [0.3, 0.3, 0.3]
    spec.add_material(name="floor", rgba=[0.80, 0.78, 0.74, 1.0], specular=0.05)
    # In the room group, like a scene's floor: it casts no shadow, so it shows no acne.
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], material="floor", group=ROOM_GROUP)
    spec.stat.extent, spec.stat.center = 0.6, [0.0, 0.0, 0.05]  # the shadow map covers the object, not the floor
    spec.worldbody.add_light(
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        dir=[-0.3, 0.4, -0.85],
        pos=[0.6, -0.8, 1.7],
        diffuse=[0.6, 0.6, 0.6],
        specular=[0.2, 0.2, 0.2],
        castshadow=True,
        bulbradius=0.02,
    )
    add_objects(spec, [PlacedObject(0, asset, Pose((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)))], materials,
                SpecOptions(dynamic=False))
    return spec


def render_tile(asset: Asset, materials: dict[str, MaterialSpec]) -> np.ndarray:
    """(H, W, 3) uint8 view of one asset, framed so its bounding sphere fills the tile."""
    model = asset_spec(asset, materials).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lo, hi = asset.visual.bounds_m
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (lo + hi) / 2
    radius = float(np.linalg.norm(hi - lo)) / 2
    camera.distance = 1.15 * radius / math.sin(math.radians(model.vis.global_.fovy) / 2)
    camera.azimuth, camera.elevation = AZIMUTH_DEG, ELEVATION_DEG
    renderer = mujoco.Renderer(model, height=TILE[1], width=TILE[0])
    try:
        renderer.update_scene(data, camera=camera)
        room_casts_no_shadow(model, renderer.scene)
        return renderer.render().copy()
    finally:
        renderer.close()


def label(tile: np.ndarray, lines: list[str]) -> np.ndarray:
    out = tile.copy()
    for k, text in enumerate(lines):
        y = LABEL_PX * (k + 1) - 3
        cv2.putText(out, text, (5, y), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 3, cv2.LINE_AA)
        cv2.putText(out, text, (5, y), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (20, 20, 20), 1, cv2.LINE_AA)
    return out


def sheet(catalogue: Catalogue, categories: list[str], seed: int, columns: int) -> np.ndarray:
    """Tiles in catalogue order (grouped as the catalogue lists them), one instance each, in the
    category's first colour that is not black (black hides shape on a sheet this small)."""
    tiles = []
    for key in categories:
        color = next((c for c in catalogue.categories[key].colors if c != "black"), None)
        asset = build_asset(catalogue, key, np.random.default_rng(seed), color=color)
        size_cm = " x ".join(f"{v * 100:.0f}" for v in asset.size_m)
        group = catalogue.categories[key].group
        tiles.append(label(render_tile(asset, catalogue.materials), [key, f"{group}", f"{size_cm} cm"]))
    rows = math.ceil(len(tiles) / columns)
    blank = np.full_like(tiles[0], 255)
    tiles += [blank] * (rows * columns - len(tiles))
    return np.vstack([np.hstack(tiles[r * columns : (r + 1) * columns]) for r in range(rows)])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "assets.png")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--columns", type=int, default=10)
    parser.add_argument("--only", default="", help="comma-separated catalogue keys (default: all)")
    parser.add_argument("--catalogue", type=Path, default=None)
    args = parser.parse_args(argv)
    catalogue = load_catalogue(args.catalogue)
    keys = [k for k in args.only.split(",") if k] or list(catalogue.categories)
    image = sheet(catalogue, keys, args.seed, min(args.columns, len(keys)))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote {args.out} ({image.shape[1]}x{image.shape[0]}, {args.out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
