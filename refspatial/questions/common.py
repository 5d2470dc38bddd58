"""What every question family shares: answer points, reasoning traces and the QA record."""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import cv2
import numpy as np

from ..relations import PREDICATES, ViewFacts
from ..relations.masks import box_of, cached_boxes, padded
from .phrases import Phrasebook
from .program import Node, ProgramError, count_steps, execute, with_results
from .refer import compile_ref, simple_refs

QA = dict[str, Any]
POINT_TRIES = 20
ORIENTATION_PREDICATES = ("on_facing_side", "on_back_side")
TARGET_EXPONENTS_KEY = ("target_exponents",)  # where a view's cache keeps target_order's exponents
# Where a view's cache keeps the ``object_key`` of every one-object question its record has asked
# so far (``questions_for_view`` starts it afresh): a description already asked is passed over
# before a question is built around it.
ASKED_KEY = ("asked_objects",)
SIZE_MEASURES = {"taller_than": "height", "shorter_than": "height", "wider_than": "width",
                 "thinner_than": "width", "bigger_than": "size", "smaller_than": "size"}


def asked(view: ViewFacts) -> set[str]:
    """The object keys this view's record has asked so far: those of the latest
    ``questions_for_view`` on this view (none before the first)."""
    return view.cache.get(ASKED_KEY, set())


def weighted(weights: dict, rng: np.random.Generator) -> Any:
    keys, cdf = _cumulative(tuple(weights.items()))
    # What rng.choice(len(keys), p=p) does, without its checks (a fifth of its cost was them):
    # one uniform draw looked up in the cumulative weights, so the stream is the same.
    return keys[int(cdf.searchsorted(rng.random(), side="right"))]


@functools.lru_cache(maxsize=64)
def _cumulative(items: tuple) -> tuple[tuple, np.ndarray]:
    """Keys and cumulative normalised weights of a recipe's weight table, computed as
    Generator.choice computes them (the same few tables, drawn from thousands of times)."""
    p = np.array([w for _, w in items], dtype=float)
    p /= p.sum()
    cdf = p.cumsum()
    cdf /= cdf[-1]
    cdf.flags.writeable = False  # shared by every caller
    return tuple(k for k, _ in items), cdf


def target_order(view: ViewFacts, rng: np.random.Generator) -> list:
    """Every askable object once, in a random order that favours those away from the image centre
    (the camera aims at the middle of the scene: uniform targets would pile answer points up in
    the central cells). Going down the list finds a description that fits only one object of six
    (a between, a five-step chain), where repeated weighted draws kept landing on the same few."""
    objs = view.askable()
    # Weighted sampling without replacement: each key u ** (1 / weight), largest first. Sorted as
    # Python floats, stably, as numpy's stable argsort of the negated keys orders them (a few
    # objects: the array sort's set-up cost more than the sort).
    keys = (rng.random(len(objs)) ** _target_exponents(view)).tolist()
    return [objs[i] for i in descending(keys)]


def descending(keys: list[float]) -> list[int]:
    """``np.argsort(-np.array(keys), kind="stable")`` as a list: indices by key, largest first,
    equal keys in index order."""
    return sorted(range(len(keys)), key=keys.__getitem__, reverse=True)


def _target_exponents(view: ViewFacts) -> np.ndarray:
    """1 / each askable object's weight (memoised per view: every target search asks)."""
    if TARGET_EXPONENTS_KEY not in view.cache:
        objs = view.askable()
        centre = np.array([view.width / 2, view.height / 2])
        diag = float(np.hypot(view.width, view.height))
        w = np.array([0.05 + np.linalg.norm(np.array(o.centroid_px or centre) - centre) / diag for o in objs]) ** 3
        view.cache[TARGET_EXPONENTS_KEY] = 1.0 / (w / w.sum())
    return view.cache[TARGET_EXPONENTS_KEY]


def over_objects(view: ViewFacts, objects, node: Node, rng) -> tuple[list[Node], list, list[str]] | None:
    """Describe each object in the plainest way that works, then apply ``node`` to them.

    Returns (program, values, the objects' words), or None when an object has no
    safe description or the final node does not execute (near-tie).
    """
    book = Phrasebook.get()
    program: list[Node] = []
    ids, words = [], []
    for o in objects:
        refs = simple_refs(view, o)[:1]
        if not refs:
            return None
        text, texts = book.describe(refs[0], rng, view)
        ids.append(compile_ref(refs[0], program, texts))
        words.append(text)
    program.append({**node, "inputs": ids})
    try:
        return program, execute(program, view), words
    except ProgramError:
        return None


