"""The room, the table and the lights as MuJoCo geoms: textured floor, walls with skirting, a
ceiling, a window and a door, background furniture, and a sun plus lamps.

Room geoms are in ``ROOM_GROUP``: the renderer keeps them out of the shadow map (a wall or
the ceiling would otherwise shade the whole table under a low sun), and nothing of the room
collides except the floor.
"""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import mujoco
import numpy as np

from .scene import BOARD_M, LEG_HALF_M, LEG_INSET_M, Light, Prop, Room, Scene, Surface, Texture
from .textures import kelvin_rgb

ROOM_GROUP = 2  # drawn, casts no shadow (render.py), never an object
TABLE_THICKNESS_M = 0.03
SHADOW_SINK_M = 0.006  # how far below a top its hidden shadow caster lies (inside the slab, never seen)
WALL_THICKNESS_M = 0.1
SKIRTING_M = (0.012, 0.08)  # depth, height
WINDOW_GLOW = 0.85  # emission of the window's pane: daylight seen through it
BASE_DIFFUSE = 0.55  # a sun of intensity 1 (white things stay below clipping with lamps and the headlight)
SUN_DISTANCE_M = 1.2  # the sun's position before the aim point: inside the room, under the ceiling
BOX, CYL, PLANE = mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_PLANE


def add_texture(spec: mujoco.MjSpec, name: str, texture: Texture, folder: Path | None = None) -> str:
    """A 2-D texture from an image: in memory (MuJoCo's first data row is v = 0, the image's
    bottom row), or, with ``folder``, as a PNG written there (MJCF cannot hold image data)."""
    if spec.texture(name) is not None:
        return name
    if folder is not None:
        filename = f"{re.sub(r'[^A-Za-z0-9_.-]', '_', name)}.png"
        cv2.imwrite(str(folder / filename), np.ascontiguousarray(texture.rgb[..., ::-1]))
        # MuJoCo maps a file's first row to v = 0; vflip keeps the PNG upright for people and tools.
        spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, file=filename, vflip=True)
        return name
    h, w, _ = texture.rgb.shape
    tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=w, height=h, nchannel=3)
    tex.data = np.ascontiguousarray(np.flipud(texture.rgb)).tobytes()
    return name


def _surface_material(spec: mujoco.MjSpec, name: str, surface: Surface, folder: Path | None, specular: float = 0.1,
                      shininess: float = 0.2, reflectance: float = 0.0) -> str:
    mat = spec.add_material(name=name, specular=specular, shininess=shininess, reflectance=reflectance)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = add_texture(spec, f"{name}_tex", surface.texture, folder)
    mat.texuniform = True
    mat.texrepeat = [1.0 / surface.tile_m, 1.0 / surface.tile_m]
    return name


def add_room(spec: mujoco.MjSpec, scene: Scene, friction: tuple[float, float, float], visual: bool = True,
             folder: Path | None = None) -> None:
    """The room; without `visual`, only what physics touches (floor, table, boards), untextured.
    With `folder`, textures are written there as PNG files (an MJCF export)."""
    room, t = scene.room, scene.table
    world = spec.worldbody
    hx, hy = (s / 2 for s in room.size_m)
    # On a floor scene the floor is the support physics calls "table".
    floor_name = "table" if t.surface == "floor" else "floor"
    if not visual:
        world.add_geom(name=floor_name, type=PLANE, size=[hx, hy, 0.1], friction=friction, condim=6)
        if t.surface == "table":
            _table(spec, scene, None, friction)
        return
    top = _surface_material(spec, "table_mat", room.top, folder, specular=0.25, shininess=0.35)
    floor = _surface_material(spec, "floor_mat", room.floor, folder, specular=0.15, shininess=0.3)
    wall = _surface_material(spec, "wall_mat", room.wall, folder, specular=0.03, shininess=0.05)
    wood = _surface_material(spec, "furniture_mat", room.furniture, folder, specular=0.2, shininess=0.3)
    # The floor draws no shadow of its own (ROOM_GROUP): a plane that is its own occluder in the
    # shadow map is where shadow acne shows, and only what stands on it should shade it.
    world.add_geom(name=floor_name, type=PLANE, size=[hx, hy, 0.1], material=floor, friction=friction, condim=6,
                   group=ROOM_GROUP)
    _walls(spec, room, wall)
    if t.surface == "table":
        _table(spec, scene, top, friction)
    for k, prop in enumerate(room.props):
        if prop.kind == "window":  # the only prop with a texture of its own (an MJCF export writes it)
            _window(spec, f"prop{k}", prop, room, wood, folder)
        elif prop.kind == "shelf":
            # A bookcase full of spines behind a scene with a book makes "the book" name dozens of
            # things to a reader (annotator): its boards then stand empty.
            _shelf(spec, f"prop{k}", prop, room, wood,
                   spines=not any(o.asset.category == "book" for o in scene.objects))
        else:
            _PROPS[prop.kind](spec, f"prop{k}", prop, room, wood)
    add_lights(spec, scene)


