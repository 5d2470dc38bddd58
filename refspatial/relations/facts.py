"""Per-view facts about each object, the inputs every predicate reads.

"Viewer frame": the camera's right and forward axes projected onto the ground
plane (gravity is world -z), so "left of" means the same thing whether the
camera looks steeply down or almost level.

Visibility compares an object's visible pixels (segmentation) with its full
silhouette (its mesh projected without occluders); objects mostly hidden behind
others are not asked about.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import cv2
import numpy as np

from ..compiled import convex_ring
from ..render import View
from ..scene import Cavity, PlacedObject, Scene
from ..vector import column_bounds, length
from .geometry import covered_pixels_each, gap_between, overlap_share, polygon_area, project
from .masks import BOXES_KEY, PIXELS_KEY, PixelStats, box_of, object_boxes, pixel_stats

VISIBLE_SHARE_OF_IMAGE = 0.0006  # below this many pixels (share of the image) an object is too small to ask about
MIN_VISIBLE_PX = 20
MIN_VISIBLE_SHARE = 0.4  # an object less visible than this (of its silhouette) is too occluded to ask about
# A book lying flat under a can, seen edge-on as a strip 6 px tall (594 px in all) of a 540 px
# image, does not read as a book (annotator): what is asked about must span this share of the
# image's height both ways (10 px at 960x540; relative, as VISIBLE_SHARE_OF_IMAGE is).
MIN_VISIBLE_SPAN_SHARE = 0.0185
# A box behind a chair showed 46 % of itself as two dark slivers between the chair's legs, 356 px
# in all, and nothing there read as a box (annotator, read 36): the largest connected piece of
# what shows must itself be big enough to ask about and hold this share of the silhouette.
# Objects showing WHOLE_SHARE of their silhouette or more are not split by anything that matters.
MIN_PIECE_SHARE = 0.3
WHOLE_SHARE = 0.9
# A white laptop showing 43 % of itself, one 779 px wedge between two white cabinets, did not
# read as a laptop (annotator, read 39): a thing mostly hidden is recognised only from a larger
# piece, so below MOSTLY_HIDDEN_SHARE of its silhouette its largest piece must be
# MOSTLY_HIDDEN_PIECE times the asked-about minimum (933 px at 960x540; 0.7 % of seen objects
# in a mixed set fall below it).
MOSTLY_HIDDEN_SHARE = 0.6
MOSTLY_HIDDEN_PIECE = 3.0
SUPPORT_GAP_M = 0.05  # RefSpatial: a platform top within 5 cm of an object's bottom...
SUPPORT_COVER = 0.7  # ...covering >= 70 % of its footprint supports it
TABLE = -1  # support id of the table


@dataclass(frozen=True, eq=False)
class ObjectFacts:
    object_id: int
    category: str
    name: str
    color: str
    aabb_world_m: np.ndarray  # (2, 3) min and max corners of the posed visual mesh
    lateral_m: float  # centre along the viewer's right axis
    forward_m: float  # centre along the viewer's ground-projected forward axis
    depth_m: float  # median camera depth of the visible surface (inf if unseen)
    visible_px: int
    status: str  # "visible" (may be asked about), "marginal" (seen, too little to ask) or "hidden"
    footprint_world: np.ndarray | None = None  # (4, 2) oriented footprint corners on the ground, ccw
    front_world: np.ndarray | None = None  # (3,) unit vector of the semantic front
    front_side: str = "front"
    volume_m3: float = 0.0
    centroid_px: tuple[float, float] | None = None  # (column, row) of the visible mask's centroid
    visible_share: float = 1.0  # visible pixels / silhouette pixels
    support: int | None = None  # object id it stands on, TABLE, or None (floating / unknown)
    cavity: Cavity | None = None
    is_support: bool = False  # its top face may hold other objects (plate, book, box...)
    pose_world: np.ndarray | None = None  # 4x4 world <- object
    lab: tuple[float, float, float] | None = None  # CIE Lab of the visible pixels' mean colour (None if unseen)
    # (K, 2) convex outline of the posed mesh on the ground: a round bowl's true width along any
    # axis (its footprint box, turned 45 degrees, is 1.41 times wider)
    outline_world: np.ndarray | None = None

    @cached_property
    def center_world_m(self) -> np.ndarray:
        # Asked ~10^4 times per view; computed once, read-only since it is shared.
        centre = 0.5 * (self.aabb_world_m[0] + self.aabb_world_m[1])
        centre.flags.writeable = False
        return centre

    @cached_property
    def ground_centres(self) -> tuple[np.ndarray, ...]:
        """Where a strict reader may put the thing on the ground: its mesh box's centre and, where
        known, its oriented footprint's. They differ by centimetres for a pen holder with pens in
        it or a pan with a handle, so relations that hinge on a centre must hold by both."""
        centres = (self.center_world_m[:2],)
        if self.footprint_world is not None:
            centres += (self.footprint_world.mean(0),)
        return centres

    @property
    def footprint_m(self) -> np.ndarray:
        """(x, y) extents of the world box on the ground."""
        return self.aabb_world_m[1, :2] - self.aabb_world_m[0, :2]

    @cached_property  # the size predicates ask it of every pair, twice
    def footprint_sides_m(self) -> tuple[float, float] | None:
        """The oriented footprint's two side lengths, shorter first (None without a footprint)."""
        if self.footprint_world is None:
            return None
        c = self.footprint_world
        return tuple(sorted((length(c[1] - c[0]), length(c[2] - c[1]))))

    @property
    def height_m(self) -> float:
        return float(self.aabb_world_m[1, 2] - self.aabb_world_m[0, 2])

    @cached_property
    def box_volume_m3(self) -> float:
        """Volume of the object's oriented box (footprint sides x height): what "big" looks like
        to a person, who does not subtract a bowl's hollow (memoised: size comparisons ask it
        ~10^3 times per view)."""
        if self.footprint_world is None:
            return float(np.prod(self.footprint_m) * self.height_m)
        c = self.footprint_world
        return float(length(c[1] - c[0]) * length(c[2] - c[1]) * self.height_m)

    def interval_along(self, axis_world: np.ndarray, centre: float | None = None) -> tuple[float, float]:
        """The object's extent along a horizontal axis as (low, high): its ground outline's shadow
        on the axis, or an interval around its centre coordinate (``centre``, by default its box
        centre's) where the facts have no outline. Not centred on the box's centre: a pair of
        scissors' blades reach 1.5 cm further one way than its box centre says (strict audit: "the
        can right of the scissors" overlapped them)."""
        ground = self.ground_outline
        if ground is None:
            if centre is None:
                centre = float(self.center_world_m[:2] @ axis_world[:2])
            half = self.extent_along(axis_world) / 2
            return centre - half, centre + half
        key = ("interval", axis_world[:2].tobytes())
        if key not in self._extents:
            coords = ground @ axis_world[:2]
            self._extents[key] = (float(coords.min()), float(coords.max()))
        return self._extents[key]

    def extent_along(self, axis_world: np.ndarray) -> float:
        """Width of the object projected on a horizontal unit axis (memoised: the predicates ask
        it of the same few axes, the view's own and the free-space directions, ~10^4 times)."""
        key = axis_world[:2].tobytes()
        extent = self._extents.get(key)
        if extent is None:
            if self.outline_world is not None:
                coords = self.outline_world @ axis_world[:2]
                extent = float(coords.max() - coords.min())
            elif self.footprint_world is not None:
                coords = self.footprint_world @ axis_world[:2]
                extent = float(coords.max() - coords.min())
            else:
                extent = float(np.abs(self.footprint_m * axis_world[:2]).sum())
            self._extents[key] = extent
        return extent

    @property
    def ground_outline(self) -> np.ndarray:
        """The mesh's convex ground outline, or its footprint box where the facts lack one."""
        return self.outline_world if self.outline_world is not None else self.footprint_world

    @cached_property  # the overlap and size predicates ask it of every pair
    def ground_area_m2(self) -> float:
        """Area of the ground outline."""
        return polygon_area(self.ground_outline)

    @cached_property
    def _extents(self) -> dict:
        return {}


