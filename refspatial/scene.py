"""The scene model: plain, frozen data passed between stages.

Frames and units are in the names. World frame: metres, +z up (gravity is -z).
Object frame: origin at the centre of the object's footprint on its resting
surface, +z up, +x the object's semantic front. Camera frame (MuJoCo): the camera
looks along -z, +y is up in the image, +x is right.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .vector import length


@dataclass(frozen=True, eq=False)
class MeshData:
    """A triangle mesh in the object frame."""

    vertices_m: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int32, counter-clockwise seen from outside
    # Texture coordinates, indexed per face corner so a seam needs no split vertices (smooth
    # normals stay shared): (K, 2) float32 with v = 0 at the image's bottom row (OpenGL, glTF
    # flipped), and (M, 3) int32 indices into them. Both None for an untextured mesh.
    texcoords: np.ndarray | None = None
    face_texcoords: np.ndarray | None = None

    @cached_property
    def bounds_m(self) -> np.ndarray:
        """(2, 3) array: min corner, max corner (read-only: computed once, placement asks it per try)."""
        bounds = np.stack([self.vertices_m.min(axis=0), self.vertices_m.max(axis=0)])
        bounds.flags.writeable = False
        return bounds

    @cached_property
    def volume_m3(self) -> float:
        """Enclosed volume (every view of every scene asks it of each object's mesh)."""
        return abs(signed_volume(self.vertices_m, self.faces))


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed mesh (divergence theorem): negative when its faces point inward."""
    v = np.asarray(vertices)  # a plain array: indexing trimesh's tracked arrays costs more than the sum
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = (v[faces[:, k]].T for k in range(3))
    return float((ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)).sum() / 6.0)


@dataclass(frozen=True)
class Cavity:
    """The open space of a container, in the object frame (for inside/outside and filling)."""

    shape: str  # "cylinder" (half_extents_m[0] is the radius) or "box"
    half_extents_m: tuple[float, float]  # x, y
    floor_z_m: float  # inner floor height
    rim_z_m: float  # top of the opening


@dataclass(frozen=True, eq=False)
class Texture:
    """An image mapped onto a mesh through its texcoords. It carries the object's whole colour:
    a textured object's rgba only records the colour word's reference rgb."""

    key: str  # stable name of what made it: a generator and its parameters, or the image's sha256
    rgb: np.ndarray  # (H, W, 3) uint8, top row first (as in an image file)


@dataclass(frozen=True, eq=False)
class Asset:
    """One concrete object: geometry, look and semantics, ready to place."""

    category: str  # catalogue key, e.g. "mug"
    name: str  # short noun used in text, e.g. "mug"
    color: str  # colour word, e.g. "red"
    rgba: tuple[float, float, float, float]
    material: str  # e.g. "ceramic"
    visual: MeshData
    collision: tuple[MeshData, ...]  # convex parts; together they approximate visual
    front_local: tuple[float, float, float]  # unit vector, object frame
    front_side: str  # name of the semantic front, e.g. "handle"
    params: dict[str, float] = field(default_factory=dict)  # sampled shape parameters
    licence: str = "project-own (procedural)"
    cavity: Cavity | None = None  # containers only
    support: bool = False  # other objects may be stacked on its top face
    texture: Texture | None = None  # mapped through visual.texcoords (which must then be set)
    source: str = "procedural"  # "procedural", or the asset library it came from

    @property
    def size_m(self) -> np.ndarray:
        """Extents (x, y, z) of the visual mesh's box in the object frame."""
        b = self.visual.bounds_m
        return b[1] - b[0]


@dataclass(frozen=True)
class Pose:
    pos_world_m: tuple[float, float, float]
    quat_wxyz: tuple[float, float, float, float]

    def matrix(self) -> np.ndarray:
        """4x4 homogeneous transform world <- object."""
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(self.quat_wxyz)
        T[:3, 3] = self.pos_world_m
        return T


@dataclass(frozen=True, eq=False)
class PlacedObject:
    object_id: int  # 0..n-1 within the scene; segmentation uses the same ids
    asset: Asset
    pose: Pose


BOARD_M = 0.02  # shelf board thickness
# Legs stand this far in from the table's corners (centre) and are this wide (half); on a shelf
# they go on up as posts through every board below the highest.
LEG_INSET_M = 0.05
LEG_HALF_M = 0.025


@dataclass(frozen=True)
class Table:
    size_m: tuple[float, float]  # extents along world x and y
    top_z_m: float
    rgba: tuple[float, float, float, float]
    texture: str  # a MuJoCo builtin: "checker", "gradient" or "flat"
    # Shelf boards above the top, as heights over it (empty for a plain table). Board k is
    # support id -(k + 2): -1 is the table top itself.
    levels_m: tuple[float, ...] = ()
    # "table", or "floor": a room's floor that reaches beyond the view (no legs, no edges to ask about)
    surface: str = "table"


@dataclass(frozen=True)
class Camera:
    name: str
    pos_world_m: tuple[float, float, float]
    quat_wxyz: tuple[float, float, float, float]  # world <- MuJoCo camera frame
    fovy_deg: float
    width: int
    height: int

    def intrinsics(self) -> np.ndarray:
        """3x3 pinhole K in pixels (OpenCV convention, origin at the top-left pixel corner)."""
        f = 0.5 * self.height / np.tan(np.radians(self.fovy_deg) / 2)
        return np.array([[f, 0.0, self.width / 2], [0.0, f, self.height / 2], [0.0, 0.0, 1.0]])

    def T_world_cam(self) -> np.ndarray:
        """4x4 world <- camera in the OpenCV convention (+z forward, +y down)."""
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(self.quat_wxyz) @ np.diag([1.0, -1.0, -1.0])
        T[:3, 3] = self.pos_world_m
        return T


@dataclass(frozen=True)
class Light:
    dir_world: tuple[float, float, float]  # direction the light shines along
    intensity: float  # multiplier on the recipe's base diffuse colour
    kelvin: float = 6500.0  # colour temperature; 6500 K is neutral white
    kind: str = "sun"  # "sun" (directional, casts the shadows) or "lamp" (a spot in the room)
    pos_world_m: tuple[float, float, float] | None = None  # lamps only
    shadow_m: float = 0.0  # light source radius: shadow edges soften with it (0: hard)


@dataclass(frozen=True, eq=False)
class Surface:
    """A textured room surface: floor, walls, table top, background furniture."""

    look: str  # look name in textures.yaml, or "image:<file>" for a user's image
    rgb: tuple[float, float, float]  # mean colour of its texture
    texture: Texture
    tile_m: float  # metres one repeat of the texture covers


@dataclass(frozen=True)
class Prop:
    """A piece of background furniture or an opening in a wall: seen, never asked about."""

    kind: str  # "cabinet", "shelf", "sofa", "plant", "window", "door"
    pos_world_m: tuple[float, float, float]  # centre of its base
    yaw_rad: float
    size_m: tuple[float, float, float]  # along its own x (depth), y (width), z (height)


@dataclass(frozen=True, eq=False)
class Room:
    """Walls, floor and background around the scene, so no view sees a void."""

    size_m: tuple[float, float]  # inner extents along world x and y, centred on the origin
    height_m: float
    floor: Surface
    wall: Surface
    top: Surface  # the table top and shelf boards (a floor scene's floor is `floor`)
    furniture: Surface  # background furniture and the door
    props: tuple[Prop, ...] = ()
    outdoors: Surface | None = None  # what the window shows: a generated view or a user's panorama


@dataclass(frozen=True, eq=False)
class Scene:
    """A composed scene. Before settling, object poses are the drop poses."""

    recipe_name: str
    recipe_hash: str
    seed: int
    table: Table
    objects: tuple[PlacedObject, ...]
    cameras: tuple[Camera, ...]
    lights: tuple[Light, ...]  # the first is the key light (a sun), which casts the shadows
    room: Room
    # Pairs of object ids (smaller first) in contact after settling; -1 is the table.
    contacts: tuple[tuple[int, int], ...] = ()

    @property
    def light(self) -> Light:
        return self.lights[0]

    @property
    def scene_id(self) -> str:
        return f"{self.recipe_name}-{self.recipe_hash[:8]}-{self.seed}"


def quat_to_matrix(q: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / length(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(R: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix."""
    m = np.asarray(R, dtype=float)
    t = np.trace(m)
    if t > 0:
        s = 2.0 * np.sqrt(t + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, 0.0]
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q = np.array(q) / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    return tuple(float(v) for v in q)


def yaw_quat(yaw_rad: float) -> tuple[float, float, float, float]:
    """Rotation about world +z."""
    return (float(np.cos(yaw_rad / 2)), 0.0, 0.0, float(np.sin(yaw_rad / 2)))