def _geom(spec: mujoco.MjSpec, **kw) -> None:
    spec.worldbody.add_geom(group=ROOM_GROUP, contype=0, conaffinity=0, **kw)


def _walls(spec: mujoco.MjSpec, room: Room, wall: str) -> None:
    hx, hy = (s / 2 for s in room.size_m)
    h, w = room.height_m, WALL_THICKNESS_M
    ds, hs = SKIRTING_M
    skirt = spec.add_material(name="skirting_mat", rgba=[*(0.9 * c for c in room.wall.rgb), 1.0], specular=0.2)
    for axis in (0, 1):
        for sign in (-1, 1):
            size = [hx + w, hy + w, h / 2]
            size[axis] = w / 2
            pos = [0.0, 0.0, h / 2]
            pos[axis] = sign * ((hx, hy)[axis] + w / 2)
            _geom(spec, type=BOX, size=size, pos=pos, material=wall)
            size, pos = list(size), list(pos)
            size[axis], size[2] = ds / 2, hs / 2
            pos[axis], pos[2] = sign * ((hx, hy)[axis] - ds / 2), hs / 2
            size[1 - axis] = (hx, hy)[1 - axis]
            _geom(spec, type=BOX, size=size, pos=pos, material=skirt.name)
    _geom(spec, type=BOX, size=[hx + w, hy + w, w / 2], pos=[0, 0, h + w / 2], material=wall)  # ceiling


def _table(spec: mujoco.MjSpec, scene: Scene, material: str | None, friction) -> None:
    """Top, shelf boards and legs. Drawn for the renderer, the top and the boards cast no shadow
    themselves (ROOM_GROUP): a slab hidden inside each, its top SHADOW_SINK_M lower, casts it
    instead, so the floor and lower boards are still shaded while the top cannot shadow its own
    surface (the speckled acne of a plane in its own shadow map)."""
    t = scene.table
    world = spec.worldbody
    half = [t.size_m[0] / 2, t.size_m[1] / 2, TABLE_THICKNESS_M / 2]
    slabs = [("table", t.top_z_m, TABLE_THICKNESS_M)]
    slabs += [(f"board{k}", t.top_z_m + h, BOARD_M) for k, h in enumerate(t.levels_m)]  # supports, named
    for name, top, thick in slabs:
        drawn = {} if material is None else {"material": material, "group": ROOM_GROUP}
        world.add_geom(name=name, type=BOX, size=[half[0], half[1], thick / 2], pos=[0, 0, top - thick / 2],
                       friction=friction, condim=6, **drawn)
        if material is not None:
            sunk = [half[0] - SHADOW_SINK_M, half[1] - SHADOW_SINK_M, thick / 2 - SHADOW_SINK_M]
            world.add_geom(type=BOX, size=sunk, pos=[0, 0, top - thick / 2 - SHADOW_SINK_M / 2], material=material,
                           contype=0, conaffinity=0)
    if material is None:  # physics: legs touch nothing (the objects rest on the top and boards)
        return
    # Legs, continued up as posts to the highest board on a shelf.
    leg_h = (t.top_z_m + (max(t.levels_m) if t.levels_m else 0.0) - TABLE_THICKNESS_M) / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            world.add_geom(type=BOX, size=[LEG_HALF_M, LEG_HALF_M, leg_h],
                           pos=[sx * (half[0] - LEG_INSET_M), sy * (half[1] - LEG_INSET_M), leg_h],
                           material=material, contype=0, conaffinity=0)


def _frame(prop: Prop) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prop origin (base centre) and its x (into the room) and y axes in the world."""
    c, s = np.cos(prop.yaw_rad), np.sin(prop.yaw_rad)
    return np.array(prop.pos_world_m), np.array([c, s, 0.0]), np.array([-s, c, 0.0])


def _block(spec, prop: Prop, x: float, y: float, z: float, size, material: str | None = None, rgba=None) -> None:
    """A box at (x, y, z) in the prop's frame (z: height of its centre), half sizes `size`."""
    o, ax, ay = _frame(prop)
    pos = o + x * ax + y * ay + np.array([0, 0, z])
    quat = [np.cos(prop.yaw_rad / 2), 0, 0, np.sin(prop.yaw_rad / 2)]
    kw = {"material": material} if material else {"rgba": list(rgba)}
    _geom(spec, type=BOX, size=list(size), pos=pos.tolist(), quat=quat, **kw)