@dataclass(frozen=True, eq=False)
class ViewFacts:
    objects: tuple[ObjectFacts, ...]  # indexed by object id
    right_axis: np.ndarray  # (3,) world, horizontal unit vector
    forward_axis: np.ndarray  # (3,) world, horizontal unit vector, away from the viewer
    seg: np.ndarray  # int32 (H, W)
    depth_m: np.ndarray  # float32 (H, W)
    K: np.ndarray | None = None  # (3, 3)
    T_world_cam: np.ndarray | None = None  # (4, 4) OpenCV camera
    table_size_m: tuple[float, float] = (0.0, 0.0)  # table extents along world x, y (centred at the origin)
    table_top_z_m: float = 0.0
    table_levels_m: tuple[float, ...] = ()  # shelf boards above the top; board k is support -(k + 2)
    contacts: frozenset[tuple[int, int]] = frozenset()  # object pairs touching, smaller id first, -1 = table
    table_surface: str = "table"  # or "floor": a room's floor, whose edges are out of the picture
    prop_kinds: frozenset[str] = frozenset()  # the room's background pieces ("plant", "sofa"...)
    # Memo of derived values (predicate verdicts, descriptions): question search asks the same things often.
    cache: dict = field(default_factory=dict, repr=False)

    @property
    def width(self) -> int:
        return int(self.seg.shape[1])

    @property
    def height(self) -> int:
        return int(self.seg.shape[0])

    def footprint_gap(self, a: ObjectFacts, b: ObjectFacts) -> float:
        """Ground gap between two objects, memoised: touching, separated, near, far and the
        distance between them all ask it, for both orders of each pair. Measured between the
        meshes' own ground outlines where the facts have them: between their boxes, an apple
        and a stapler were 7 cm apart where a ruler says 8.6 (annotator)."""
        key = ("gap", *sorted((a.object_id, b.object_id)))
        if key not in self.cache:
            self.cache[key] = gap_between(a.ground_outline, b.ground_outline)
        return self.cache[key]

    def stacked(self, a: ObjectFacts, b: ObjectFacts) -> bool:
        """One rests on or in the other (a cup on a plate, an apple in a bowl): beside each other
        they are not, whatever their centres say."""
        return a.support == b.object_id or b.support == a.object_id

    def centre_in_camera(self, o: ObjectFacts) -> np.ndarray | None:
        """The object's box centre in the OpenCV camera frame (x right, y down, z forward), metres."""
        if self.T_world_cam is None:
            return None
        key = ("cam_centre", o.object_id)
        if key not in self.cache:
            R, t = self.T_world_cam[:3, :3], self.T_world_cam[:3, 3]
            self.cache[key] = R.T @ (o.center_world_m - t)
        return self.cache[key]

    def askable(self) -> list[ObjectFacts]:
        return [o for o in self.objects if o.status == "visible"]

    def resting_level(self, o: ObjectFacts) -> int | None:
        """The table top (TABLE) or shelf board (-(k + 2)) an object rests on, through any stack
        of objects beneath it; None when some support in the chain is unknown."""
        return self._levels[o.object_id]

    @cached_property
    def _levels(self) -> tuple[int | None, ...]:
        # Once per view: between asks it of every triple of objects.
        levels = []
        for o in self.objects:
            support = o.support
            for _ in range(len(self.objects)):  # a chain longer than the objects would be a cycle
                if support is None or support < 0:
                    break
                support = self.objects[support].support
            else:
                support = None
            levels.append(support)
        return tuple(levels)

    def on_other_levels(self, *objs: ObjectFacts) -> bool:
        """Known to rest on different levels (a shelf's boards): plan-view relations do not hold across them."""
        levels = {self.resting_level(o) for o in objs}
        return len(levels) > 1 and None not in levels


