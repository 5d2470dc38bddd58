"""Procedural texture images: wood, stone, tiles, fabric, plaster, glaze, brushed metal, fur,
fruit skin, printed labels, screens and keys.

Every generator is a pure function of its parameters (a mapping from
``scene_assets/textures.yaml``), a base colour and a seed, and returns a float image
(H, W, 3) in [0, 1], top row first. Generators keep the image's mean near the base colour
(print, grain and speckle are small shares of the area) so that the colour word an object
is named by stays what a person sees. All noise tiles, so a pattern wrapped around a
cylinder or repeated over a floor shows no seam.

Images are cached per process by (texture name, colour, seed): scenes reuse the same few
hundred images (764 for the shipped catalogue and looks, 57 MiB, 2.2 s to make them all), and
making one costs a few milliseconds. The cache holds them all, so a long run makes each once.
"""

from __future__ import annotations

import functools
from typing import Callable

import cv2
import numpy as np

Image = np.ndarray  # (H, W, 3) float32 in [0, 1]
Generator = Callable[[dict, np.ndarray, np.random.Generator, tuple[int, int]], Image]
GENERATORS: dict[str, Generator] = {}
# Every image the shipped catalogue and looks can ask for, with room to spare (a smaller cache
# evicted images a long run asks for again: at 512 a few per cent of scenes remade some).
CACHE_IMAGES = 2048


def generator(name: str) -> Callable[[Generator], Generator]:
    def register(fn: Generator) -> Generator:
        GENERATORS[name] = fn
        return fn

    return register


def make(kind: str, params: tuple[tuple[str, object], ...], rgb: tuple[float, float, float], seed: int,
         size: tuple[int, int]) -> np.ndarray:
    """The uint8 image (H, W, 3) of one texture (``params`` as sorted items, so it hashes)."""
    return _make(kind, params, tuple(round(float(c), 4) for c in rgb), int(seed), tuple(size))


@functools.lru_cache(maxsize=CACHE_IMAGES)
def _make(kind: str, params: tuple, rgb: tuple, seed: int, size: tuple) -> np.ndarray:
    rng = np.random.default_rng(seed)
    image = GENERATORS[kind](dict(params), np.asarray(rgb, dtype=np.float32), rng, size)
    out = np.clip(image * 255.0 + 0.5, 0, 255).astype(np.uint8)
    out.flags.writeable = False  # shared by every scene that asks for it
    return out


# ---------------------------------------------------------------- building blocks


def noise(rng: np.random.Generator, size: tuple[int, int], cells: tuple[int, int], octaves: int = 4,
          gain: float = 0.5) -> np.ndarray:
    """Tileable fractal value noise (H, W) in about [0, 1]: cubic interpolation of random
    lattices that wrap around, each octave twice as fine and ``gain`` times as strong."""
    h, w = size
    total, amp, norm = np.zeros((h, w), np.float32), 1.0, 0.0
    gy, gx = cells
    for _ in range(octaves):
        gy, gx = min(gy, h), min(gx, w)
        total += amp * _lattice(rng, (h, w), (gy, gx))
        norm += amp
        amp *= gain
        gy, gx = gy * 2, gx * 2
    return total / norm


def _lattice(rng: np.random.Generator, size: tuple[int, int], cells: tuple[int, int]) -> np.ndarray:
    h, w = size
    gy, gx = cells
    grid = rng.random((gy, gx), dtype=np.float32)
    pad = 2
    wrapped = np.pad(grid, pad, mode="wrap")
    sy, sx = h / gy, w / gx
    big = cv2.resize(wrapped, (int(round((gx + 2 * pad) * sx)), int(round((gy + 2 * pad) * sy))),
                     interpolation=cv2.INTER_CUBIC)
    y0, x0 = int(round(pad * sy)), int(round(pad * sx))
    return big[y0:y0 + h, x0:x0 + w]


# Variation added on top of the scaled colour: scaling alone leaves a black object's grain
# below one 8-bit level, so it renders perfectly flat.
LIFT = 0.2


