"""Colour as a person sees it: sRGB -> CIE Lab, and the distance at which two colours read as
different (CIE76 Delta E; about 2.3 is just noticeable, 10 is clearly different at a glance)."""

from __future__ import annotations

import numpy as np

DISTINCT_DELTA_E = 10.0  # a colour word may tell two things apart only when they differ this much
_D65 = np.array([0.95047, 1.0, 1.08883])
_RGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])


def srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """CIE Lab (D65) of sRGB colours in [0, 1], shape (..., 3)."""
    c = np.asarray(rgb, dtype=np.float64)
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = linear @ _RGB_TO_XYZ.T / _D65
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], axis=-1)


def mean_lab(pixels: np.ndarray) -> tuple[float, float, float] | None:
    """Lab of the mean colour of uint8 pixels (N, 3); None without pixels."""
    if len(pixels) == 0:
        return None
    return lab_of_mean(pixels.reshape(-1, 3).mean(axis=0))


def lab_of_mean(mean_rgb: np.ndarray) -> tuple[float, float, float]:
    """Lab of a mean uint8-scale sRGB colour (3,)."""
    return tuple(float(v) for v in srgb_to_lab(mean_rgb / 255.0))  # type: ignore[return-value]


def delta_e(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a, float) - np.asarray(b, float)))
