"""Folders that appear whole or not at all: written in a hidden sibling, then swapped in.

Exports and asset libraries are folders of many files; a crash or a full disk half-way must
leave the old folder (or nothing) in place, never a mixture.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator


@contextmanager
def staged_folder(out_dir: Path, cannot_write: Callable[[str], Exception]) -> Iterator[Path]:
    """A temporary sibling of ``out_dir`` that becomes ``out_dir`` when the block ends cleanly;
    on any error it is deleted and ``out_dir`` is left as it was. ``cannot_write(reason)`` makes
    the one-line error for a place that cannot be written."""
    out_dir = Path(out_dir)
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", suffix=".partial", dir=out_dir.parent))
    except OSError as e:
        raise cannot_write(e.strerror or str(e)) from None
    try:
        yield tmp
        swap_in(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def swap_in(tmp: Path, out_dir: Path) -> None:
    """Put the finished folder in place; an old one is removed only after the new one is there."""
    os.chmod(tmp, 0o755)  # mkdtemp makes 0700 folders
    old = None
    if out_dir.exists():
        old = out_dir.with_name(f".{out_dir.name}.old-{os.getpid()}")
        out_dir.rename(old)
    tmp.rename(out_dir)
    if old is not None:
        shutil.rmtree(old)
