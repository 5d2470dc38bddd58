"""An independent check of the comparatives a dataset asks, under the strict human readings.

Written apart from the relation engine (it imports nothing from ``refspatial.relations`` or
``refspatial.questions``): it re-derives each comparative from what a record stores -- the
objects' oriented boxes, supports and enclosed volumes, the depth map, the segmentation and
the camera -- and checks every relation a question relied on:

- left/right, in front/behind: the two objects' extents along the viewer's axis (the camera's
  right or forward axis laid on the ground; from the stored ground outline of the mesh, or the
  oriented box where a record has none) do not overlap, and neither object rests on the other;
- closer to the camera: nearer both by the visible surface (median depth over its mask) and by
  the box centre's depth, and not spanning the other (or spanned by it) along the viewer's forward
  axis on the ground;
- bigger/smaller: larger by enclosed volume, by box volume and by the area it covers in the
  picture (its outline raised to its height, projected), its longest dimension not under 90 %
  of the other's;
- in front/behind also: the centres further apart front to back than side to side;
- taller/shorter, wider/thinner: by at least 1 cm;
- above/below: directly over or under (the smaller's centre within the larger's ground outline,
  one's bottom not below the other's top less 2 cm);
- higher/lower in the image: the whole mask shifted (top row and bottom row both above);
- between: the subject's box centre lies on the ground segment joining the anchors' centres
  (not beyond either end, at most a quarter of its length off it), and its mask centroid lies
  between theirs in the image likewise;

and, beside the relations, what a person checks in the picture:
- a free spot keeps 2 % of the image width clear of every object's pixels (the platform it
  lies on aside: the object under the point, if any);
- a colour word names every object it picks out truly: the mean colour of each one's pixels
  reads as that word (``refspatial.colour_words``).

    python -m refspatial.strict_audit DATASET_DIR [DATASET_DIR ...]

prints how many times each relation and picture check was made and every violation, and exits
1 when there is any.
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull

from .colour import srgb_to_lab
from .colour_words import reads_as
from .manifest import ManifestError
from .records import ShardReader
from .scene import quat_to_matrix
from .stats import load_manifest

TOLERANCE_M = 0.01  # box extents and heights must differ by this much to count as ordered
STACK_SLACK_M = 0.02  # "over" allows this much interpenetration of resting boxes
BETWEEN_OFF = 0.25  # share of the anchors' distance the subject may lie off the line joining them
CLEAR_SHARE = 0.02  # share of the image width a free spot keeps from every object
ROUNDING_PX = 1.0  # answer points are stored to 3 decimals: they may move this far


class Box:
    """One object as a record stores it: its oriented box's 8 corners, support and volume."""

    def __init__(self, o: dict) -> None:
        b = o["box_world"]
        R = quat_to_matrix(b["quat_wxyz"])
        half = np.asarray(b["size_m"]) / 2
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        self.id = o["id"]
        self.centre = np.asarray(b["center_m"], float)
        self.corners = self.centre + (signs * half) @ R.T
        self.support = o.get("support")
        self.volume = float(o["volume_m3"])
        self.box_volume = float(np.prod(b["size_m"]))
        # The mesh's ground outline, where the record has one (a round bowl is narrower than its box).
        outline = o.get("outline_world_m")
        self.outline = None if not outline else np.asarray(outline, float).reshape(-1, 2)

    def span(self, axis: np.ndarray) -> tuple[float, float]:
        if self.outline is not None and axis[2] == 0:
            c = self.outline @ axis[:2]
        else:
            c = self.corners @ axis
        return float(c.min()), float(c.max())


