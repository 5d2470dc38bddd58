"""Sizes, colours and the pixel layout of ``refspatial show``'s picture, shared by the panels
(``show.py``) and what is drawn over the RGB panel (``show_overlay.py``)."""

from __future__ import annotations

from dataclasses import dataclass

PANEL_WIDTH_PX = 960
DPI = 128  # a power of two: figure inches * DPI is an exact pixel count, so the layout is exact
GAP_PX, TITLE_PX, PAD_PX = 6, 30, 10
TEXT_PX, LABEL_PX = 15, 13  # font heights (pixels) of the text block and of labels on the images
LINE_PX = round(TEXT_PX * 1.4)
CHAR_PX = TEXT_PX * 0.6  # DejaVu Sans averages under 0.6 em per character, so wrapped lines fit
MARKER_PX, STEP_PX = 16, 18  # diameters of answer markers and numbered step discs
RING_PX = 5  # the k-th QA's outlines lie k * RING_PX outside the mask, so shared objects show every ring
LABEL_CHARS = 28  # step texts are cut to this on the image; the text block keeps them whole
DEFAULT_QA = 4  # QAs drawn when --qa is not given; more crowd the picture
QA_COLORS = ("#ff1493", "#00b4ff", "#ffa500", "#32cd32", "#a45cff", "#ff4500")
BACKGROUND_RGB = (40, 40, 40)  # segmentation background, and depth pixels where nothing was hit


class ShowError(ValueError):
    """A record or QA index that does not exist, or a bad --out; the message says what to pass."""


@dataclass(frozen=True)
class Layout:
    """Where everything lands in the output PNG, in output pixels (origin top-left)."""

    width: int  # the record's image size
    height: int
    crop: tuple[float, float, float, float]  # x0, y0, w, h of the record shown, record pixels
    text_lines: int

    @property
    def scale(self) -> float:  # output pixels per record pixel in the RGB panel
        return PANEL_WIDTH_PX / self.crop[2]

    @property
    def main(self) -> tuple[int, int, int, int]:  # x, y, w, h
        return 0, TITLE_PX, PANEL_WIDTH_PX, round(self.crop[3] * self.scale)

    def side(self, k: int) -> tuple[int, int, int, int]:
        """Depth (k=0) and segmentation (k=1), stacked right of the RGB panel at half size."""
        _, y, w, h = self.main
        return w + GAP_PX, y + k * (h // 2 + GAP_PX // 2), w // 2, h // 2 - GAP_PX // 2

    @property
    def size(self) -> tuple[int, int]:  # output width, height
        _, y, w, h = self.main
        return w + GAP_PX + w // 2, y + h + 2 * PAD_PX + self.text_lines * LINE_PX

    def panel_xy(self, x: float, y: float) -> tuple[float, float]:
        """Record pixel coordinates -> output pixels within the RGB panel."""
        return (x - self.crop[0]) * self.scale, (y - self.crop[1]) * self.scale

    def to_pixel(self, x: float, y: float) -> tuple[int, int]:
        """Output (column, row) of a normalised record point."""
        px, py = self.panel_xy(x * self.width, y * self.height)
        return int(self.main[0] + px), int(self.main[1] + py)


def pt(px: float) -> float:
    return px * 72 / DPI


def axes(fig, lay: Layout, box: tuple[int, int, int, int]):
    fw, fh = lay.size
    x, y, bw, bh = box
    ax = fig.add_axes((x / fw, 1 - (y + bh) / fh, bw / fw, bh / fh))
    ax.set_axis_off()
    x0, y0, cw, ch = lay.crop
    ax.set_xlim(x0, x0 + cw)
    ax.set_ylim(y0 + ch, y0)
    return ax
