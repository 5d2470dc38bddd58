"""The two types every exporter returns or raises, kept free of heavy imports so that
building the command line (``add_cli``) loads neither numpy, cv2 nor the loader."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


class ExportError(ValueError):
    """An export that cannot run as asked; the one-line message names what to change."""


@dataclass(frozen=True)
class ExportSummary:
    """What one export wrote. ``counts`` are format-specific (records, QA, points ...)."""

    format: str
    out_dir: Path
    records: int  # dataset records read
    files: int  # files written under out_dir
    bytes: int  # their total size
    counts: dict[str, int] = field(default_factory=dict)

    def line(self) -> str:
        """One line for the command line."""
        extra = ", ".join(f"{v} {k}" for k, v in sorted(self.counts.items()))
        return (f"exported {self.records} records as {self.format} to {self.out_dir}: "
                f"{self.files} files, {self.bytes / 1e6:.1f} MB" + (f" ({extra})" if extra else ""))