class View:
    """One record: boxes, viewer axes, depths."""

    def __init__(self, sample: dict) -> None:
        self.boxes = {o["id"]: Box(o) for o in sample["scene"]["objects"]}
        T = np.asarray(sample["T_world_cam"])
        self.R, self.t = T[:3, :3], T[:3, 3]
        self.K = np.asarray(sample["K"], float)
        self.right = _ground(self.R[:, 0])
        self.forward = _ground(self.R[:, 2])
        self.depth, self.seg, self.rgb = sample["depth_m"], sample["seg"], sample["rgb"]
        self._surface: dict[int, float] = {}
        self._centroid: dict[int, np.ndarray | None] = {}

    def stacked(self, a: Box, b: Box) -> bool:
        return a.support == b.id or b.support == a.id

    def surface_depth(self, a: Box) -> float:
        """Median depth over the object's mask, once per object (questions ask the same pairs often)."""
        if a.id not in self._surface:
            d = self.depth[self.seg == a.id]
            self._surface[a.id] = float(np.median(d)) if d.size else float("inf")
        return self._surface[a.id]

    def centre_depth(self, a: Box) -> float:
        return float((self.R.T @ (a.centre - self.t))[2])

    def looks_size(self, a: Box) -> float:
        """Area in pixels of the image of the object's ground outline raised from its bottom to its
        top (its box where the record has no outline): how big it looks from this camera."""
        ring = a.outline if a.outline is not None else a.corners[:, :2]
        lo, hi = a.span(Z)
        solid = np.concatenate([np.c_[ring, np.full(len(ring), lo)], np.c_[ring, np.full(len(ring), hi)]])
        cam = (solid - self.t) @ self.R
        uv = (cam @ self.K.T)[:, :2] / cam[:, 2:3]
        return float(ConvexHull(uv).volume)  # a 2-D hull's "volume" is its area

    def mean_lab(self, oid: int) -> np.ndarray | None:
        """CIE Lab of the mean colour of the object's pixels, None when it shows none."""
        pixels = self.rgb[self.seg == oid]
        return srgb_to_lab(pixels.mean(axis=0) / 255.0) if len(pixels) else None

    def clearance_px(self, point) -> float:
        """Distance in pixels from a normalised image point to the nearest pixel of an object,
        the one under the point aside (the platform a free spot lies on)."""
        h, w = self.seg.shape
        col, row = min(int(point[0] * w), w - 1), min(int(point[1] * h), h - 1)
        platform = self.seg[row, col]
        rows, cols = np.nonzero((self.seg >= 0) & (self.seg != platform))
        if not rows.size:
            return float("inf")
        return float(np.sqrt(((cols + 0.5 - point[0] * w) ** 2 + (rows + 0.5 - point[1] * h) ** 2).min()))

    def rows(self, a: Box) -> tuple[int, int] | None:
        """First and last image row of the object's pixels."""
        rows = np.nonzero((self.seg == a.id).any(axis=1))[0]
        return (int(rows[0]), int(rows[-1])) if rows.size else None

    def centroid(self, a: Box) -> np.ndarray | None:
        """(column, row) of the object's mask centroid, None when it shows no pixel."""
        if a.id not in self._centroid:
            rows, cols = np.nonzero(self.seg == a.id)
            self._centroid[a.id] = np.array([cols.mean(), rows.mean()]) if rows.size else None
        return self._centroid[a.id]


def _ground(v: np.ndarray) -> np.ndarray:
    g = np.array([v[0], v[1], 0.0])
    return g / np.linalg.norm(g)


def _before(v: View, a: Box, b: Box, axis: np.ndarray) -> bool:
    """The whole of a lies before the whole of b along axis, and neither rests on the other."""
    return not v.stacked(a, b) and a.span(axis)[1] < b.span(axis)[0]


Z = np.array([0.0, 0.0, 1.0])


def _outline_of(a: Box) -> np.ndarray:
    return a.outline if a.outline is not None else a.corners[:, :2]


def _within(point: np.ndarray, outline: np.ndarray) -> bool:
    hull = ConvexHull(outline)
    return bool(np.all(hull.equations[:, :2] @ point + hull.equations[:, 2] <= 1e-9))


def _over(a: Box, b: Box) -> bool:
    """Directly over: the smaller's centre lies within the larger's ground outline (a round plate's
    own, not its box's), and a's bottom is not below b's top."""
    small, big = sorted((a, b), key=lambda o: ConvexHull(_outline_of(o)).volume)
    return _within(small.centre[:2], _outline_of(big)) and a.span(Z)[0] >= b.span(Z)[1] - STACK_SLACK_M


def _shown_higher(v: View, a: Box, b: Box) -> bool:
    """a's pixels lie higher in the picture than b's: its top row and its bottom row both above b's."""
    ra, rb = v.rows(a), v.rows(b)
    return ra is not None and rb is not None and ra[0] < rb[0] and ra[1] < rb[1]


