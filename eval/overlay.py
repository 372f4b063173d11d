"""The text and activation bars `shoulder-bench render` draws over each video frame (Pillow), drawn only where they
are: the rows the overlay covers pass through Pillow, the rest of the frame is not touched (eval/render.py)."""
from __future__ import annotations

import numpy as np

from shoulder_bench.eval.render_model import PALE, SATURATED


class Overlay:
    """The text and activation bars drawn over each frame (Pillow). The static parts (title, legend) are rasterised
    once and the labels' masks are cached by their text; per frame only the rows the overlay covers (a band at the
    top, the text band at the bottom) pass through Pillow, so the pixels are those of drawing everything on the whole
    frame (tests/test_render.py compares the two): at 480 x 360, 1.0 ms a frame instead of 3.4 (activations changing
    every third frame, as in a 30 fps video of 0.1 s steps)."""

    CACHE = 4096  # text masks kept (an activation label repeats while the activation holds: 3 video frames a step)

    def __init__(self, width: int, height: int, title: str, muscles, scale: float):
        from PIL import ImageFont

        self.size = max(9, height // 22)
        self.font = ImageFont.load_default(size=self.size)
        self.small = ImageFont.load_default(size=max(8, int(self.size * 0.85)))
        self.title, self.muscles, self.scale = title, muscles, scale
        self.width, self.height = width, height
        # the layout: bottom band of time, angle, target; title top left; activation bars top right (full bar = the
        # colour scale), their labels left of them and the scale's legend below them
        self.pad = pad = max(3, self.size // 3)
        self.bar_w, self.row = max(20, width // 8), int(self.small.size * 1.3)
        self.x1 = width - pad - self.bar_w
        label_w = max(self.small.getlength(f"{m} 00.0%") for m in muscles)
        fits = self.small.getlength(title) + label_w + self.bar_w + 4 * pad < width
        self.top = pad if fits else pad + self.row
        self._masks: dict = {}

    def _text(self, ops: list, xy, text: str, font, fill, anchor: str | None = None, stroke: bool = False) -> None:
        """Append the mask operations of ImageDraw.text(xy, text, fill, font, anchor[, stroke_width=1,
        stroke_fill=black]) at whole-pixel xy: the stroke's mask in black, then the glyphs' in `fill`."""
        for width, colour in ((1, (0, 0, 0)), (0, fill)) if stroke else ((0, fill),):
            key = (text, font is self.small, anchor, width)
            mask = self._masks.get(key)
            if mask is None:
                mask = self._mask(text, font, anchor, width)
                if len(self._masks) >= self.CACHE:
                    self._masks.clear()
                self._masks[key] = mask
            if mask is not None:
                ops.append(("mask", xy[0] + mask[0], xy[1] + mask[1], mask[2], colour))

    @staticmethod
    def _mask(text: str, font, anchor: str | None, stroke_width: int):
        """(left, top, L image): the coverage Pillow draws `text` with, placed at (left, top) from the anchor point
        (ImageDraw.text at whole pixels pastes this same mask with Image.paste's blend); None if it covers nothing."""
        from PIL import Image, ImageDraw

        left, top, right, bottom = font.getbbox(text, stroke_width=stroke_width, anchor=anchor)
        if right <= left or bottom <= top:
            return None
        im = Image.new("L", (right - left, bottom - top))
        ImageDraw.Draw(im).text((-left, -top), text, fill=255, font=font, anchor=anchor,
                                stroke_width=stroke_width, stroke_fill=255)  # 255 * coverage / 255: the coverage
        return left, top, im

    def draw(self, frame: np.ndarray, t: float, angle: float, target: float, acts, crashed: bool) -> np.ndarray:
        """Draw the overlay into `frame` (height x width x 3 uint8, changed in place unless read-only) and return it."""
        if not frame.flags.writeable:
            frame = frame.copy()
        pad, s, w, h, x1, row, bar_w = self.pad, self.size, self.width, self.height, self.x1, self.row, self.bar_w
        ops: list = []  # in drawing order: ("rect", [x0, y0, x1, y1], fill, outline) or ("mask", x, y, L, colour)
        # bottom band: time, angle, target
        text = f"t {t:5.2f} s   angle {angle:6.1f}°   target {target:6.1f}°"
        if crashed:
            text += "   CRASHED"
        ops.append(("rect", [0, h - s - 2 * pad, w, h], (0, 0, 0, 150), None))
        self._text(ops, (pad, h - s - pad), text, self.font, (255, 255, 255))
        # top left: what is shown
        self._text(ops, (pad, pad), self.title, self.small, (255, 255, 255), stroke=True)
        # top right: activation bars in the muscles' colours, full bar = the colour scale
        for i, (name, a) in enumerate(zip(self.muscles, acts)):
            y = self.top + i * row
            f = min(float(a) / self.scale, 1.0)
            rgb = tuple(int(255 * c) for c in (PALE[:3] + f * (SATURATED[:3] - PALE[:3])))
            self._text(ops, (x1 - pad, y), f"{name} {100 * float(a):4.1f}%", self.small, (255, 255, 255), "ra", True)
            ops.append(("rect", [x1, y + 1, x1 + bar_w, y + row - 2], (0, 0, 0, 120), (255, 255, 255, 160)))
            ops.append(("rect", [x1, y + 1, x1 + int(round(bar_w * f)), y + row - 2], rgb, None))
        y = self.top + len(self.muscles) * row
        self._text(ops, (x1 + bar_w, y), f"bar = {100 * self.scale:g}%", self.small, (220, 220, 220), "ra", True)
        return _paint(frame, ops)


def _rows(op, height: int) -> tuple[int, int]:
    """The rows [y0, y1) of the frame an overlay operation changes (empty if none)."""
    if op[0] == "rect":
        y0, y1 = op[1][1], op[1][3] + 1  # Pillow's rectangles include their last row
    else:
        y0, y1 = op[2], op[2] + op[3].size[1]
    return max(y0, 0), min(y1, height)


def _paint(frame: np.ndarray, ops: list) -> np.ndarray:
    """Apply the overlay operations to `frame` in place, as ImageDraw.Draw(Image.fromarray(frame), "RGBA") would on the
    whole frame: each run of overlapping rows is cut out, drawn on with Pillow (rectangles blended by their alpha,
    text as Image.paste of its colour through its coverage: ImageDraw.text's own blend) and put back. Operations on
    rows apart commute; those sharing rows keep their order; the cut-outs span the whole width and end where the
    frame does wherever an operation reaches past it, so Pillow clips exactly as on the frame."""
    from PIL import Image, ImageDraw

    height = frame.shape[0]
    spans = [_rows(op, height) for op in ops]
    runs: list[list] = []  # [y0, y1, op indices]
    for k in sorted((k for k, (a, b) in enumerate(spans) if b > a), key=lambda k: spans[k]):
        a, b = spans[k]
        if runs and a <= runs[-1][1]:
            runs[-1][1] = max(runs[-1][1], b)
            runs[-1][2].append(k)
        else:
            runs.append([a, b, [k]])
    for y0, y1, members in runs:
        im = Image.fromarray(frame[y0:y1])
        d = ImageDraw.Draw(im, "RGBA")
        for k in sorted(members):
            op = ops[k]
            if op[0] == "rect":
                x0, ya, xb, yb = op[1]
                d.rectangle([x0, ya - y0, xb, yb - y0], fill=op[2], outline=op[3])
            else:
                _, x, y, mask, colour = op
                im.paste(colour, (x, y - y0, x + mask.size[0], y - y0 + mask.size[1]), mask)
        frame[y0:y1] = np.asarray(im)
    return frame