def erosion_px(view: ViewFacts) -> int:
    """About 0.5 % of the short image side, so points keep off mask borders at any resolution."""
    return max(1, round(min(view.width, view.height) / 180))


def sample_mask_points(mask: np.ndarray, n: int, rng: np.random.Generator, erode: int) -> list[list[float]] | None:
    """n normalised (x, y) points on a frame-sized mask, eroded first; each rounded point is
    checked on the mask. A point (x, y) stands for pixel column floor(x * W), row floor(y * H)."""
    # 0/1 either way (a mask of other values is on where its uint8 cast is not 0, as it was).
    m = mask.view(np.uint8) if mask.dtype == bool else (mask.astype(np.uint8) != 0).view(np.uint8)
    x, y, w, h = cv2.boundingRect(m)
    if w == 0:
        return None
    window = padded((slice(y, y + h), slice(x, x + w)), erode + 1, mask.shape)
    return _draw_points(_eroded(m[window], erode, window), lambda r, c: mask[r, c], n, rng, mask.shape)


def sample_points(view: ViewFacts, object_id: int, n: int, rng: np.random.Generator) -> list[list[float]] | None:
    """n points on the object's eroded visible mask."""
    key = ("eroded_pixels", object_id)
    if key not in view.cache:  # the same objects are pointed at in question after question
        box = box_of(cached_boxes(view), object_id)
        pixels = None
        if box is not None:
            erode = erosion_px(view)
            window = padded(box, erode + 1, view.seg.shape)
            pixels = _eroded((view.seg[window] == object_id).view(np.uint8), erode, window)
        view.cache[key] = pixels
    if view.cache[key] is None:
        return None
    return _draw_points(view.cache[key], lambda r, c: view.seg[r, c] == object_id, n, rng, view.seg.shape)


class _Pixels(NamedTuple):
    """A window's pixels, row by row: their indices in the raveled window, and where the window
    lies (its width, its first row and column in the frame)."""

    flat: np.ndarray
    width: int
    row0: int
    col0: int


def _eroded(mask: np.ndarray, erode: int, window: tuple[slice, slice]) -> _Pixels:
    """The pixels of a 0/1 uint8 window of the frame (``mask``, cut at ``window``) left after
    ``erode`` 3x3 erosions. The window must reach erode + 1 pixels past the mask (or the frame's
    edge): then no pixel near the window's border is one the erosion could keep, and the result
    is the whole frame's."""
    # ``erode`` 3x3 erosions are one erosion by a (2 erode + 1) square, which OpenCV runs as two
    # separable passes whatever its size. Its 0/1 result read as bool and raveled finds its
    # pixels ten times quicker than a 2-D uint8 nonzero (17 against 184 us a 220 x 180 window),
    # in the same row-by-row order.
    kept = cv2.erode(mask, np.ones((2 * erode + 1, 2 * erode + 1), np.uint8))
    return _Pixels(kept.view(bool).ravel().nonzero()[0], kept.shape[1], window[0].start, window[1].start)


def _draw_points(pixels: _Pixels, on_mask, n: int, rng: np.random.Generator,
                 frame: tuple[int, int]) -> list[list[float]] | None:
    """n of the candidate pixels, at random, as normalised points that round back onto the mask."""
    flat, width, row0, col0 = pixels
    if len(flat) == 0:
        return None
    h, w = frame
    points: list[list[float]] = []
    for _ in range(n * POINT_TRIES):
        k = int(rng.integers(len(flat)))
        row, col = divmod(int(flat[k]), width)
        x, y = _thousandths((col + col0 + 0.5) / w), _thousandths((row + row0 + 0.5) / h)
        if on_mask(min(int(y * h), h - 1), min(int(x * w), w - 1)):
            points.append([x, y])
            if len(points) == n:
                return points
    return None


def _thousandths(v: float) -> float:
    """``v`` rounded to 3 decimals as numpy rounds (scaled, rounded half to even, scaled back),
    which a point's coordinates always were: here in Python floats (0.3 against 4.7 us a
    coordinate through numpy's scalars; every pixel centre of common frame sizes rounds alike,
    tests/test_questions.py)."""
    return round(v * 1000.0) / 1000.0


def format_points(points: list[list[float]]) -> str:
    return "[" + ", ".join(f"({x:.3f}, {y:.3f})" for x, y in points) + "]"