def _window(spec, name: str, prop: Prop, room: Room, wood: str, folder: Path | None = None) -> None:
    """A framed window; its pane shows the world outside (room.outdoors), lit by daylight."""
    _, w, h = prop.size_m
    sill = prop.pos_world_m[2]
    pane = spec.add_material(name=f"{name}_pane", emission=WINDOW_GLOW, specular=0.6)
    if room.outdoors is not None:
        # A box face maps a texture's first row to its top: the image goes in as it is, while
        # add_texture turns images for meshes' v-up coordinates; so hand it the image upside down.
        upright = Texture(room.outdoors.texture.key, np.ascontiguousarray(np.flipud(room.outdoors.texture.rgb)))
        pane.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = add_texture(spec, f"{name}_view", upright, folder)
    else:
        pane.rgba = [0.78, 0.86, 0.95, 1.0]
    _block(spec, prop, 0.006, 0, sill + h / 2, (0.006, w / 2, h / 2), pane.name)
    bar = 0.035
    frame = [0.92, 0.92, 0.9, 1]
    for z in (sill + bar / 2, sill + h / 2, sill + h - bar / 2):  # sill, transom, head
        _block(spec, prop, 0.015, 0, z, (0.015, w / 2, bar / 2), rgba=frame)
    for y in (-w / 2 + bar / 2, 0.0, w / 2 - bar / 2):  # jambs and the mullion
        _block(spec, prop, 0.015, y, sill + h / 2, (0.015, bar / 2, h / 2), rgba=frame)


def _door(spec, name: str, prop: Prop, room: Room, wood: str) -> None:
    _, w, h = prop.size_m
    _block(spec, prop, 0.02, 0, h / 2, (0.02, w / 2, h / 2), wood)
    for y in (-w / 2, w / 2):
        _block(spec, prop, 0.025, y, h / 2, (0.025, 0.03, h / 2 + 0.03), rgba=[0.9, 0.9, 0.88, 1])
    _block(spec, prop, 0.06, w / 2 - 0.1, 1.0, (0.02, 0.05, 0.012), rgba=[0.75, 0.75, 0.78, 1])


def _cabinet(spec, name: str, prop: Prop, room: Room, wood: str) -> None:
    d, w, h = prop.size_m
    _block(spec, prop, d / 2, 0, h / 2 + 0.04, (d / 2, w / 2, h / 2 - 0.04), wood)
    _block(spec, prop, d / 2 - 0.02, 0, 0.02, (d / 2 - 0.03, w / 2 - 0.03, 0.02), rgba=[0.1, 0.1, 0.1, 1])
    for y in (-w / 4, w / 4):  # two doors with handles
        _block(spec, prop, d + 0.002, y, h / 2 + 0.04, (0.002, w / 4 - 0.01, h / 2 - 0.08), wood)
        _block(spec, prop, d + 0.012, y + (0.1 if y < 0 else -0.1) * w / 2, h * 0.75, (0.01, 0.008, 0.05),
               rgba=[0.7, 0.7, 0.72, 1])


def _shelf(spec, name: str, prop: Prop, room: Room, wood: str, spines: bool = True) -> None:
    d, w, h = prop.size_m
    t = 0.02
    for y in (-w / 2 + t / 2, w / 2 - t / 2):
        _block(spec, prop, d / 2, y, h / 2, (d / 2, t / 2, h / 2), wood)
    _block(spec, prop, t / 2, 0, h / 2, (t / 2, w / 2, h / 2), wood)
    boards = 5
    palette = [[0.6, 0.15, 0.12, 1], [0.15, 0.3, 0.55, 1], [0.2, 0.45, 0.25, 1], [0.85, 0.8, 0.65, 1],
               [0.25, 0.22, 0.2, 1], [0.75, 0.55, 0.2, 1]]
    for k in range(boards):
        z = k * (h - t) / (boards - 1)
        _block(spec, prop, d / 2, 0, z + t / 2, (d / 2, w / 2 - t, t / 2), wood)
        if k == boards - 1 or not spines:
            continue
        y, j = -w / 2 + 2 * t, 0
        gap = (h - t) / (boards - 1)
        while y < w / 2 - 3 * t:  # rows of book spines: deterministic from the shelf's size
            bw = 0.02 + 0.015 * ((k * 7 + j * 3) % 4)
            bh = gap * (0.6 + 0.08 * ((k + j * 5) % 4))
            _block(spec, prop, d / 2, y + bw / 2, z + t + bh / 2, (d / 2 - 0.03, bw / 2, bh / 2),
                   rgba=palette[(k * 5 + j) % len(palette)])
            y, j = y + bw + 0.002, j + 1


