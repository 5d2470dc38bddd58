"""Object-centric sides and positions on the support: facing/back side, corner/edge."""

from __future__ import annotations

import numpy as np

from ..vector import angle_deg, length
from .facts import TABLE, ObjectFacts, ViewFacts
from .geometry import project
from .registry import Verdict, predicate
from .vertical import contained

FACING_DEG = 45.0  # within this of B's front: on its facing side (or back side, mirrored)
# A person reads "on the side facing away from the lamp's shade" as the whole half-plane behind
# it: a thing 60 degrees off that direction is on that side for them, so "not on it" waits until
# the thing is clearly across the line through B (90 degrees, plus 10 of slack).
NOT_FACING_DEG = 100.0
MIN_FRONT_TILT = 0.7  # |horizontal part| of B's front: fronts pointing up/down have no side
NO_FRONT = "none"  # catalogue side name of objects without a semantic front (apples, bowls...)
# At the edge: within 10 cm of a table edge. "Not near the edge" waits until 25 cm: at the back of
# a counter, foreshortening makes 20 cm look like nothing (annotator: a jar 18 cm in was "near").
EDGE_M = (0.10, 0.25)
# At a corner: within 18 cm of both edges meeting there. Not at one from 30 cm (28 said "not" of
# a holder 3 cm from one edge and 28.9 cm from the other, which, foreshortened at the back of
# the table, looked at the corner: annotator).
CORNER_M = (0.18, 0.30)
CORNER_SHARE = 0.25  # ...with its centre in the outer quarter of the table along both edges


def _side_angle(a: ObjectFacts, b: ObjectFacts) -> float | None:
    """Angle in degrees between B's horizontal front and the direction from B to A on the ground."""
    if b.front_world is None or b.front_side == NO_FRONT:
        return None
    front = np.asarray(b.front_world[:2], dtype=float)
    if length(front) < MIN_FRONT_TILT:
        return None
    to_a = a.center_world_m[:2] - b.center_world_m[:2]
    if length(to_a) < 1e-6:
        return None
    cosine = front @ to_a / (length(front) * length(to_a))
    return angle_deg(cosine)


def _within(angle: float | None, near: float, far: float) -> Verdict:
    if angle is None:
        return None
    if angle <= near:
        return True
    if angle >= far:
        return False
    return None