def _on_segment(p: np.ndarray, q: np.ndarray, r: np.ndarray, ends: float) -> bool:
    """p lies along q->r (ends..1-ends of the way) at most BETWEEN_OFF of its length off it."""
    seg, rel = r - q, p - q
    length = float(np.linalg.norm(seg))
    if length == 0:
        return False
    t = float(rel @ seg) / length**2
    off = abs(float(seg[0] * rel[1] - seg[1] * rel[0])) / length
    return ends <= t <= 1 - ends and off <= BETWEEN_OFF * length


def _between(v: View, a: Box, b: Box, c: Box) -> bool:
    if not _on_segment(a.centre[:2], b.centre[:2], c.centre[:2], 0.0):
        return False
    pa, pb, pc = (v.centroid(o) for o in (a, b, c))
    return pa is not None and pb is not None and pc is not None and _on_segment(pa, pb, pc, 0.05)


def _more_along(v: View, a: Box, b: Box, axis: np.ndarray, across: np.ndarray) -> bool:
    """The centres lie further apart along ``axis`` than across it (not side by side)."""
    d = a.centre - b.centre
    return abs(float(d @ axis)) >= abs(float(d @ across)) - 1e-6


def _longest(a: Box) -> float:
    """Longest dimension: the largest distance between two corners of its ground outline, or its height."""
    ring = a.outline if a.outline is not None else a.corners[:, :2]
    span = float(np.max(np.linalg.norm(ring[:, None] - ring[None], axis=2)))
    return max(span, _height(a))