@dataclass(frozen=True, eq=False)
class PosedShape:
    """What an object's pose makes of its mesh, the same from every view of a scene: computed once
    per scene (``posed_shapes``), not once per view (the convex outline alone is a qhull run)."""

    pose: np.ndarray  # 4x4 world <- object
    verts: np.ndarray  # (V, 3) posed visual vertices
    aabb: np.ndarray  # (2, 3)
    footprint: np.ndarray  # (4, 2)
    front: np.ndarray  # (3,)
    outline: np.ndarray  # (K, 2)


def posed_shapes(scene: Scene) -> tuple[PosedShape, ...]:
    """Each object's PosedShape, indexed like ``scene.objects``. The arrays are shared by every
    view's facts, so they are made read-only."""
    out = []
    for obj in scene.objects:
        T = obj.pose.matrix()
        asset = obj.asset
        verts = asset.visual.vertices_m @ T[:3, :3].T + T[:3, 3]
        shape = PosedShape(T, verts, np.stack(column_bounds(verts)), _footprint(asset, T),
                           T[:3, :3] @ np.asarray(asset.front_local), _outline(verts))
        for a in (shape.pose, shape.verts, shape.aabb, shape.footprint, shape.front, shape.outline):
            a.flags.writeable = False
        out.append(shape)
    return tuple(out)


