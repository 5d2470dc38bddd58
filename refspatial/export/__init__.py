"""Exports of a refspatial dataset into the layouts other tools read unchanged.

Every exporter is a function ``(dataset_dir, out_dir, **options) -> ExportSummary`` in its
own module, listed in ``FORMATS`` by name; a module is imported only when its format is
used, so pxr, pycolmap, open3d and pyarrow load only for the export that needs them.

    from refspatial.export import export
    export("roborefer", Path("data/demo"), Path("exports/roborefer"), max_turns=15)

On the command line: ``refspatial export FORMAT DIR OUT [options]`` (see ``add_cli``).
"""

from __future__ import annotations

import argparse
import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..argtypes import at_least
from .base import ExportError, ExportSummary

__all__ = ["FORMATS", "ExportError", "ExportSummary", "Format", "add_cli", "export", "exporter", "run_cli"]


_positive_int = at_least(1)
_nonnegative_float = at_least(0.0, float)


@dataclass(frozen=True)
class Option:
    """One command-line option of a format: argparse's flag and keywords (dest = the
    exporter's keyword argument)."""

    flag: str
    kwargs: dict[str, Any]

    @property
    def dest(self) -> str:
        return self.flag.lstrip("-").replace("-", "_")


@dataclass(frozen=True)
class Format:
    name: str
    target: str  # "module:function", imported on first use
    help: str
    options: tuple[Option, ...] = ()

    def load(self) -> Callable[..., ExportSummary]:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module, __name__), function)


_UNSEEN = Option("--unseen-share", {
    "type": _nonnegative_float, "default": 0.0, "metavar": "F",
    "help": "hold out about this share of predicate combinations (a fixed hash of their names): "
            "training subsets leave them out, the Unseen bench split tests them (default: 0)"})
_ASCII = Option("--ascii", {"action": "store_true", "help": "write text files instead of binary"})
FORMATS: dict[str, Format] = {f.name: f for f in (
    Format("roborefer", ".roborefer:export_roborefer",
           "RoboRefer / LLaVA-style JSON subsets with image/ and depth/ folders and their registration",
           (Option("--max-turns", {"type": _positive_int, "default": 15,
                                   "help": "QA turns per record, at most 15 (default: 15)"}),
            Option("--depth-encoding", {"choices": ("linear", "inverse"), "default": "linear",
                                        "help": "depth PNGs: linear metric depth, or inverse (relative inverse "
                                                "depth as Depth Anything gives RoboRefer at inference); both "
                                                "min-max per image, near bright (default: linear)"}),
            _UNSEEN)),
    Format("bench", ".bench:export_bench",
           "RefSpatial-Bench layout: <Split>/question.json with RGB and mask PNGs, and as Parquet",
           (_UNSEEN,)),
    Format("parquet", ".parquet:export_parquet",
           "Hugging Face datasets Parquet: one row per record, images as Image structs"),
    Format("usd", ".usd:export_usd", "one USD stage per scene (meshes rebuilt from recipe and seed)",
           (_ASCII,)),
    Format("colmap", ".colmap:export_colmap", "one COLMAP reconstruction per scene, points from depth",
           (Option("--stride", {"type": _positive_int, "default": 4,
                                "help": "seed a 3-D point every STRIDE pixels (default: 4)"}),
            Option("--depth-tolerance-m", {"type": _nonnegative_float, "default": 0.01,
                                           "help": "depth agreement for a view to join a track (default: 0.01)"}),
            Option("--text", {"action": "store_true", "help": "write cameras.txt ... instead of .bin"}))),
    Format("pointcloud", ".pointcloud:export_pointcloud", "coloured PLY point clouds per record (world frame)",
           (Option("--voxel-size-m", {"type": _nonnegative_float, "default": 0.0,
                                      "help": "voxel downsampling size in metres, 0 = off (default: 0)"}),
            Option("--keep-background", {"action": "store_true", "help": "keep sky pixels (far plane)"}),
            Option("--objects-only", {"action": "store_true", "help": "keep object pixels only"}),
            _ASCII)),
)}


def exporter(name: str) -> Callable[..., ExportSummary]:
    """The export function of a format."""
    if name not in FORMATS:
        raise ExportError(f"unknown export format {name!r}; choose one of {', '.join(FORMATS)}")
    return FORMATS[name].load()


def export(name: str, dataset_dir: Path | str, out_dir: Path | str, **options: Any) -> ExportSummary:
    """Export ``dataset_dir`` (a folder with manifest.json) to ``out_dir`` as format ``name``."""
    dataset_dir, out_dir = Path(dataset_dir), Path(out_dir)
    src, dst = dataset_dir.resolve(), out_dir.resolve()
    if dst == src or dst in src.parents:  # --overwrite would delete the dataset being read
        raise ExportError(f"OUT {out_dir} holds DIR {dataset_dir}; choose an OUT outside the dataset folder")
    return exporter(name)(dataset_dir, out_dir, **options)


# --- command line ------------------------------------------------------------------------------


def add_cli(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``export FORMAT DIR OUT [options]``; dispatch with ``args.func(args)``."""
    parser = subparsers.add_parser("export", help="write a dataset in a layout other tools read",
                                   description="Write a dataset in a layout other tools read unchanged.")
    formats = parser.add_subparsers(dest="format", metavar="FORMAT", required=True)
    for f in FORMATS.values():
        sub = formats.add_parser(f.name, help=f.help, description=f.help)
        sub.add_argument("dir", type=Path, metavar="DIR", help="dataset folder (holds manifest.json)")
        sub.add_argument("out", type=Path, metavar="OUT", help="output folder; must not exist or be empty")
        sub.add_argument("--overwrite", action="store_true", help="replace a non-empty OUT once the export is done")
        for option in f.options:
            sub.add_argument(option.flag, dest=option.dest, **option.kwargs)
        sub.set_defaults(func=run_cli, export_options=tuple(o.dest for o in f.options))
    return parser


def run_cli(args: argparse.Namespace) -> int:
    """Run the export the parsed arguments describe and print its one-line summary."""
    options = {dest: getattr(args, dest) for dest in args.export_options}
    summary = export(args.format, args.dir, args.out, overwrite=args.overwrite, **options)
    print(summary.line())
    return 0
