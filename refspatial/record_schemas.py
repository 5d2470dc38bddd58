"""The topics of a shard and the schema each one carries, so a shard describes itself.

The JSON schemas of ``/scene``, ``/relations`` and ``/qa`` are data: one file per topic in
``refspatial/schemas/`` (JSON Schema 2020-12), read once here and written verbatim (compact)
into every shard. They name every field a record holds, with its type, unit and whether it is
required; fields that early format-1 shards lack are optional and say so. Image and
calibration topics use Foxglove's protobuf schemas. A schema shared by two topics (RawImage
for depth and seg) is registered once.

``validate(topic, message)`` checks one decoded JSON message against its schema (needs the
``jsonschema`` package: ``pip install 'refspatial[test]'``).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from mcap.writer import Writer
from mcap_protobuf.schema import build_file_descriptor_set

SCHEMA_DIR = Path(__file__).parent / "schemas"
JSON_TOPICS = {"/scene": "scene", "/relations": "relations", "/qa": "qa"}  # topic -> schemas/<name>.schema.json
IMAGE_TOPICS = {"rgb": "/camera/rgb", "depth": "/camera/depth", "seg": "/camera/seg"}
PROTO_TOPICS = {
    "/camera/calibration": (CameraCalibration, {}),
    "/camera/rgb": (CompressedImage, {"content": "RGB, lossless PNG"}),
    "/camera/depth": (RawImage, {"unit": "metre", "value": "distance along the optical axis"}),
    "/camera/seg": (RawImage, {"value": "object id + 1; 0 = background"}),
}
# One chunk per group: the JSON messages with the calibration, then each image alone.
GROUPS = ((*JSON_TOPICS, "/camera/calibration"), *((t,) for t in IMAGE_TOPICS.values()))


def _load(name: str) -> dict:
    path = SCHEMA_DIR / f"{name}.schema.json"
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise RuntimeError(f"{path}: cannot read the schema ({e}); reinstall refspatial") from None


JSON_SCHEMAS: dict[str, dict] = {topic: _load(name) for topic, name in JSON_TOPICS.items()}


def schema_bytes(topic: str) -> bytes:
    """The schema as stored in a shard: compact UTF-8 JSON, keys in file order."""
    return json.dumps(JSON_SCHEMAS[topic], ensure_ascii=False, separators=(",", ":")).encode("utf-8")


def register_channels(mcap: Writer) -> dict[str, int]:
    """Register every schema once and every topic's channel; topic -> channel id."""
    channels, schema_ids = {}, {}
    for topic, schema in JSON_SCHEMAS.items():
        sid = mcap.register_schema(schema["title"], "jsonschema", schema_bytes(topic))
        channels[topic] = mcap.register_channel(topic, "json", sid)
    for topic, (cls, meta) in PROTO_TOPICS.items():
        name = cls.DESCRIPTOR.full_name
        if name not in schema_ids:
            fds = build_file_descriptor_set(cls).SerializeToString(deterministic=True)
            schema_ids[name] = mcap.register_schema(name, "protobuf", fds)
        channels[topic] = mcap.register_channel(topic, "protobuf", schema_ids[name], meta)
    return channels


@lru_cache(maxsize=None)
def _validator(topic: str) -> Any:
    try:
        from jsonschema import Draft202012Validator
    except ImportError:
        raise ImportError("validating records needs jsonschema; pip install 'jsonschema>=4.18'") from None
    schema = JSON_SCHEMAS[topic]
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def validate(topic: str, message: dict) -> list[str]:
    """Every way ``message`` breaks its topic's schema, one line each ('' path = top level)."""
    if topic not in JSON_SCHEMAS:
        raise ValueError(f"no JSON schema for topic {topic!r}; choose one of {', '.join(JSON_SCHEMAS)}")
    errors = sorted(_validator(topic).iter_errors(message), key=lambda e: list(map(str, e.absolute_path)))
    return [f"{topic} {'/'.join(map(str, e.absolute_path))}: {e.message}" for e in errors]