def _spans(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """One interval holds the other: neither is nearer at both ends."""
    return (a[0] < b[0]) != (a[1] < b[1])


def _height(a: Box) -> float:
    lo, hi = a.span(Z)
    return hi - lo


STRICT = {
    "left_of": lambda v, a, b: _before(v, a, b, v.right),
    "right_of": lambda v, a, b: _before(v, b, a, v.right),
    "in_front_of": lambda v, a, b: _before(v, a, b, v.forward) and _more_along(v, a, b, v.forward, v.right),
    "behind": lambda v, a, b: _before(v, b, a, v.forward) and _more_along(v, a, b, v.forward, v.right),
    "closer_to_camera": lambda v, a, b: v.surface_depth(a) < v.surface_depth(b) and v.centre_depth(a) < v.centre_depth(b)
    and not _spans(a.span(v.forward), b.span(v.forward)),
    "bigger_than": lambda v, a, b: a.volume > b.volume and a.box_volume > b.box_volume
    and v.looks_size(a) > v.looks_size(b) and _longest(a) >= 0.9 * _longest(b) - 1e-6,
    "smaller_than": lambda v, a, b: a.volume < b.volume and a.box_volume < b.box_volume
    and v.looks_size(a) < v.looks_size(b) and _longest(b) >= 0.9 * _longest(a) - 1e-6,
    "taller_than": lambda v, a, b: _height(a) >= _height(b) + TOLERANCE_M,
    "shorter_than": lambda v, a, b: _height(b) >= _height(a) + TOLERANCE_M,
    "wider_than": lambda v, a, b: np.ptp(a.span(v.right)) >= np.ptp(b.span(v.right)) + TOLERANCE_M,
    "thinner_than": lambda v, a, b: np.ptp(b.span(v.right)) >= np.ptp(a.span(v.right)) + TOLERANCE_M,
    "above": lambda v, a, b: _over(a, b),
    "below": lambda v, a, b: _over(b, a),
    "higher_in_image": lambda v, a, b: _shown_higher(v, a, b),
    "lower_in_image": lambda v, a, b: _shown_higher(v, b, a),
}


def asked(qa: dict) -> list[tuple[str, int, int, bool]]:
    """(predicate, a, b, said) for every comparative a question's program relied on in its own
    view: each object a relation kept, a yes/no query's answer, a pick's chosen option."""
    steps = qa["steps"]
    out = []
    for n in steps:
        if n.get("view", "self") != "self" or n.get("predicate") not in STRICT:
            continue
        p = n["predicate"]
        if n["op"] == "relate" and len(n["inputs"]) == 2:
            anchor = steps[n["inputs"][1]]["result"]
            for k in n["result"]:
                out.append((p, anchor, k, True) if n.get("reverse") else (p, k, anchor, True))
        elif n["op"] == "query" and len(n["inputs"]) == 2:
            a, b = (steps[i]["result"] for i in n["inputs"])
            out.append((p, a, b, bool(n["result"])))
        elif n["op"] == "pick":  # the result is the object id the predicate holds for against the other
            options = [steps[i]["result"] for i in n["inputs"]]
            out.extend((p, n["result"], other, True) for other in options if other != n["result"])
    return out


def audit(*roots: Path) -> tuple[Counter, list[str]]:
    """Relations and picture checks made per kind, and one line per violation."""
    checked: Counter = Counter()
    violations = []
    for root in roots:
        for shard in load_manifest(Path(root))["shards"]:
            for sample in ShardReader(Path(root) / shard["file"]).iter(fields=("rgb", "depth", "seg")):
                view = View(sample)
                for qa in sample["qa"]:
                    for kind, problem in _audit_qa(view, qa):
                        checked[kind] += 1
                        if problem:
                            violations.append(f"{qa['qa_id']}: {problem}: {qa['prompt']}")
    return checked, violations


def _audit_qa(view: View, qa: dict):
    """(what was checked, the problem or None) for every check one QA calls for."""
    boxes = view.boxes
    for p, a, b, said in asked(qa):
        holds = STRICT[p](view, boxes[a], boxes[b])
        # A "no" must hold strictly too: the converse reading, with the objects swapped.
        ok = holds if said else _strict_no(p, view, boxes[a], boxes[b])
        yield p, None if ok else f"{p}({a}, {b}) said {said}"
    steps = [n for n in qa["steps"] if n.get("view", "self") == "self"]
    for n in steps:
        if n["op"] == "relate" and n.get("predicate") == "between":
            b, c = (qa["steps"][i]["result"] for i in n["inputs"][1:])
            for a in n["result"]:
                yield "between", None if _between(view, boxes[a], boxes[b], boxes[c]) else f"between({a}, {b}, {c})"
        if n["op"] == "filter" and n.get("color"):
            for o in n["result"]:
                lab = view.mean_lab(o)
                if lab is not None:
                    yield "colour word", None if reads_as(lab, n["color"]) else f"object {o} does not look {n['color']}"
    if qa["family"] == "placement" and qa["kind"] == "point":
        for point in qa["answer_points"]:
            room = view.clearance_px(point)
            need = CLEAR_SHARE * view.seg.shape[1] - ROUNDING_PX
            yield "free spot clearance", None if room >= need else f"free spot {point} only {room:.1f} px from an object"


CONVERSE = {"left_of": "right_of", "right_of": "left_of", "in_front_of": "behind", "behind": "in_front_of",
            "bigger_than": "smaller_than", "smaller_than": "bigger_than", "taller_than": "shorter_than",
            "shorter_than": "taller_than", "wider_than": "thinner_than", "thinner_than": "wider_than",
            "above": "below", "below": "above", "higher_in_image": "lower_in_image",
            "lower_in_image": "higher_in_image"}


def _strict_no(p: str, v: View, a: Box, b: Box) -> bool:
    """'A is not p of B' read strictly: the converse holds (A right of B for left_of), or for
    closer_to_camera B is closer; for above/below, A is not over/under B at all."""
    if p in ("above", "below"):
        return not STRICT[p](v, a, b)
    if p == "closer_to_camera":
        return STRICT[p](v, b, a)
    return STRICT[CONVERSE[p]](v, a, b)


def main(argv: list[str] | None = None) -> int:
    roots = [Path(a) for a in (sys.argv[1:] if argv is None else argv)]
    if not roots:
        print("usage: python -m refspatial.strict_audit DATASET_DIR [DATASET_DIR ...]", file=sys.stderr)
        return 2
    try:
        checked, violations = audit(*roots)
    except (ManifestError, FileNotFoundError, NotADirectoryError) as exc:  # a wrong or damaged folder
        print(f"strict_audit: error: {exc}", file=sys.stderr)
        return 2
    for p, n in sorted(checked.items()):
        print(f"{p:<20} {n:>7} checked")
    for line in violations:
        print(f"violation: {line}")
    print(f"{sum(checked.values())} checks, {len(violations)} violations")
    return 1 if violations else 0


if __name__ == "__main__":
    raise SystemExit(main())
