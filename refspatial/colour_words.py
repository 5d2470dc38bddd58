"""Whether a colour word is true to the picture: the word an object was made with ("white") is
used only when its rendered colour reads as that word rather than another.

The prototypes are the median rendered CIE Lab of objects made with each word, measured on
generated data (``colour_words.yaml``): the renderer's light and exposure keep a white pot at
L* 56, not the 97 of its paint, so paint colours cannot be the yardstick. An object reads as its
word when that word's prototype is the nearest one to its mean rendered colour; words a render
cannot tell apart (gray and silver) count as one. Recalibrate after changing the light or the
look of materials:

    python -m refspatial.colour_words DATASET_DIR [DATASET_DIR ...] > refspatial/colour_words.yaml
"""

from __future__ import annotations

import sys
from collections import defaultdict
from functools import lru_cache
from pathlib import Path

import numpy as np
import yaml

from .vector import length

TABLE = Path(__file__).with_name("colour_words.yaml")


HEADER = """\
# Median rendered CIE Lab of objects made with each colour word (refspatial/colour_words.py says
# how they are used). Written by `python -m refspatial.colour_words DATASET_DIR ...`.
"""


# Words a render cannot tell apart: a brushed-metal "silver" and a matte "gray" both come out a
# mid gray under these lights. A constant, not read from the table, so that recalibrating never
# depends on the file it rewrites.
ALIKE = [["gray", "silver"]]


@lru_cache(maxsize=1)
def _table() -> tuple[dict[str, np.ndarray], dict[str, str]]:
    data = yaml.safe_load(TABLE.read_text(encoding="utf-8"))
    prototypes = {w: np.asarray(lab, float) for w, lab in data["prototypes"].items()}
    alike = {w: group[0] for group in data.get("alike", ALIKE) for w in group}
    return prototypes, alike


def known(word: str) -> bool:
    return word in _table()[0]


def reads_as(lab, word: str, margin: float = 0.0) -> bool:
    """Whether a mean rendered Lab colour reads as ``word``: its prototype is the nearest (up to
    words that read alike), and nearer than any word that reads otherwise by ``margin`` (CIE Lab
    units). Words without a prototype never do: nobody has looked at them."""
    prototypes, alike = _table()
    if word not in prototypes:
        return False
    lab = np.asarray(lab, float)
    distance = {w: length(lab - p) for w, p in prototypes.items()}
    group = alike.get(word, word)
    own = min(d for w, d in distance.items() if alike.get(w, w) == group)
    others = [d for w, d in distance.items() if alike.get(w, w) != group]
    return not others or own + margin < min(others)


def calibrate(*roots: Path) -> dict[str, list]:
    """Median rendered Lab per colour word over every object view of the datasets."""
    from .records import ShardReader
    from .stats import load_manifest

    labs: dict[str, list] = defaultdict(list)
    for root in roots:
        for shard in load_manifest(Path(root))["shards"]:
            for sample in ShardReader(Path(root) / shard["file"]).iter(fields=()):
                for o in sample["scene"]["objects"]:
                    if o.get("rendered_lab") is not None and o.get("color"):
                        labs[o["color"]].append(o["rendered_lab"])
    return {w: [round(float(x), 1) for x in np.median(np.asarray(v), axis=0)] for w, v in sorted(labs.items())}


def main(argv: list[str] | None = None) -> int:
    roots = [Path(a) for a in (sys.argv[1:] if argv is None else argv)]
    if not roots:
        print("usage: python -m refspatial.colour_words DATASET_DIR [DATASET_DIR ...]", file=sys.stderr)
        return 2
    table = {"prototypes": calibrate(*roots), "alike": ALIKE}
    print(HEADER + yaml.safe_dump(table, default_flow_style=None, sort_keys=False), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
