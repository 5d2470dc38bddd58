"""A registration of a roborefer export for RoboRefer's dataset mixture, as Python to paste.

RoboRefer lists its training sets in ``llava/data/datasets_mixture.py``: one
``Dataset(dataset_name=..., dataset_type="spatialdataset", data_path=..., image_path=...,
depth_path=...)`` per subset, passed to ``add_dataset``, and an RGB-only twin
(``..._RGB``, no ``depth_path``) of each. Its own names for RefSpatial (``2D_choice_qa``)
start with a digit, which Python refuses as a variable name; ours are
``refspatial_<recipe>_<subset>``, valid identifiers without ``+`` (the mixture separator).

The file holds one function, ``register_refspatial_<recipe>(root)``, and the mixture
string. Paths are joined to ``root`` at call time, so the file's bytes depend on the dataset
alone and the export folder may move.
"""

from __future__ import annotations

import keyword
import re
from pathlib import Path

FILE = "roborefer_mixture.py"
TEMPLATE = '''"""RoboRefer registration of a refspatial export (recipe {recipe!r}, hash {recipe_hash}).

Paste this function into RoboRefer's llava/data/datasets_mixture.py (which defines Dataset
and add_dataset), call it at the end of register_datasets_mixtures() with this folder:

    {function}("/path/to/this/export")

and train with DATA_MIXTURE set to the string {mixture_name} holds (each subset with
depth and RGB only, as RefSpatial's); join it to other names with "+".
"""

{mixture_name} = "{mixture}"


def {function}(root):
{body}'''
ENTRY = '''    {name} = Dataset(
        dataset_name="{name}",
        dataset_type="spatialdataset",
        data_path=root + "/{data}",
        image_path=root + "/{image}",{depth}
    )
    add_dataset({name})
'''


def identifier(text: str) -> str:
    """``text`` as a lower-case Python identifier: other characters become ``_``."""
    name = re.sub(r"\W+", "_", text.lower()).strip("_") or "dataset"
    return name if name.isidentifier() and not keyword.iskeyword(name) else f"_{name}"


def write_mixture(out: Path, manifest: dict, subsets: dict[str, tuple[str, str]]) -> str:
    """Write FILE into ``out``; ``subsets`` maps a subset to its (image folder, depth folder).
    Returns the mixture string."""
    prefix = f"refspatial_{identifier(manifest['recipe'])}"
    entries, names = [], []
    for subset, (image, depth) in sorted(subsets.items()):
        name = f"{prefix}_{identifier(subset)}"
        for variant, depth_line in ((name, f'\n        depth_path=root + "/{depth}",'), (f"{name}_RGB", "")):
            entries.append(ENTRY.format(name=variant, data=f"{subset}.json", image=image, depth=depth_line))
            names.append(variant)
    mixture = "+".join(names)
    text = TEMPLATE.format(recipe=manifest["recipe"], recipe_hash=manifest["recipe_hash"], function=f"register_{prefix}",
                           mixture_name=f"{prefix.upper()}_MIXTURE", mixture=mixture, body="\n".join(entries))
    (out / FILE).write_text(text, encoding="utf-8")
    return mixture
