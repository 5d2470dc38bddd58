"""refspatial: an open generator of multi-step spatial-referring data for VLMs."""

from __future__ import annotations

import os

# MuJoCo picks its GL backend when it is first imported; EGL works headless on CPU
# (Mesa llvmpipe) and on NVIDIA machines alike. A user's own choice (osmesa) wins.
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

__version__ = "0.1.0"
