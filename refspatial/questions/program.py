"""A small functional program language over view facts.

A program is a list of nodes (plain dicts, so they are stored as they are). Each
node names an operation from ``OPS``, its arguments, and ``inputs``: indices of
earlier nodes whose values it consumes. A node may name the ``view`` it reads
("self", the record's own view, by default; "other" for the first image of a
multi-view question). Executing a program gives every node a value; the last
node's value is the answer. Any near-tie (an undecided predicate, an ordinal
whose neighbours are too close) makes the whole program ambiguous, so no stored
answer ever rests on one.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Callable, Mapping

import numpy as np

from ..relations import PREDICATES, Quantity, ViewFacts
from ..relations.directional import DEPTH_MARGIN_M, SHELF_INWARD
from ..relations.masks import box_of, cached_boxes
from ..relations.metric import centre_distance
from ..relations.free_space import solve, stored_constraints

Node = dict[str, Any]
Value = Any  # list[int] (object ids), int (one object), bool, str, float or [x, y]
Views = Mapping[str, ViewFacts]


class ProgramError(Exception):
    """The program does not pick out a definite answer on this view."""


OPS: dict[str, Callable[..., Value]] = {}
SCENE_OPS: set[str] = set()  # operations that read every view (passed as the node's "_views")


def op(name: str, reads_all_views: bool = False):
    def register(fn: Callable[..., Value]) -> Callable[..., Value]:
        OPS[name] = fn
        if reads_all_views:
            SCENE_OPS.add(name)
        return fn

    return register


@op("scene")
def _scene(view: ViewFacts, node: Node) -> list[int]:
    """All objects a viewer can see (visible or marginal); hidden ones do not exist for the viewer."""
    return [o.object_id for o in view.objects if o.status != "hidden"]


def answers_to(view: ViewFacts, o, category: str | None) -> bool:
    """Whether a person would count the object among things called by the category's name: any
    object for None, its own category, any kind of it whose name ends in that name, and any
    category templates.yaml says is also called so. A tissue box is a box to anyone looking, so
    "the box" beside one is ambiguous (annotator); a plant pot is a pot; a mug is a cup."""
    if category is None or o.category == category:
        return True
    key = ("answers_to", category)
    if key not in view.cache:
        name = next((x.name for x in view.objects if x.category == category), None)
        view.cache[key] = frozenset() if name is None else frozenset(
            x.category for x in view.objects
            if x.name.endswith(" " + name) or name in _also_called().get(x.category, ()))
    return o.category in view.cache[key]


@lru_cache(maxsize=1)
def _also_called() -> dict[str, tuple[str, ...]]:
    from .phrases import Phrasebook  # phrases imports this module (through refer)

    return {category: tuple(names) for category, names in Phrasebook.get().data["also_called"].items()}


@op("filter")
def _filter(view: ViewFacts, node: Node, ids: list[int]) -> list[int]:
    """Objects answering to the node's category name (``answers_to``) in its colour (either may
    be None: any). Fails on a barely visible match."""
    category, color, objects = node.get("category"), node.get("color"), view.objects
    out = [i for i in ids if answers_to(view, objects[i], category) and color in (None, objects[i].color)]
    if any(objects[i].status != "visible" for i in out):
        raise ProgramError(f"a barely visible {node.get('category') or 'object'} makes the description unsafe")
    return out


def _verdict(view: ViewFacts, name: str, ids: list[int]) -> bool:
    verdict = PREDICATES[name](view, *(view.objects[i] for i in ids))
    if verdict is None:
        raise ProgramError(f"{name} is undecided for objects {ids}")
    return verdict


@op("relate")
def _relate(view: ViewFacts, node: Node, ids: list[int], *anchors: int) -> list[int]:
    """Objects for which the predicate holds against the anchors (subject first, or last when reversed).

    With no anchors it is a unary predicate of the object (at the table's edge...)."""
    kept = []
    for i in ids:
        if i in anchors:
            continue
        args = [*anchors, i] if node.get("reverse") else [i, *anchors]
        if _verdict(view, node["predicate"], args):
            kept.append(i)
    return kept


ORDINAL_MARGIN_M = 0.03  # centres closer than this along an axis are a near-tie for ranking ("second from the left")
ORDINAL_SIZE_SHARE = 0.5  # ...and so are centres closer than half the pair's mean extent along it
ORDINAL_AXES = {
    # axis -> (coordinate of an object, end whose rank 1 has the smallest coordinate, margin)
    "left_right": (lambda o: o.lateral_m, "left", ORDINAL_MARGIN_M),
    "front_back": (lambda o: o.forward_m, "front", ORDINAL_MARGIN_M),
    "depth": (lambda o: o.depth_m, "near", DEPTH_MARGIN_M),
}


@op("ordinal")
def _ordinal(view: ViewFacts, node: Node, ids: list[int]) -> int:
    """The rank-th object from the named end along an axis; its neighbours must be clearly apart."""
    key, low_end, margin = ORDINAL_AXES[node["axis"]]
    order = sorted(ids, key=lambda i: key(view.objects[i]))
    if node["end"] != low_end:
        order.reverse()
    rank = node["rank"]
    if len(order) < max(rank, 2):
        raise ProgramError(f"ordinal rank {rank} over {len(order)} objects")
    coords = [key(view.objects[i]) for i in order]
    axis = {"left_right": view.right_axis, "front_back": view.forward_axis}.get(node["axis"])
    chosen = view.objects[order[rank - 1]]
    for j in (rank - 2, rank):  # neighbours before and after the chosen one
        if not 0 <= j < len(coords):
            continue
        gap = margin
        if axis is not None:  # two baskets overlapping by most of their width have no order a person agrees on
            extents = chosen.extent_along(axis) + view.objects[order[j]].extent_along(axis)
            gap = max(margin, ORDINAL_SIZE_SHARE * extents / 2)
        if abs(coords[j] - coords[rank - 1]) <= gap:
            raise ProgramError("ordinal neighbours are a near-tie")
    if node["axis"] == "depth":
        _check_depth_order(view, order, rank)
    if node["axis"] == "left_right":
        # "The third can from the right" over cans on two boards is counted along one board's row
        # by a reader (annotator, read 22); only the extreme one reads the same either way.
        if rank > 1 and view.table_levels_m and view.on_other_levels(*(view.objects[i] for i in order)):
            raise ProgramError("ranks from the side across shelf boards are counted by row")
        _check_picture_order(view, order, rank, from_left=node["end"] == "left")
    if node["axis"] == "front_back" and view.table_levels_m:
        # Across boards "the second pen holder from the front" reads by the shelf's depth or by
        # nearness to the viewer, and they disagree (annotator): a rank only within one board.
        if view.on_other_levels(*(view.objects[i] for i in order)):
            raise ProgramError("front-to-back ranks across shelf boards read two ways")
        _check_shelf_front(view, order, rank, margin, from_front=node["end"] == "front")
    return order[rank - 1]


def _check_shelf_front(view: ViewFacts, order: list[int], rank: int, margin: float, from_front: bool) -> None:
    """"The bottle nearest the front" of a shelf seen 23 degrees off its axis reads as nearest the
    shelf's own front edge as well as nearest the viewer (annotator): the rank must be the same,
    with clearly apart neighbours, along the shelf's depth too."""
    sign = 1.0 if from_front else -1.0
    chosen = view.objects[order[rank - 1]]
    for j in (rank - 2, rank):
        if not 0 <= j < len(order):
            continue
        other = view.objects[order[j]]
        later, earlier = (other, chosen) if j > rank - 1 else (chosen, other)
        step = sign * float((later.center_world_m - earlier.center_world_m) @ SHELF_INWARD)
        extents = chosen.extent_along(SHELF_INWARD) + other.extent_along(SHELF_INWARD)
        if step <= max(margin, ORDINAL_SIZE_SHARE * extents / 2):
            raise ProgramError("the shelf's own front ranks them otherwise")


def _check_picture_order(view: ViewFacts, order: list[int], rank: int, from_left: bool) -> None:
    """"The second lemon from the left" is counted in the picture: the chosen one and each
    neighbour in the ranking must stand apart across the image too, in the same order, by half
    their mean width there. A lemon in a pan 13 cm further left in the room, drawn in the same
    column as one in front, has no rank a reader can see (annotator)."""
    boxes = cached_boxes(view)
    chosen = view.objects[order[rank - 1]]
    for j in (rank - 2, rank):
        if not 0 <= j < len(order):
            continue
        other = view.objects[order[j]]
        ba, bb = box_of(boxes, chosen.object_id), box_of(boxes, other.object_id)
        if chosen.centroid_px is None or other.centroid_px is None or ba is None or bb is None:
            raise ProgramError("an ordinal neighbour is not seen")
        widths = (ba[1].stop - ba[1].start) + (bb[1].stop - bb[1].start)
        later, earlier = (other, chosen) if j > rank - 1 else (chosen, other)
        apart = (later.centroid_px[0] - earlier.centroid_px[0]) * (1 if from_left else -1)
        if apart <= ORDINAL_SIZE_SHARE * widths / 2:
            raise ProgramError("ordinal neighbours are a near-tie in the picture")


def _check_depth_order(view: ViewFacts, order: list[int], rank: int) -> None:
    """"The nearest vase" needs it nearer than each other vase by every reading of "closer to
    the camera" (visible surface, centre depth, straight line; never across shelf boards): a vase
    on the top board nearer along the optical axis but level in a straight line with one on the
    board below is nearest to nobody (annotator)."""
    chosen = order[rank - 1]
    for other in order:
        if other != chosen:
            pair = sorted((chosen, other), key=lambda i: view.objects[i].depth_m)  # the order's own key
            if not _verdict(view, "closer_to_camera", pair):
                raise ProgramError("the depth ranking is not clear by every reading")


@op("unique")
def _unique(view: ViewFacts, node: Node, ids: list[int] | int) -> int:
    """The one object a description picks; anything else is not a valid referring expression."""
    if isinstance(ids, int):  # an object found in another view: it must be seen in this one
        if view.objects[ids].status != "visible":
            raise ProgramError(f"object {ids} is not clearly visible in this view")
        return ids
    if len(ids) != 1:
        raise ProgramError(f"description matches {len(ids)} objects")
    return ids[0]


@op("query")
def _query(view: ViewFacts, node: Node, *objects: int) -> bool:
    """Truth of a predicate over unique objects (yes/no questions)."""
    return _verdict(view, node["predicate"], list(objects))


@op("pick")
def _pick(view: ViewFacts, node: Node, a: int, b: int) -> int:
    """Of two unique objects, the one the predicate holds for against the other ("which is further left")."""
    forward, backward = _verdict(view, node["predicate"], [a, b]), _verdict(view, node["predicate"], [b, a])
    if forward == backward:
        raise ProgramError(f"{node['predicate']} does not separate objects {a} and {b}")
    return a if forward else b


@op("count")
def _count(view: ViewFacts, node: Node, ids: list[int]) -> int:
    """How many objects a filter matched (the filter already refuses barely visible matches)."""
    return len(ids)


def _camera_distance(v: ViewFacts, o) -> Quantity | None:
    """Straight-line distance from the camera to the object's centre, metres ("how far from the camera")."""
    centre = v.centre_in_camera(o)
    return None if centre is None or o.status == "hidden" else Quantity(float(np.linalg.norm(centre)), "m")


# "How wide is the book from here" is asked only where its span from left to right is one of its
# own sides, within max(1 cm, 8 %): a book turned 30 degrees spans 26 cm across the view where
# its cover is 17 x 23 cm, and a reader measures the book (annotator).
WIDTH_AGREES = (0.01, 0.08)


def _width(v: ViewFacts, o) -> Quantity | None:
    """The object's extent along the viewer's right axis, when it is also one of its own sides."""
    sides = o.footprint_sides_m
    if sides is None:
        return None
    span = o.extent_along(v.right_axis)
    if not any(abs(span - side) <= max(WIDTH_AGREES[0], WIDTH_AGREES[1] * side) for side in sides):
        return None
    return Quantity(span, "m")


# "How deep into the scene is the cabinet" has one answer only where the thing's visible surface
# lies at about one depth: a cabinet seen from 2.10 to 2.75 m read 2.37 m (its pixels' median),
# 27 cm past its front and 17 cm short of its centre (annotator, read 38). Asked where the middle
# 80 % of its visible depths span at most this share of the answer.
DEPTH_SPREAD_SHARE = 0.10


def _depth(v: ViewFacts, o) -> Quantity | None:
    """Depth along the viewing direction (the optical axis) of the visible surface, the median
    over its mask, when that surface lies at about one depth (DEPTH_SPREAD_SHARE)."""
    box = box_of(cached_boxes(v), o.object_id)
    if box is None or not np.isfinite(o.depth_m):
        return None
    near, far = np.percentile(v.depth_m[box][v.seg[box] == o.object_id], [10, 90])
    return Quantity(o.depth_m, "m") if far - near <= DEPTH_SPREAD_SHARE * o.depth_m else None


QUANTITIES: dict[str, Callable[..., Quantity | None]] = {
    "depth": _depth,
    "camera_distance": _camera_distance,
    "centre_distance": lambda v, a, b: centre_distance(v, a, b),
    "height": lambda v, o: Quantity(o.height_m, "m"),
    "width": _width,
}


@op("measure")
def _measure(view: ViewFacts, node: Node, *objects: int) -> float:
    """A metric quantity of unique objects: a measure predicate, or depth / height / width of one object."""
    name = node["quantity"]
    facts = [view.objects[i] for i in objects]
    q = QUANTITIES[name](view, *facts) if name in QUANTITIES else PREDICATES[name](view, *facts)
    if q is None:
        raise ProgramError(f"{name} cannot be measured here")
    return round(q.value, 4)


@op("free_space")
def _free_space(view: ViewFacts, node: Node, *anchors: int) -> list[float]:
    """A free point meeting the node's constraints; each constraint names its anchors by input position."""
    answer = solve(view, stored_constraints(node["constraints"], anchors))
    if answer is None:
        raise ProgramError("no free space meets the constraints")
    return list(answer.point)


@op("mark")
def _mark(view: ViewFacts, node: Node, target: int) -> str:
    """The label of the drawn mark around the object (visual choice)."""
    labels = [m["label"] for m in node["marks"] if m["object_id"] == target]
    if len(labels) != 1:
        raise ProgramError("the object carries no mark")
    return labels[0]


CAMERA_SHIFT_MARGIN_M = 0.10
CAMERA_TURN_MARGIN_DEG = 10.0


@op("camera_move", reads_all_views=True)
def _camera_move(view: ViewFacts, node: Node) -> str:
    """Which way the camera went from the other view to this one: "left"/"right" along the other
    camera's ground-projected right axis (margin 10 cm), or the turn "left"/"right" (margin 10 deg).
    A turn is asked only when the camera did not also move the other way: circling a table, it
    moves left while its heading turns right, and a person comparing the pictures sees the scene
    swing round, not a turn either way (annotator)."""
    first, second = node["_views"]["other"], node["_views"]["self"]
    moved = float((second.T_world_cam[:3, 3] - first.T_world_cam[:3, 3]) @ first.right_axis)
    f1, f2 = first.forward_axis, second.forward_axis
    turned = -float(np.degrees(np.arctan2(f1[0] * f2[1] - f1[1] * f2[0], f1 @ f2)))
    if node["motion"] == "shift":
        value, margin = moved, CAMERA_SHIFT_MARGIN_M
    else:
        value, margin = turned, CAMERA_TURN_MARGIN_DEG
        if abs(moved) > CAMERA_SHIFT_MARGIN_M and (moved > 0) != (turned > 0):
            raise ProgramError("the camera circled: it moved one way and turned the other")
    if abs(value) <= margin:
        raise ProgramError("the camera barely moved that way")
    return "right" if value > 0 else "left"


def execute(program: list[Node], views: ViewFacts | Views, skip: int | None = None,
            known: list[Value] | None = None) -> list[Value]:
    """Values of every node, in order. Raises ProgramError on ambiguity.

    ``views`` is one view, or a mapping of view names ("self", "other") for
    multi-view programs. ``skip`` names a node to bypass (its value becomes its
    first input's), which is how the degeneracy test removes one relation at a time.
    ``known``: values of the program's first nodes from an earlier run on the same views
    (a node's value depends on the nodes before it alone), which are not worked out again.
    """
    named = {"self": views} if isinstance(views, ViewFacts) else dict(views)
    values: list[Value] = list(known or ())
    for k in range(len(values), len(program)):
        node = program[k]
        inputs = [values[i] for i in node.get("inputs", [])]
        if k == skip:
            values.append(inputs[0])
            continue
        fn = OPS.get(node["op"])
        if fn is None:
            raise ProgramError(f"unknown operation {node['op']!r}")
        view = named.get(node.get("view", "self"))
        if view is None:
            raise ProgramError(f"program reads view {node.get('view')!r}, which was not given")
        values.append(fn(view, {**node, "_views": named} if node["op"] in SCENE_OPS else node, *inputs))
    return values


def count_steps(program: list[Node]) -> int:
    """RefSpatial-Bench's step count: anchor objects plus the relation phrases tied to them.

    The viewer-frame ordinals and the target's own category and colour do not
    count; "on" (on top of an anchor) adds no phrase; a description without
    anchors is one step (locating the target).
    """
    phrases = [n for n in program if n["op"] in ("relate", "query", "pick")]
    anchors = {i for n in phrases for i in n["inputs"][1:]}
    for n in program:
        if n["op"] == "free_space":
            anchors.update(n["inputs"])
            phrases.extend(c for c in n["constraints"] if c["kind"] != "on_top")
    return max(1, len(anchors) + len(phrases))


def is_degenerate(program: list[Node], views: ViewFacts | Views, values: list[Value] | None = None) -> bool:
    """True if some relation node can be skipped without changing the answer (CLEVR's test).
    ``values``: the program's values on these views, when the caller has executed it already."""
    if values is None:
        values = execute(program, views)
    target = values[-1]
    for k, node in enumerate(program):
        if node["op"] != "relate":
            continue
        try:  # the nodes before the skipped one keep their values
            if execute(program, views, skip=k, known=values[:k])[-1] == target:
                return True
        except ProgramError:
            continue
    return False


def with_results(program: list[Node], values: list[Value]) -> list[Node]:
    """Nodes annotated with their values, the form stored in records."""
    return [{**node, "result": value.item() if isinstance(value, np.generic) else value}
            for node, value in zip(program, values)]
