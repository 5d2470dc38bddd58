"""The image audit: what the pictures look like, re-derived from the stored pixels.

``refspatial stats`` adds this section to its JSON, text and HTML: the share of pixels that
see no surface (depth at or beyond the far plane), the looks (textures) objects and room
surfaces wear, the lights and their colour temperatures, where assets came from (procedural
or a library), and rendered-colour confusions: two things of one category whose colour words
differ, told apart in some question by colour, whose mean visible colours (recomputed here
from the RGB and segmentation, not read from the record) lie closer than
``colour.DISTINCT_DELTA_E`` in CIE Lab.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from .colour import DISTINCT_DELTA_E, delta_e, mean_lab
from .export.common import valid_depth as has_surface

KELVIN_EDGES = (1500, 2700, 3500, 4500, 5500, 6500, 12000)  # bins of the lights' colour temperature


class ImageTally:
    """Running image counts; reads the rgb, depth and seg fields of every record."""

    def __init__(self) -> None:
        self.pixels = 0
        self.void_pixels = 0
        self.records_with_void = 0
        self.object_looks: Counter = Counter()
        self.surface_looks: Counter = Counter()
        self.sources: Counter = Counter()
        self.lights_per_scene: Counter = Counter()
        self.kelvin = np.zeros(len(KELVIN_EDGES) - 1, dtype=np.int64)
        self.colour_pairs = 0  # same category, different colour words, told apart by colour in a question
        self.confusions: list[str] = []  # of those, the ones that look alike

    def add(self, sample: dict) -> None:
        scene, depth = sample["scene"], sample["depth_m"]
        void = int((~has_surface(depth)).sum())
        self.pixels += depth.size
        self.void_pixels += void
        self.records_with_void += void > 0
        for o in scene["objects"]:
            key = o.get("texture") or "untextured"
            # Procedural looks are "<look>/<pattern>/<rgb>"; an imported image is known by its hash alone.
            self.object_looks[key.split("/")[0] if "/" in key or key == "untextured" else "imported image"] += 1
            procedural = o.get("source", "procedural") == "procedural"  # a library asset's source is its origin
            self.sources["procedural" if procedural else "asset library"] += 1
        room = scene.get("room")
        if room is not None and scene.get("view_index", 0) == 0:  # a scene's room and lights, once
            for kind, s in room["surfaces"].items():
                self.surface_looks[f"{kind}: {s['look']}"] += 1
            lights = scene.get("lights", [])
            self.lights_per_scene[len(lights)] += 1
            self.kelvin += np.histogram([light["kelvin"] for light in lights], bins=KELVIN_EDGES)[0]
        self._colours(sample)

    def _colours(self, sample: dict) -> None:
        scene, rgb, seg = sample["scene"], sample["rgb"], sample["seg"]
        text = " ".join(qa["prompt"] for qa in sample["qa"])
        seen = [o for o in scene["objects"] if o["visibility"] != "hidden"]
        labs = {o["id"]: mean_lab(rgb[seg == o["id"]]) for o in seen}
        for a in seen:
            if f"{a['color']} {a['name']}" not in text:
                continue
            for b in seen:
                if b["id"] == a["id"] or b["category"] != a["category"] or b["color"] == a["color"]:
                    continue
                self.colour_pairs += 1
                if labs[a["id"]] is None or labs[b["id"]] is None or \
                        delta_e(labs[a["id"]], labs[b["id"]]) < DISTINCT_DELTA_E:
                    self.confusions.append(f"{scene['scene_id']}/{scene['view']}: the {a['color']} {a['name']} "
                                           f"against the {b['color']} {b['name']}")

    def summary(self) -> dict:
        return {
            "void_share": round(self.void_pixels / self.pixels, 6) if self.pixels else 0.0,
            "records_with_void": self.records_with_void,
            "object_looks": dict(self.object_looks.most_common()),
            "surface_looks": dict(sorted(self.surface_looks.items())),
            "asset_sources": dict(self.sources.most_common()),
            "lights_per_scene": {str(k): v for k, v in sorted(self.lights_per_scene.items())},
            "light_kelvin": {"edges": list(KELVIN_EDGES), "counts": self.kelvin.tolist()},
            "colour_pairs": self.colour_pairs,
            "colour_confusions": len(self.confusions),
            "colour_confusion_share": round(len(self.confusions) / self.colour_pairs, 4) if self.colour_pairs else 0.0,
            "colour_confusion_examples": self.confusions[:10],
        }


def format_text(images: dict) -> list[str]:
    lines = [
        "images:",
        f"  pixels with no surface   {images['void_share']:.4%} ({images['records_with_void']} records with any)",
        f"  colour confusions        {images['colour_confusions']} of {images['colour_pairs']} pairs told apart "
        f"by colour ({images['colour_confusion_share']:.1%})",
        "  lights per scene         " + ", ".join(f"{k}: {v}" for k, v in images["lights_per_scene"].items()),
        "  asset sources            " + ", ".join(f"{k}: {v}" for k, v in images["asset_sources"].items()),
        f"  object looks             {len(images['object_looks'])} in use; most common: "
        + ", ".join(list(images["object_looks"])[:6]),
    ]
    return lines