def trace(program: list[Node], values: list, views: dict[str, ViewFacts], rng) -> list[dict] | None:
    """Reasoning steps in RefSpatial's format: where each named object is, and the orientations and
    sizes the relations compare, in the order the program uses them."""
    steps: list[dict] = []
    texts = {k: n.get("text", "") for k, n in enumerate(program) if n["op"] == "unique"}
    for k, (node, value) in enumerate(zip(program, values)):
        view = views[node.get("view", "self")]
        if node["op"] == "unique":
            point = sample_points(view, value, 1, rng)
            if point is None:
                return None
            steps.append(_in_view(node, {"kind": "Position", "text": node.get("text", ""), "object_id": int(value),
                                         "point": point[0]}))
        elif node["op"] == "relate" and node["predicate"] in ORIENTATION_PREDICATES:
            for a in node["inputs"][1:]:
                front = view.T_world_cam[:3, :3].T @ view.objects[values[a]].front_world
                steps.append(_in_view(node, {"kind": "Orientation", "text": texts[a], "object_id": int(values[a]),
                                             "vector": [round(float(c), 3) for c in front / np.linalg.norm(front)]}))
        elif node["op"] == "relate" and node["predicate"] in SIZE_MEASURES:
            for a in node["inputs"][1:]:
                steps.append(_in_view(node, _size_step(view, texts[a], values[a], SIZE_MEASURES[node["predicate"]])))
    return steps


def _in_view(node: Node, step: dict) -> dict:
    """Steps read in the other image of a multi-view question say so."""
    if node.get("view", "self") != "self":
        step["view"] = node["view"]
    return step


def _size_step(view: ViewFacts, text: str, object_id: int, measure: str) -> dict:
    o = view.objects[object_id]
    value = {"height": o.height_m, "width": o.extent_along(view.right_axis), "size": o.volume_m3 ** (1 / 3)}[measure]
    return {"kind": "Size", "text": text, "object_id": int(object_id), "measure": measure, "value": round(value, 3)}


def trace_text(steps: list[dict]) -> str:
    lines = []
    for s in steps:
        if s["kind"] == "Position":
            lines.append(f"[Position] [{s['text']}]: {format_points([s['point']])}")
        elif s["kind"] == "Orientation":
            lines.append(f"[Orientation] [{s['text']}]: ({s['vector'][0]:.3f}, {s['vector'][1]:.3f}, {s['vector'][2]:.3f})")
        else:
            lines.append(f"[Size] [{s['text']}]: {s['value']:.2f}")
    return "\n".join(lines)


def point_qa(family: str, template: str, text: str, program: list[Node], values: list,
             views: dict[str, ViewFacts], spec: dict, rng, fill: dict[str, str] | None = None,
             **extra: Any) -> QA | None:
    """A point question about the object the program ends on, in the record's own view. ``fill``
    gives the template's placeholders other than {ref} and {clauses}."""
    points = sample_points(views["self"], values[-1], spec["answer_points"], rng)
    if points is None:
        return None
    prompt = Phrasebook.get().template(template, rng=rng).format(ref=text, clauses=text, **(fill or {}))
    return make_qa(family, "point", prompt, format_points(points), program, values, views, rng,
                   points=points, target=values[-1], **extra)


# Measures that ask a registered predicate in other words: centre to centre is still a distance.
MEASURED_PREDICATE = {"centre_distance": "distance_between"}


def make_qa(family: str, kind: str, prompt: str, answer: str, program: list[Node], values: list,
            views: dict[str, ViewFacts], rng, points: list[list[float]] | None = None,
            target: int | None = None, ref: str | None = None, **extra: Any) -> QA | None:
    """The stored QA record; point questions get RoboRefer's suffix and a reasoning trace."""
    steps = trace(program, values, views, rng) if points else []
    if steps is None:
        return None
    if steps and target is not None and steps[-1].get("object_id") == target and "view" not in steps[-1]:
        steps[-1]["point"] = points[0]  # the chain ends where the answer points
    qa: QA = {
        "family": family,
        "kind": kind,
        "prompt": prompt,
        "question": f"{prompt} {Phrasebook.get().point_suffix}" if points else prompt,
        "answer": answer,
        "answer_points": points or [],
        "target_id": None if target is None else int(target),
        "ref": ref,
        "steps": with_results(program, values),
        "num_steps": count_steps(program),
        "predicates": sorted({n["predicate"] for n in program if "predicate" in n}
                             | {MEASURED_PREDICATE.get(n["quantity"], n["quantity"]) for n in program
                                if n["op"] == "measure" and MEASURED_PREDICATE.get(n["quantity"], n["quantity"]) in PREDICATES}
                             | ({"free_space"} if any(n["op"] == "free_space" for n in program) else set())),
        "reasoning_steps": steps,
        "reasoning": f"<think>{trace_text(steps)}</think><answer>{answer}</answer>" if points else None,
    }
    qa.update(extra)
    return qa
