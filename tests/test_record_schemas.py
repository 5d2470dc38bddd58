"""The JSON schemas of /scene, /relations and /qa describe every field a record holds.

Real messages (generated today, and the committed golden shard written by an earlier
version of the format) validate; a message that lacks a required key, has a wrong type or
an undeclared field does not. Each schema is stored once per shard, verbatim from its file.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from refspatial.record_schemas import JSON_SCHEMAS, SCHEMA_DIR, schema_bytes, validate

jsonschema = pytest.importorskip("jsonschema")
GOLDEN_SHARD = Path(__file__).parent / "golden" / "dataset" / "shards" / "shard-00000.mcap"


def _json_messages(shard: Path) -> list[tuple[str, dict]]:
    with open(shard, "rb") as f:
        return [(c.topic, json.loads(m.data))
                for _, c, m in make_reader(f).iter_messages(topics=list(JSON_SCHEMAS))]


@pytest.fixture(scope="module")
def messages(tiny_dataset) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {t: [] for t in JSON_SCHEMAS}
    for shard in sorted((tiny_dataset / "shards").glob("*.mcap")):
        for topic, message in _json_messages(shard):
            out[topic].append(message)
    return out


def test_schema_files_are_valid_json_schema():
    for topic, schema in JSON_SCHEMAS.items():
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["additionalProperties"] is False and "key" in schema["required"]
    assert sorted(p.name for p in SCHEMA_DIR.glob("*.json")) == ["qa.schema.json", "relations.schema.json",
                                                                 "scene.schema.json"]


def test_generated_messages_validate(messages):
    assert all(messages.values())
    for topic, items in messages.items():
        for message in items:
            assert validate(topic, message) == []


def test_golden_shard_of_an_earlier_writer_validates():
    for topic, message in _json_messages(GOLDEN_SHARD):
        assert validate(topic, message) == []


def _broken(message: dict, path: tuple, value=KeyError) -> dict:
    """A deep copy with the value at ``path`` replaced (or its key removed)."""
    out = copy.deepcopy(message)
    node = out
    for step in path[:-1]:
        node = node[step]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return out


@pytest.mark.parametrize("topic, path, value, where", [
    ("/scene", ("width",), KeyError, "'width' is a required property"),
    ("/scene", ("width",), "960", "width"),
    ("/scene", ("objects", 0, "pose"), KeyError, "objects/0"),
    ("/scene", ("objects", 0, "visibility"), "maybe", "objects/0/visibility"),
    ("/scene", ("K",), [[1.0, 0.0], [0.0, 1.0]], "K"),
    ("/scene", ("objects", 0, "colour"), "red", "objects/0"),
    ("/relations", ("relations", 0, "predicate"), KeyError, "relations/0"),
    ("/relations", ("relations", 0, "objects"), "0 1", "relations/0/objects"),
    ("/qa", ("qa", 0, "answer"), KeyError, "qa/0"),
    ("/qa", ("qa", 0, "num_steps"), "2", "qa/0/num_steps"),
    ("/qa", ("qa", 0, "family"), "riddle", "qa/0/family"),
    ("/qa", ("qa", 0, "steps", 0, "op"), KeyError, "qa/0/steps/0"),
    ("/qa", ("key",), 7, "/qa key"),
])
def test_a_broken_message_fails_naming_the_place(messages, topic, path, value, where):
    message = messages[topic][0]
    assert validate(topic, message) == []
    errors = validate(topic, _broken(message, path, value))
    assert errors and any(where in e for e in errors), errors


def test_each_schema_is_stored_once_and_verbatim(tiny_dataset):
    shard = sorted((tiny_dataset / "shards").glob("*.mcap"))[0]
    with open(shard, "rb") as f:
        summary = make_reader(f).get_summary()
    names = [s.name for s in summary.schemas.values()]
    assert len(names) == len(set(names)) == 6  # three JSON, calibration, compressed and raw image
    for s in summary.schemas.values():
        if s.encoding == "jsonschema":
            topic = next(t for t, sc in JSON_SCHEMAS.items() if sc["title"] == s.name)
            assert s.data == schema_bytes(topic)
    with pytest.raises(ValueError, match="no JSON schema"):
        validate("/camera/rgb", {})