def view_facts(scene: Scene, view: View, shapes: tuple[PosedShape, ...] | None = None) -> ViewFacts:
    """The facts of one view; ``shapes`` are the scene's ``posed_shapes`` when the caller has them
    (a scene's views share them)."""
    R = view.T_world_cam[:3, :3]
    right, forward = _horizontal(R[:, 0]), _horizontal(R[:, 2])
    min_px = max(MIN_VISIBLE_PX, VISIBLE_SHARE_OF_IMAGE * view.seg.size)
    boxes = object_boxes(view.seg)
    shapes = posed_shapes(scene) if shapes is None else shapes
    pixels = {o.object_id: pixel_stats(view.seg, view.depth_m, boxes, o.object_id, view.rgb) for o in scene.objects}
    # Nothing seen: the share is 0 whatever the silhouette, which then need not be drawn.
    seen = [(o, s) for o, s in zip(scene.objects, shapes) if pixels[o.object_id].count]
    silhouettes = dict(zip((o.object_id for o, _ in seen), _silhouettes_px(seen, view)))
    objects = [_object_facts(o, s, view, right, forward, min_px, boxes, pixels[o.object_id],
                             silhouettes.get(o.object_id, 0)) for o, s in zip(scene.objects, shapes)]
    objects = _with_supports(objects, surfaces(scene.table.top_z_m, scene.table.levels_m),
                             np.array(scene.table.size_m))
    objects = _lost_in_containers(objects)
    return ViewFacts(tuple(objects), right, forward, view.seg, view.depth_m, view.K, view.T_world_cam,
                     tuple(scene.table.size_m), scene.table.top_z_m, tuple(scene.table.levels_m),
                     frozenset(scene.contacts), table_surface=scene.table.surface,
                     prop_kinds=frozenset(p.kind for p in scene.room.props),
                     cache={BOXES_KEY: boxes, PIXELS_KEY: pixels})


def surfaces(top_z: float, levels: tuple[float, ...]) -> dict[int, float]:
    """Support id -> world height of the table top (TABLE) and of each shelf board."""
    return {TABLE: top_z, **{-(k + 2): top_z + h for k, h in enumerate(levels)}}


def _object_facts(obj: PlacedObject, shape: PosedShape, view: View, right, forward, min_px: float, boxes,
                  stats: PixelStats, silhouette_px: int) -> ObjectFacts:
    asset = obj.asset
    centre = shape.aabb.mean(0)
    px = stats.count
    share = min(1.0, px / max(silhouette_px, 1)) if px else 0.0
    box = box_of(boxes, obj.object_id)  # the mask's bounding box: its span both ways
    seen_whole = px >= min_px and share >= MIN_VISIBLE_SHARE and box is not None and \
        min(box[0].stop - box[0].start, box[1].stop - box[1].start) >= MIN_VISIBLE_SPAN_SHARE * view.seg.shape[0]
    if seen_whole and share < WHOLE_SHARE:
        seen_whole = recognisable_piece(view.seg[box] == obj.object_id, share, min_px)
    status = "visible" if seen_whole else ("marginal" if px else "hidden")
    return ObjectFacts(
        obj.object_id, asset.category, asset.name, asset.color, shape.aabb, float(centre @ right),
        float(centre @ forward), stats.depth_m, px, status,
        footprint_world=shape.footprint, front_world=shape.front, outline_world=shape.outline,
        front_side=asset.front_side, volume_m3=asset.visual.volume_m3, centroid_px=stats.centroid_px,
        visible_share=share, cavity=asset.cavity, is_support=asset.support, pose_world=shape.pose,
        lab=stats.lab,
    )


def recognisable_piece(mask: np.ndarray, share: float, min_px: float) -> bool:
    """Whether the largest 8-connected piece of an object's visible mask (``share`` of its
    silhouette in all) is asked-about size by itself (MOSTLY_HIDDEN_PIECE times that when less
    than MOSTLY_HIDDEN_SHARE shows) and holds MIN_PIECE_SHARE of the silhouette."""
    n, _, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8)
    if n < 2:
        return False
    areas = stats[1:, cv2.CC_STAT_AREA]
    largest = int(areas.max())
    needed = min_px * (MOSTLY_HIDDEN_PIECE if share < MOSTLY_HIDDEN_SHARE else 1.0)
    return largest >= needed and largest / int(areas.sum()) * share >= MIN_PIECE_SHARE


