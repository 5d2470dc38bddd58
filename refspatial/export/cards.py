"""Dataset cards (README.md with Hugging Face metadata) for the Parquet exports.

A card states the licence and every field. Procedural assets, and everything rendered from
them, are the project's own work under Apache-2.0 (``scene_assets/LICENSES.md``); meshes
from an asset library keep their own licences, which every record names per object, so a
dataset drawing on one is tagged ``other`` and its card lists the licences seen.
"""

from __future__ import annotations

PROCEDURAL = "project-own (procedural)"  # Asset.licence of catalogue assets


def licence(licences: set[str]) -> tuple[str, str]:
    """(the card's ``license`` tag, a sentence for its text) for the objects' licences."""
    others = sorted(licences - {PROCEDURAL})
    if not others:
        return "apache-2.0", ("Apache-2.0: every asset is procedural, the refspatial project's own work, "
                              "and so are the images rendered from them.")
    return "other", ("Procedural assets and renders: Apache-2.0. Imported meshes keep their own licences: "
                     + ", ".join(others) + "; each object's is in the record's `scene` (`objects[*].licence`, "
                     "`source`). Check them before you redistribute.")


def yaml_splits(splits: dict[str, str]) -> str:
    """The ``configs`` data_files entries: split name -> file glob."""
    return "\n".join(f"  - split: {name}\n    path: {glob}" for name, glob in splits.items())


RECORDS = """---
license: {tag}
task_categories:
- visual-question-answering
configs:
- config_name: default
  data_files:
{splits}
---
# {recipe} (refspatial export)

Spatial-referring QA rendered by refspatial from recipe `{recipe}` (hash `{recipe_hash}`):
{records} rows, {qa} questions. One row per rendered view; `qa` holds its questions and answers.

**Licence.** {licence}

| column | type | meaning |
| --- | --- | --- |
| `key` | string | record key `<scene_id>/<view>` |
| `scene_id`, `view` | string | the scene and the camera |
| `view_index`, `width`, `height` | int64 | the view's index; image size in pixels |
| `image` | image | RGB PNG |
| `depth` | image | 8-bit depth, min-max normalised per image, near bright; no surface = 0 |
| `K` | 3x3 float64 | pinhole intrinsics, pixels |
| `T_world_cam` | 4x4 float64 | world <- OpenCV camera (+x right, +y down, +z forward), metres |
| `scene`, `relations` | string | the record's scene and relations as JSON |
| `qa` | list of structs | `qa_id`, `family`, `kind`, `prompt`, `question`, `answer`, `answer_points` (normalised [x, y]), `target_id`, `ref`, `num_steps`, `predicates`, `reasoning`, `images` (multi-view: the two record keys), `json` (the whole QA dict) |

Points are normalised (x, y) with x = (u + 0.5) / width. docs/FORMAT.md in the refspatial
repository describes every field. Rows hold a different number of QA, which torch's
default collate refuses; batch them with `refspatial.export.parquet.collate`:

```python
from datasets import load_dataset
from torch.utils.data import DataLoader
from refspatial.export.parquet import collate

ds = load_dataset("parquet", data_files="data/train-*.parquet", split="train")
for batch in DataLoader(ds, batch_size=8, collate_fn=collate):
    images, qa = batch["image"], batch["qa"]  # uint8 (B, H, W, 3); one list of QA dicts per row
```
"""

BENCH = """---
license: {tag}
task_categories:
- question-answering
configs:
- config_name: default
  data_files:
{splits}
---
# {recipe} benchmark (refspatial export)

Spatial-referring questions in RefSpatial-Bench's layout, rendered by refspatial from
recipe `{recipe}` (hash `{recipe_hash}`). Each split is also a folder (`Location/`,
`Placement/`, `Unseen/`) with `question.json`, images and masks, as RoboRefer's
`Evaluation/test_benchmark.py` reads them.

**Licence.** {licence}

| column | type | meaning |
| --- | --- | --- |
| `id` | int64 | question number within its split |
| `image` | image | the RGB view (PNG) |
| `mask` | image | single-channel PNG, 255 where a point counts as a hit |
| `object` | string | the referring expression of the target or free spot |
| `prompt` | string | the question without the answer-format suffix |
| `suffix` | string | RoboRefer's point-format instruction; ask `f"{{prompt}} {{suffix}}"` |
| `step` | int64 | RefSpatial-Bench step count (1-5) |

Score: the share of predicted normalised points (x, y) whose pixel (int(x W), int(y H)) is
inside the mask. `unseen` holds questions whose predicate combination is held out of the
training export made with the same `--unseen-share` (here {unseen_share}).
"""
