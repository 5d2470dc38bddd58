"""Where the shipped data (asset catalogue, recipes) lives.

In a checkout (editable install) the folders sit beside the package; in a wheel
they are copied into ``refspatial/_data``. ``REFSPATIAL_DATA`` overrides both.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def data_root() -> Path:
    override = os.environ.get("REFSPATIAL_DATA")
    if override:
        return Path(override)
    for root in (_PACKAGE.parent, _PACKAGE / "_data"):
        if (root / "scene_assets").is_dir() and (root / "recipes").is_dir():
            return root
    raise FileNotFoundError(
        f"refspatial data folders not found beside {_PACKAGE}; set REFSPATIAL_DATA to the folder "
        "that holds scene_assets/ and recipes/"
    )


def assets_dir() -> Path:
    return data_root() / "scene_assets"


def recipes_dir() -> Path:
    return data_root() / "recipes"
