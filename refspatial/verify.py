"""`refspatial verify DIR`: re-execute every stored program on its stored record and check it.

Checks, per QA: every node's stored value equals the recomputed one; referring
programs are not degenerate; the step count follows the rule; point answers lie
on the target's visible mask (placement points on the stored free-region mask,
which must equal the recomputed one); choice letters, counts and quantities agree
with the program's value; every reasoning step's point, vector or size matches; the
wording rules hold (camera moves only between views a person can compare, a named side
only where it faces the camera, "outside" only of a container that holds something,
marked boxes that do not nest).
Per shard: the checksum matches the manifest. Nothing is trusted that can be
recomputed from the record itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from .annotate import rle_decode
from .manifest import read_manifest
from .questions.common import SIZE_MEASURES, _size_step
from .questions.multiview import camera_move_askable
from .questions.program import ProgramError, count_steps, execute, is_degenerate
from .questions.refer import holds_anything
from .questions.sides import SIDE_PREDICATES, side_visible
from .questions.visual import marks_apart
from .records import ShardError, ShardReader, sha256_file
from .relations import ViewFacts
from .relations.stored import facts_from_record

FLOAT_TOL = 1e-4


@dataclass
class Report:
    shards: int = 0
    records: int = 0
    qa: int = 0
    checks: int = 0
    failures: list[str] = field(default_factory=list)

    def fail(self, where: str, problem: str) -> None:
        self.failures.append(f"{where}: {problem}")


def verify(root: Path) -> Report:
    root = Path(root)
    manifest = read_manifest(root)
    report = Report()
    for shard in manifest["shards"]:
        path = root / shard["file"]
        report.shards += 1
        if not path.is_file():
            report.fail(shard["file"], "missing")
            continue
        if sha256_file(path) != shard["sha256"]:
            report.fail(shard["file"], "sha256 differs from manifest.json")
            _name_damaged_records(shard["file"], path, report)
            continue
        for scene in _scenes(ShardReader(path)):
            _verify_scene(shard["file"], scene, report)
    return report


def _name_damaged_records(file: str, path: Path, report: Report) -> None:
    """Which records of a changed shard no longer read back (each chunk has its own CRC), so the
    failure names them, not only the shard; the shard's index itself may be what broke. Each
    record's key is read on its own: a damaged JSON chunk loses its record's key, not the others'."""
    try:
        reader = ShardReader(path)
    except ShardError as exc:
        report.fail(file, f"unreadable: {_cause(exc)}")
        return
    for i in range(len(reader)):
        key = None
        try:
            key = reader.read(i, fields=())["key"]
            reader.read(i)
        except ShardError as exc:
            where = f"({key})" if key is not None else "(its key unreadable)"
            report.fail(f"{file} record {i} {where}", _cause(exc))


def _cause(exc: ShardError) -> str:
    """A ShardError's problem without the path and advice around it (the failure line has both)."""
    text = str(exc)
    return text[text.find(": ") + 2:text.rfind("; delete it")] if "; delete it" in text else text


def _scenes(reader: ShardReader) -> Iterator[list[dict]]:
    """Records grouped by scene (a scene's views are written one after another)."""
    group: list[dict] = []
    for sample in reader.iter(fields=("depth", "seg")):
        if group and group[-1]["scene"]["scene_id"] != sample["scene"]["scene_id"]:
            yield group
            group = []
        group.append(sample)
    if group:
        yield group


def _verify_scene(shard: str, samples: list[dict], report: Report) -> None:
    facts = {s["key"]: facts_from_record(s["scene"], s["seg"], s["depth_m"], s["K"], s["T_world_cam"])
             for s in samples}
    for s in samples:
        report.records += 1
        for j, qa in enumerate(s["qa"]):
            report.qa += 1
            where = f"{shard} record {s['index']} ({s['key']}) qa {j}"
            views = {"self": facts[s["key"]]}
            if qa.get("images"):
                views["other"] = facts.get(qa["images"][0])
                if views["other"] is None:
                    report.fail(where, f"image {qa['images'][0]} is not in this shard")
                    continue
            for problem in check_qa(qa, views):
                report.fail(where, problem)
            report.checks += 1


def check_qa(qa: dict, views: dict[str, ViewFacts]) -> list[str]:
    """Problems with one QA (empty when it checks out)."""
    program = [{k: v for k, v in n.items() if k != "result"} for n in qa["steps"]]
    try:
        values = execute(program, views)
    except ProgramError as exc:
        return [f"program no longer executes: {exc}"]
    problems = [f"node {k} ({n['op']}): stored {n['result']!r}, recomputed {v!r}"
                for k, (n, v) in enumerate(zip(qa["steps"], values)) if not _same(n["result"], v)]
    if any(n["op"] == "relate" for n in program) and is_degenerate(program, views, values):
        problems.append("a relation step is degenerate")
    if count_steps(program) != qa["num_steps"]:
        problems.append(f"num_steps {qa['num_steps']} but the program counts {count_steps(program)}")
    problems += _check_answer(qa, values, views)
    problems += _check_trace(qa, views)
    problems += _check_wording(qa, program, values, views)
    return problems


