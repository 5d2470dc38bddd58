"""Files that appear whole or not at all: written under a hidden ``.NAME.partial`` beside the
target, then renamed over it. A failed write (a full disk) removes its partial file, so a
folder never holds half a file, and a re-run has nothing stale to trip on."""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator


def partial_path(path: Path) -> Path:
    """Where ``path`` is written before it is renamed into place (``remove_partials`` finds these)."""
    return path.with_name(f".{path.name}.partial")


def file_in_the_way(folder: Path) -> Path | None:
    """The first of ``folder`` and its parents that exists but is not a folder: a mkdir there
    fails with "File exists" or "Not a directory", which names neither the file nor the fix."""
    return next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), None)


@contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """Yield the partial path to write; on success it replaces ``path``, on any error it goes."""
    tmp = partial_path(Path(path))
    try:
        yield tmp
        tmp.replace(path)
    except BaseException:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass  # a disk turned read-only: the next run's clean-up removes it
        raise


def write_json(path: Path, obj: dict) -> None:
    """``obj`` as indented, key-sorted JSON, fsynced before the rename (a crash right after
    must not leave an empty file under the final name)."""
    data = (json.dumps(obj, indent=1, sort_keys=True) + "\n").encode("utf-8")
    with replacing(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