def shade(rgb: np.ndarray, factor: np.ndarray) -> Image:
    """The base colour scaled per pixel (factor (H, W), about 1 on average), plus a little of
    the same variation in absolute terms so that dark colours show it too."""
    f = factor[..., None]
    return np.clip(f * rgb[None, None, :] + LIFT * (f - 1.0), 0.0, 1.0).astype(np.float32)


def mix(a: Image, b: np.ndarray, alpha: np.ndarray) -> Image:
    """a where alpha is 0, b (a colour or an image) where alpha is 1."""
    return (a * (1 - alpha[..., None]) + np.asarray(b, np.float32) * alpha[..., None]).astype(np.float32)


def contrast(rgb: np.ndarray) -> np.ndarray:
    """A print colour that reads on the base: near-white on dark bases, near-black on light ones."""
    luma = float(rgb @ np.array([0.299, 0.587, 0.114]))
    return np.array([0.95, 0.95, 0.93], np.float32) if luma < 0.55 else np.array([0.08, 0.08, 0.10], np.float32)


def _grid(size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    h, w = size
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    return u / w, v / h


# ---------------------------------------------------------------- surfaces of objects


@generator("grain")
def _grain(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Wood: growth rings bent by low noise, running along x, with fibres."""
    u, v = _grid(size)
    warp = noise(rng, size, (2, 4), 3)
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (v * p["rings"] + warp * p["warp"]))
    fibres = noise(rng, size, (64, 4), 2)
    factor = 1.0 + p["depth"] * (rings - 0.5) + 0.08 * (fibres - 0.5)
    return shade(rgb, factor)


@generator("planks")
def _planks(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Floor boards or laminate: rows of planks, each its own tone, grain and end joint."""
    u, v = _grid(size)
    rows = int(p["rows"])
    row = np.minimum((v * rows).astype(int), rows - 1)
    offsets = rng.random(rows).astype(np.float32)
    tones = 1.0 + p["tone"] * (rng.random((rows, 2)).astype(np.float32) - 0.5)
    along = (u + offsets[row]) % 1.0
    half = (along >= 0.5).astype(int)
    grain = _grain({"rings": p["rings"], "warp": 0.6, "depth": p["depth"]}, np.ones(3, np.float32), rng, size)[..., 0]
    seam = (np.abs((v * rows) % 1.0 - 0.5) > 0.5 - p["gap"]) | (np.abs(along % 0.5 - 0.25) > 0.25 - p["gap"] / 2)
    factor = tones[row, half] * grain * np.where(seam, 0.55, 1.0)
    return shade(rgb, factor)


@generator("tiles")
def _tiles(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Square tiles with grout lines and a little variation from tile to tile."""
    u, v = _grid(size)
    n = int(p["count"])
    iu, iv = (u * n).astype(int) % n, (v * n).astype(int) % n
    tone = 1.0 + p["tone"] * (rng.random((n, n)).astype(np.float32) - 0.5)
    grout = (np.minimum((u * n) % 1.0, 1 - (u * n) % 1.0) < p["grout"]) | (
        np.minimum((v * n) % 1.0, 1 - (v * n) % 1.0) < p["grout"])
    speck = noise(rng, size, (16, 16), 3)
    image = shade(rgb, tone[iv, iu] * (0.95 + 0.1 * speck))
    return mix(image, np.asarray(p["grout_rgb"], np.float32), grout.astype(np.float32))


@generator("stone")
def _stone(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Stone or granite: blotches at two scales plus dark and light flecks."""
    blotch = noise(rng, size, (4, 4), 5, 0.6)
    fleck = rng.random(size, dtype=np.float32)
    factor = 1.0 + p["blotch"] * (blotch - 0.5)
    factor = np.where(fleck < p["flecks"], 0.6, np.where(fleck > 1 - p["flecks"], 1.25, factor))
    return shade(rgb, factor)


@generator("plaster")
def _plaster(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Painted plaster, matte ceramic or paper: a faint unevenness, nearly flat."""
    factor = 1.0 + p["amount"] * (noise(rng, size, (8, 8), 5, 0.55) - 0.5)
    return shade(rgb, factor)


@generator("weave")
def _weave(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Fabric: over-under threads in both directions, with slub noise."""
    u, v = _grid(size)
    n = p["threads"]
    over = ((np.floor(u * n) + np.floor(v * n)) % 2).astype(bool)  # which thread lies on top in each cell
    across_warp = np.sin(np.pi * ((u * n) % 1.0))  # a round thread: bright along its middle
    across_weft = np.sin(np.pi * ((v * n) % 1.0))
    thread = np.where(over, across_warp, across_weft)
    slub = noise(rng, size, (8, 32), 2)
    factor = 1.0 + p["depth"] * (thread - 0.64) + 0.1 * (slub - 0.5)
    return shade(rgb, factor)


@generator("fur")
def _fur(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Fur or plush: fine strands in clumps."""
    strands = noise(rng, size, (8, 128), 2)
    clumps = noise(rng, size, (6, 6), 3)
    factor = 1.0 + p["depth"] * (strands - 0.5) + 0.5 * p["depth"] * (clumps - 0.5)
    return shade(rgb, factor)


@generator("brushed")
def _brushed(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Brushed metal: fine streaks along x and a slow sheen."""
    streaks = noise(rng, size, (128, 2), 2)
    sheen = noise(rng, size, (2, 2), 2)
    factor = 1.0 + p["streaks"] * (streaks - 0.5) + p["sheen"] * (sheen - 0.5)
    return shade(rgb, factor)


@generator("glaze")
def _glaze(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Ceramic glaze: a soft pooling of tone and sparse dark speckles in the clay."""
    pool = noise(rng, size, (3, 3), 3)
    speck = rng.random(size, dtype=np.float32) < p["speckles"]
    factor = 1.0 + p["pool"] * (pool - 0.5) - 0.35 * speck
    return shade(rgb, factor)


@generator("skin")
def _skin(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """Fruit skin: streaks along the stem axis (v) blending toward a second tone, pores and
    lenticel dots."""
    streak = noise(rng, size, (2, 24), 3)
    blush = noise(rng, size, (2, 3), 3)
    second = np.clip(rgb * np.asarray(p["second"], np.float32), 0, 1)
    amount = np.clip(p["blend"] * (blush - 0.35) * 2 + 0.3 * p["blend"] * (streak - 0.5), 0, 1)
    image = mix(shade(rgb, 1.0 + 0.06 * (streak - 0.5)), second, amount)
    pores = noise(rng, size, (64, 64), 1)
    image = shade(np.ones(3, np.float32), 1.0 + p["pores"] * (pores - 0.5)) * image
    dots = rng.random(size, dtype=np.float32) < p["dots"]
    return mix(image, np.clip(rgb * 1.35 + 0.1, 0, 1), dots.astype(np.float32) * 0.7)


# ---------------------------------------------------------------- printed and lit surfaces


def _text_lines(mask: np.ndarray, rng: np.random.Generator, box: tuple[float, float, float, float],
                lines: int, height: float) -> None:
    """Rows of word-like blocks inside box (u0, v0, u1, v1, image fractions): print at a glance."""
    h, w = mask.shape
    u0, v0, u1, v1 = box
    for k in range(lines):
        top = v0 + (v1 - v0) * (k + 0.5) / lines - height / 2
        x = u0 + rng.uniform(0.0, 0.06) * (u1 - u0)
        end = u1 - rng.uniform(0.0, 0.35) * (u1 - u0)
        while x < end:
            word = rng.uniform(0.03, 0.12) * (u1 - u0)
            mask[int(top * h):max(int(top * h) + 1, int((top + height) * h)), int(x * w):int(min(x + word, end) * w)] = 1
            x += word + 0.02 * (u1 - u0)


def _logo(mask: np.ndarray, rng: np.random.Generator, centre: tuple[float, float], radius: float) -> None:
    """A round or diamond badge (fractions of the image), the label's eye-catcher."""
    h, w = mask.shape
    u, v = _grid((h, w))
    du, dv = (u - centre[0]) * w / h, v - centre[1]
    shape = np.hypot(du, dv) if rng.random() < 0.5 else np.abs(du) + np.abs(dv)
    mask[shape < radius] = 1


@generator("label")
def _label(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """A printed label in a band around a can, bottle or jar (the texture wraps once around):
    the base colour as the label's ground, a badge and lines of print on its front half, and
    a stripe. Outside the band, the container's own finish (``rim_rgb`` scaled by the base for
    glass, or as is for metal)."""
    h, w = size
    u, v = _grid(size)
    band = (v > 1 - p["top"]) & (v < 1 - p["bottom"])  # v runs down the image; the band is set bottom-up
    ink = contrast(rgb)
    image = shade(rgb, 1.0 + 0.04 * (noise(rng, size, (4, 8), 2) - 0.5))
    art = np.zeros(size, np.float32)
    top, bottom = 1 - p["top"], 1 - p["bottom"]
    span = bottom - top
    # The print faces the object's front (+x, u = 0 on the cylinder): centred on u = 0 and 1.
    _logo(art, rng, (0.0, top + 0.35 * span), 0.22 * span)
    _logo(art, rng, (1.0, top + 0.35 * span), 0.22 * span)
    lines = np.zeros(size, np.float32)
    _text_lines(lines, rng, (0.08, top + 0.62 * span, 0.32, bottom - 0.06 * span), int(p["lines"]), 0.05 * span)
    _text_lines(lines, rng, (0.68, top + 0.62 * span, 0.92, bottom - 0.06 * span), int(p["lines"]), 0.05 * span)
    stripe = np.abs(v - (top + p["stripe_at"] * span)) < p["stripe"] * span / 2
    image = mix(image, ink, np.maximum(art, lines) * band)
    image = mix(image, np.clip(rgb * 0.55, 0, 1), (stripe & band).astype(np.float32))
    rim = np.asarray(p["rim_rgb"], np.float32)
    finish = shade(rgb * rim if p["rim_tinted"] else rim, 1.0 + 0.05 * (noise(rng, size, (64, 2), 2) - 0.5))
    return np.where(band[..., None], image, finish)


@generator("print")
def _print(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """A printed box or book cover, laid on every face by box projection: a border, a title
    block and lines of text on the base colour."""
    u, v = _grid(size)
    ink = contrast(rgb)
    image = shade(rgb, 1.0 + 0.04 * (noise(rng, size, (4, 4), 2) - 0.5))
    b = p["border"]
    border = ((u < b) | (u > 1 - b) | (v < b) | (v > 1 - b)) & ~((u < b / 2) | (u > 1 - b / 2) | (v < b / 2) | (v > 1 - b / 2))
    title = np.zeros(size, np.float32)
    _text_lines(title, rng, (0.15, 0.18, 0.85, 0.32), 1, 0.09)
    lines = np.zeros(size, np.float32)
    _text_lines(lines, rng, (0.15, 0.55, 0.85, 0.85), int(p["lines"]), 0.035)
    badge = np.zeros(size, np.float32)
    _logo(badge, rng, (0.5, 0.43), 0.06)
    image = mix(image, ink, np.maximum(np.maximum(title, lines), border.astype(np.float32)))
    return mix(image, np.clip(1.0 - rgb * 0.6, 0, 1), badge)


@generator("screen")
def _screen(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """An atlas: the device's body (the left half, its base colour) and its face (the right
    half): a dark glass screen with lit panels, or a grid of keys for key faces."""
    h, w = size
    body = shade(rgb, 1.0 + 0.05 * (noise(rng, (h, w // 2), (4, 4), 2) - 0.5))
    face = np.full((h, w // 2, 3), 0.06, np.float32)
    u, v = _grid((h, w // 2))
    if p["face"] == "keys":
        n_u, n_v = int(p["cols"]), int(p["rows"])
        gu, gv = (u * n_u) % 1.0, (v * n_v) % 1.0
        key = (gu > 0.12) & (gu < 0.88) & (gv > 0.14) & (gv < 0.86)
        face = np.where(key[..., None], np.clip(rgb * 0.8 + 0.12, 0, 1), np.clip(rgb * 0.35, 0, 1)).astype(np.float32)
    else:
        m = p["bezel"]
        glass = (u > m) & (u < 1 - m) & (v > m) & (v < 1 - m)
        # A faint diagonal sheen: the glass reflects the room, it is never one flat colour.
        sheen = 0.06 * np.clip(1.0 - np.abs(u - v - 0.2) * 3.0, 0, 1) + 0.02 * noise(rng, (h, w // 2), (4, 4), 2)
        face = np.where(glass[..., None], np.asarray(p["glass_rgb"], np.float32) + sheen[..., None], face)
        for _ in range(int(p["panels"])):  # windows and icons shown on the screen
            x0, y0 = rng.uniform(m + 0.02, 0.7), rng.uniform(m + 0.02, 0.7)
            x1, y1 = min(x0 + rng.uniform(0.1, 0.35), 1 - m - 0.02), min(y0 + rng.uniform(0.06, 0.25), 1 - m - 0.02)
            panel = (u > x0) & (u < x1) & (v > y0) & (v < y1)
            face[panel] = rng.uniform(0.35, 0.95, 3).astype(np.float32)
        face = np.where(glass[..., None], face, np.clip(rgb * 0.3, 0, 1)).astype(np.float32)
    return np.concatenate([body, face], axis=1)


@generator("outdoors")
def _outdoors(p: dict, rgb: np.ndarray, rng: np.random.Generator, size: tuple[int, int]) -> Image:
    """The view out of a window: sky (``rgb`` at the top, paler at the horizon) with clouds, over
    a skyline of hills or trees (``ground_rgb``) whose height wanders with low noise."""
    h, w = size
    u, v = _grid(size)  # v = 0 is the top row
    horizon = p["horizon"]
    pale = np.clip(rgb * 0.55 + 0.45, 0, 1)
    sky = mix(np.broadcast_to(rgb, (h, w, 3)).astype(np.float32), pale, np.clip(v / horizon, 0, 1) ** 1.5)
    clouds = np.clip((noise(rng, size, (3, 6), 4) - (1 - p["clouds"])) * 4, 0, 1)
    sky = mix(sky, np.array([0.97, 0.97, 0.98], np.float32), clouds * (v < horizon))
    ridge = horizon - p["hills"] * noise(rng, (1, w), (1, 6), 3)[0]  # skyline height per column
    ground = shade(np.asarray(p["ground_rgb"], np.float32), 1.0 + 0.3 * (noise(rng, size, (8, 16), 3) - 0.5))
    return np.where((v > ridge[None, :])[..., None], ground, sky).astype(np.float32)


# ---------------------------------------------------------------- colour temperature


def kelvin_rgb(kelvin: float) -> tuple[float, float, float]:
    """Linear-ish rgb of a black body at ``kelvin`` (1000-40000 K), normalised so the largest
    channel is 1: Tanner Helland's fit of the CIE data, accurate to a few per cent, which is
    all a light's tint needs."""
    t = kelvin / 100.0
    r = 255.0 if t <= 66 else 329.698727446 * (t - 60) ** -0.1332047592
    g = 99.4708025861 * np.log(t) - 161.1195681661 if t <= 66 else 288.1221695283 * (t - 60) ** -0.0755148492
    b = 255.0 if t >= 66 else (0.0 if t <= 19 else 138.5177312231 * np.log(t - 10) - 305.0447927307)
    rgb = np.clip(np.array([r, g, b]) / 255.0, 0, 1)
    return tuple(float(c) for c in rgb / rgb.max())