def _check_wording(qa: dict, program: list[dict], values: list, views: dict[str, ViewFacts]) -> list[str]:
    """The rules the question engine keeps so that a person reads the prompt one way."""
    out = []
    if qa["kind"] in ("camera_shift", "camera_turn") and not camera_move_askable(views["other"], views["self"]):
        out.append("camera move asked between views a person cannot compare")
    for n in program:
        if n["op"] not in ("relate", "query") or len(n["inputs"]) != 2:
            continue
        view = views[n.get("view", "self")]
        anchor = view.objects[values[n["inputs"][1]]]  # the side's owner, the container (no side is reversed)
        if n["predicate"] in SIDE_PREDICATES and not side_visible(view, anchor):
            out.append(f"names the {anchor.front_side} of object {anchor.object_id}, which does not face the camera")
        if n["predicate"] == "outside" and not holds_anything(view, anchor):
            out.append(f"'outside' object {anchor.object_id}, which holds nothing")
    boxes = [m["box_px"] for m in qa.get("marks") or ()]
    if any(not marks_apart(a, b) for k, a in enumerate(boxes) for b in boxes[k + 1:]):
        out.append("two marked boxes overlap or one holds most of another")
    return out


def _same(stored, value) -> bool:
    if isinstance(value, float) or isinstance(stored, float):
        return abs(float(stored) - float(value)) <= FLOAT_TOL
    if isinstance(value, (list, tuple)):
        return len(stored) == len(value) and all(_same(a, b) for a, b in zip(stored, value))
    return stored == value


def _on(mask: np.ndarray, point) -> bool:
    h, w = mask.shape
    x, y = point
    return 0 <= x < 1 and 0 <= y < 1 and bool(mask[int(y * h), int(x * w)])


def _check_answer(qa: dict, values: list, views: dict[str, ViewFacts]) -> list[str]:
    view, last = views["self"], values[-1]
    if qa["kind"] == "point" and qa["family"] == "placement":
        from .relations.free_space import solve, stored_constraints

        node = qa["steps"][-1]
        answer = solve(view, stored_constraints(node["constraints"], [values[i] for i in node["inputs"]]))
        mask = rle_decode(qa["free_mask"])
        out = [] if answer is not None and np.array_equal(answer.mask, mask) else ["free-region mask differs"]
        return out + [f"point {p} is not on the free region" for p in qa["answer_points"] if not _on(mask, p)]
    if qa["kind"] == "point":
        mask = view.seg == qa["target_id"]
        out = [] if last == qa["target_id"] else [f"target_id {qa['target_id']} but the program picks {last}"]
        return out + [f"point {p} is not on the target's mask" for p in qa["answer_points"] if not _on(mask, p)]
    expected = {
        "yes_no": lambda: "(A)" if last else "(B)",
        "pick": lambda: "(A)" if last == values[qa["steps"][-1]["inputs"][0]] else "(B)",
        "box": lambda: f"({last})",
        "count": lambda: str(last),
        "name": lambda: qa["answer"] if last == qa["target_id"] else None,
        "camera_shift": lambda: "(A)" if last == "left" else "(B)",
        "camera_turn": lambda: "(A)" if last == "left" else "(B)",
    }
    if qa["kind"] in expected:
        want = expected[qa["kind"]]()
        return [] if want == qa["answer"] else [f"answer {qa['answer']!r} but the program says {want!r}"]
    if qa["family"] == "quantitative":
        return [] if _same(qa["answer_value"]["value"], last) else ["answer_value differs from the program"]
    return [f"unknown kind {qa['kind']!r}"]


def _check_trace(qa: dict, views: dict[str, ViewFacts]) -> list[str]:
    out = []
    for step in qa.get("reasoning_steps", []):
        oid = step.get("object_id")
        if step["kind"] == "Position" and oid is not None:
            if not _on(views[step.get("view", "self")].seg == oid, step["point"]):
                out.append(f"reasoning point for {step['text']!r} is off its object")
        elif step["kind"] == "Orientation":
            v = views[step.get("view", "self")]
            front = v.T_world_cam[:3, :3].T @ v.objects[oid].front_world
            if not np.allclose(front / np.linalg.norm(front), step["vector"], atol=1e-3):
                out.append(f"orientation of {step['text']!r} differs")
        elif step["kind"] == "Size":
            again = _size_step(views[step.get("view", "self")], step["text"], oid, step["measure"])
            if abs(again["value"] - step["value"]) > 1e-3 or step["measure"] not in SIZE_MEASURES.values():
                out.append(f"size of {step['text']!r} differs")
    return out