def _no_side_between(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> bool:
    """Whether neither lies on one side of the other: across shelf boards, or one on or in the
    other. A tray under a can is on all its sides at once; so is a basket around a mug, whose
    handle its walls hide besides (annotator, reads 20 and 22)."""
    return (v.on_other_levels(a, b) or v.stacked(a, b)
            or contained(v, a, b) is not False or contained(v, b, a) is not False)


@predicate("on_facing_side", family="face_back", arity=2, frame="object", inverse=None)
def on_facing_side(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A lies on B's semantic front side (its handle, screen, spout, label...), in B's own frame.

    The angle between B's ground-projected front vector and the direction from B
    to A: True within 45 degrees, False beyond 100 (clearly across the line through B
    that splits its front half from its back half), undecided between; undecided
    when B's front points mostly up or down, or B has no semantic front (side "none"), and
    when the two rest on different levels (shelf boards): a toy car a board up and off to the
    bonnet's side is on that side for some readers and on no side for others (annotator).
    """
    if _no_side_between(v, a, b):
        return None
    return _within(_side_angle(a, b), FACING_DEG, NOT_FACING_DEG)


@predicate("on_back_side", family="face_back", arity=2, frame="object", inverse=None)
def on_back_side(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A lies on the side of B opposite its front: the facing-side test mirrored (angle measured
    from -front); undecided across shelf boards and for stacked or nested things, as there."""
    if _no_side_between(v, a, b):
        return None
    angle = _side_angle(a, b)
    return _within(None if angle is None else 180.0 - angle, FACING_DEG, NOT_FACING_DEG)


def _edge_distances(v: ViewFacts, a: ObjectFacts) -> np.ndarray | None:
    """Distances (x, y) from A's footprint to the nearest table edges, for objects standing on the table.

    None on a room's floor (its edges are not the room's walls and are out of the picture), on a
    shelf (questions say "the table", and a board's corners are not what a person calls one),
    and for a thing in a container: a person judges the basket at the edge, not the jar in it.
    Memoised per view and object (at_edge and at_corner both ask)."""
    key = ("edge_distances", a.object_id)
    if key not in v.cache:
        v.cache[key] = _worked_out_edge_distances(v, a)
    return v.cache[key]


def _worked_out_edge_distances(v: ViewFacts, a: ObjectFacts) -> np.ndarray | None:
    if a.support != TABLE or not v.table_size_m[0] or v.table_surface == "floor" or v.table_levels_m:
        return None
    if any(o.object_id != a.object_id and contained(v, a, o) is not False for o in v.objects):
        return None
    half = np.asarray(v.table_size_m) / 2
    corners = a.footprint_world
    distances = half - np.abs(corners).max(axis=0)
    distances.flags.writeable = False  # shared by both predicates
    return distances


@predicate("at_edge", family="corner_edge", arity=1, frame="world")
def at_edge(v: ViewFacts, a: ObjectFacts) -> Verdict:
    """A stands on the table with its footprint within 10 cm of a table edge, and so does its bulk
    (its centre, less half its footprint's narrower side); False beyond 25 cm.

    Only for objects whose support is the table and that no container holds; undecided otherwise.
    """
    d = _edge_distances(v, a)
    if d is None:
        return None
    nearest = float(d.min())
    if nearest <= EDGE_M[0]:
        # Its bulk must be there too, not just a handle's tip: a pan whose handle came 8 cm from
        # the counter's back edge, its body 18 cm in, was not "at the edge" (annotator, read 35).
        # The bulk's edge: the centre's distance less half the footprint's narrower side.
        axis = int(np.argmin(d))
        centre_in = float(np.asarray(v.table_size_m)[axis] / 2 - abs(a.center_world_m[axis]))
        return True if centre_in - a.footprint_sides_m[0] / 2 <= EDGE_M[0] else None
    return False if nearest >= EDGE_M[1] else None


@predicate("at_corner", family="corner_edge", arity=1, frame="world")
def at_corner(v: ViewFacts, a: ObjectFacts) -> Verdict:
    """A stands on the table within 18 cm of both edges meeting at a corner, and that corner is
    drawn in the picture: a person judges "at a corner" by seeing it (annotator: a holder 9 and
    16 cm in from a corner out of frame was "the one at a corner"). False if either distance is
    >= 30 cm; undecided otherwise, and where its centre lies outside the outer quarter of the
    table along either edge: on a counter 69 cm deep a bowl 17 cm in from the long side had its
    centre 27 cm in, near the middle of the table's end rather than at a corner (annotator,
    read 27)."""
    d = _edge_distances(v, a)
    if d is None:
        return None
    if float(d.max()) <= CORNER_M[0]:
        half = np.asarray(v.table_size_m) / 2
        centre_in = half - np.abs(a.center_world_m[:2])
        if np.any(centre_in > CORNER_SHARE * 2 * half):
            return None
        return True if _corner_in_picture(v, a) else None
    return False if float(d.max()) >= CORNER_M[1] else None


def _corner_in_picture(v: ViewFacts, a: ObjectFacts) -> bool:
    """Whether the table corner nearest A's centre is drawn inside the image (True when the view
    has no camera to tell)."""
    if v.K is None or v.T_world_cam is None:
        return True
    half = np.asarray(v.table_size_m) / 2
    corner = np.where(a.center_world_m[:2] >= 0, half, -half)
    uv, depth = project(np.array([[*corner, v.table_top_z_m]]), v.K, v.T_world_cam)
    return bool(depth[0] > 0 and 0 <= uv[0, 0] < v.width and 0 <= uv[0, 1] < v.height)