def _outline(verts_world: np.ndarray) -> np.ndarray:
    """Convex outline of posed vertices on the ground, counter-clockwise from its lowest-leftmost
    corner, in the micrometres records store.

    The vertices are rounded before the hull and the start is fixed: in one run of a thousand,
    posed vertices came out a few ulps apart (the same scene, another process under load) and
    qhull, the hull's maker then, began its walk round a circular outline at another of its 110
    corners; the record then differed in bytes with every coordinate the same."""
    xy = np.round(verts_world[:, :2], 6)
    return xy[convex_ring(xy)]


def _footprint(asset, T: np.ndarray) -> np.ndarray:
    """Oriented footprint corners: the object's box in its own frame, turned by its pose."""
    (x0, y0, _), (x1, y1, _) = asset.visual.bounds_m
    local = np.array([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0]])
    return (local @ T[:3, :3].T + T[:3, 3])[:, :2]


def _silhouettes_px(objects: list[tuple[PlacedObject, PosedShape]], view: View) -> list[int]:
    """Pixels each object would cover with nothing in front of it (clipped to the image), drawn
    together."""
    h, w = view.seg.shape
    K, T = view.K, view.T_world_cam  # worked out by the camera at each ask
    # An object crossing the camera plane cannot be occluded meaningfully: the whole frame.
    out = [int(view.seg.size)] * len(objects)
    drawn, at = [], []
    for k, (obj, shape) in enumerate(objects):
        uv, z = project(shape.verts, K, T)
        if not np.any(z <= 0.01):
            drawn.append(uv[obj.asset.visual.faces])
            at.append(k)
    for k, count in zip(at, covered_pixels_each(drawn, w, h)):
        out[k] = count
    return out


def _with_supports(objects: list[ObjectFacts], fixed: dict[int, float], table_size: np.ndarray) -> list[ObjectFacts]:
    """Attach what each object stands on, by RefSpatial's rule (top within 5 cm, covers >= 70 %).

    ``fixed`` are the table top and shelf boards (support id -> height); objects win over them.
    """
    table_z = fixed[TABLE]
    out = []
    for o in objects:
        bottom = o.aabb_world_m[0, 2]
        support = None
        if np.all(np.abs(o.center_world_m[:2]) <= table_size / 2):
            near = [(abs(bottom - z), sid) for sid, z in fixed.items() if abs(bottom - z) <= SUPPORT_GAP_M]
            support = min(near)[1] if near else None
        candidates = [p for p in objects if p is not o and abs(bottom - p.aabb_world_m[1, 2]) <= SUPPORT_GAP_M
                      and p.aabb_world_m[1, 2] > table_z + 0.005 and p.aabb_world_m[0, 2] < bottom]
        for p in sorted(candidates, key=lambda p: -p.aabb_world_m[1, 2]):
            if overlap_share(o.footprint_world, p.footprint_world) >= SUPPORT_COVER:
                support = p.object_id
                break
        out.append(replace(o, support=support))
    return out


def _lost_in_containers(objects: list[ObjectFacts]) -> list[ObjectFacts]:
    """A seen thing inside a container that renders in the same colour is not one a person can
    find: a black mug in a black basket averaged RGB (4, 4, 4) against the basket's (6, 5, 5),
    its rim visible only brightened six times (annotator, read 35). Such things are marginal:
    drawn and stored, never asked about or used as anchors."""
    from ..colour import DISTINCT_DELTA_E, delta_e
    from .vertical import containment  # it reads these facts: imported late, as vertical imports this module

    out = []
    for o in objects:
        if o.status == "visible" and o.lab is not None and any(
                c.cavity is not None and c.status != "hidden" and c.lab is not None and c is not o
                and delta_e(o.lab, c.lab) < DISTINCT_DELTA_E and containment(o, c) is True for c in objects):
            o = replace(o, status="marginal")
        out.append(o)
    return out


def _horizontal(v: np.ndarray) -> np.ndarray:
    h = np.array([v[0], v[1], 0.0])
    n = length(h)
    if n < 1e-6:
        raise ValueError("camera looks straight down: the viewer frame is undefined; keep pitch_deg above -89")
    return h / n