def _sofa(spec, name: str, prop: Prop, room: Room, wood: str) -> None:
    d, w, h = prop.size_m
    fabric = spec.add_material(name=f"{name}_fabric", rgba=list(_fabric_rgb(prop)), specular=0.02)
    seat = 0.42
    _block(spec, prop, d / 2 + 0.05, 0, seat / 2, (d / 2, w / 2 - 0.1, seat / 2), fabric.name)
    _block(spec, prop, 0.1, 0, h / 2, (0.1, w / 2, h / 2), fabric.name)
    for y in (-w / 2 + 0.1, w / 2 - 0.1):
        _block(spec, prop, d / 2 + 0.05, y, 0.3, (d / 2, 0.1, 0.3), fabric.name)


def _fabric_rgb(prop: Prop) -> tuple[float, float, float, float]:
    tones = [(0.35, 0.38, 0.45, 1.0), (0.55, 0.5, 0.42, 1.0), (0.3, 0.42, 0.35, 1.0), (0.5, 0.3, 0.28, 1.0)]
    return tones[int(abs(prop.pos_world_m[0] * 100 + prop.pos_world_m[1] * 10)) % len(tones)]


def _plant(spec, name: str, prop: Prop, room: Room, wood: str) -> None:
    d, w, h = prop.size_m
    o, ax, _ = _frame(prop)
    centre = o + ax * d / 2
    r = min(d, w) / 2
    _geom(spec, type=CYL, size=[0.6 * r, 0.15], pos=[*centre[:2], 0.15], rgba=[0.6, 0.35, 0.25, 1])
    leaves = [0.16, 0.42, 0.2, 1]
    for k, z in enumerate(np.linspace(0.4, h - r * 0.6, 3)):
        a = 1.3 * k
        off = 0.25 * r * np.array([np.cos(a), np.sin(a)])
        _geom(spec, type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=[r * 0.9, r * 0.8, r * 0.7],
              pos=[*(centre[:2] + off), float(z)], rgba=leaves)


_PROPS = {"window": _window, "door": _door, "cabinet": _cabinet, "shelf": _shelf, "sofa": _sofa, "plant": _plant}


def add_lights(spec: mujoco.MjSpec, scene: Scene) -> None:
    """The sun casts the shadows (soft as its radius); lamps only add light."""
    aim = np.array([*_objects_centre(scene), scene.table.top_z_m])
    for k, light in enumerate(scene.lights):
        tint = np.array(kelvin_rgb(light.kelvin))
        diffuse = (BASE_DIFFUSE * light.intensity * tint).tolist()
        if light.kind == "sun":
            d = np.array(light.dir_world)
            spec.worldbody.add_light(
                name="sun" if k == 0 else f"sun{k}", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=d.tolist(),
                pos=(aim - SUN_DISTANCE_M * d).tolist(), diffuse=diffuse, specular=(0.25 * tint).tolist(),
                ambient=(0.12 * tint).tolist(), castshadow=True, bulbradius=light.shadow_m,
            )
        else:
            spec.worldbody.add_light(
                name=f"lamp{k}", type=mujoco.mjtLightType.mjLIGHT_SPOT, dir=list(light.dir_world),
                pos=list(light.pos_world_m), diffuse=diffuse, specular=(0.1 * tint).tolist(),
                ambient=[0.0, 0.0, 0.0], castshadow=False, cutoff=75.0, exponent=2.0, attenuation=[1.0, 0.0, 0.0],
            )


def _objects_centre(scene: Scene) -> tuple[float, float]:
    """Middle of the objects' positions on the ground plane (the origin when there are none)."""
    if not scene.objects:
        return 0.0, 0.0
    xy = np.array([o.pose.pos_world_m[:2] for o in scene.objects])
    lo, hi = xy.min(0), xy.max(0)
    return float((lo[0] + hi[0]) / 2), float((lo[1] + hi[1]) / 2)
