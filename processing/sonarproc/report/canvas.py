"""Draw a :class:`~sonarproc.report.figure.MapFigure` into a PNG with numpy alone.

No matplotlib on the run path: the rasters are resampled into the plot box by index
arrays, lines are densified to half-pixel steps and stamped with a round pen (all
vectorised), text comes from the glyph atlas (:mod:`sonarproc.report.glyphs`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.report.figure import TICK, Layout, MapFigure, Raster, Swatch, layout
from sonarproc.report.glyphs import DPI, render_text
from sonarproc.report.png import encode_png

__all__ = ["hex_rgb", "resample", "to_png"]

_INK = (34, 34, 34)


def hex_rgb(colour: str) -> tuple[int, int, int]:
    """``'#1f77b4'`` -> ``(31, 119, 180)``."""
    c = colour.lstrip("#")
    return int(c[0:2], 16), int(c[2:4], 16), int(c[4:6], 16)


def resample(img: npt.NDArray[np.generic], rows: int, cols: int) -> npt.NDArray[np.generic]:
    """Nearest-neighbour resize of ``img`` (first two axes) to ``rows`` x ``cols``.

    Examples
    --------
    >>> resample(np.array([[1, 2], [3, 4]]), 4, 2).tolist()
    [[1, 2], [1, 2], [3, 4], [3, 4]]
    """
    r = ((np.arange(rows) + 0.5) * img.shape[0] / rows).astype(np.intp)
    c = ((np.arange(cols) + 0.5) * img.shape[1] / cols).astype(np.intp)
    return img[r[:, None], c[None, :]]


def _text(
    canvas: npt.NDArray[np.uint8],
    text: str,
    role: str,
    x: int,
    y: int,
    *,
    anchor: str = "left",
    vertical: bool = False,
    colour: tuple[int, int, int] = _INK,
) -> None:
    """Draw ``text`` with its baseline at ``y`` (anchor left, centre or right of ``x``)."""
    alpha, base = render_text(text, role)
    if vertical:  # turned 90 degrees anticlockwise: the baseline becomes column ``base``
        alpha = np.rot90(alpha)
        h, w = alpha.shape
        r0, c0 = y - h // 2, x - base
    else:
        h, w = alpha.shape
        shift = {"left": 0, "centre": w // 2, "right": w}[anchor]
        r0, c0 = y - base, x - shift
    r1, c1 = min(r0 + h, canvas.shape[0]), min(c0 + w, canvas.shape[1])
    ar0, ac0 = max(0, -r0), max(0, -c0)
    r0, c0 = max(r0, 0), max(c0, 0)
    if r1 <= r0 or c1 <= c0:
        return
    a = alpha[ar0 : ar0 + r1 - r0, ac0 : ac0 + c1 - c0, None].astype(np.float32) / 255.0
    region = canvas[r0:r1, c0:c1].astype(np.float32)
    ink = np.asarray(colour, np.float32)
    canvas[r0:r1, c0:c1] = (region * (1.0 - a) + ink * a + 0.5).astype(np.uint8)


def _stroke(
    canvas: npt.NDArray[np.uint8],
    px: npt.NDArray[np.float64],
    colour: tuple[int, int, int],
    width: float,
    *,
    dashed: bool = False,
    clip: tuple[int, int, int, int] | None = None,
) -> None:
    """Draw the pixel polyline ``px`` (N x 2 column, row) with a round pen.

    A row of NaN breaks the line (separate walls of one truth profile).
    """
    finite = np.all(np.isfinite(px), axis=1)
    if not finite.any():
        return
    if px.shape[0] == 1:
        pts = px
        along = np.zeros(1)
    else:
        seg = np.diff(px, axis=0)
        valid = finite[:-1] & finite[1:]
        seg[~valid] = 0.0
        lengths = np.hypot(seg[:, 0], seg[:, 1])
        steps = np.where(valid, np.maximum(np.ceil(lengths / 0.5).astype(np.intp), 1), 0)
        px = np.where(finite[:, None], px, 0.0)
        idx = np.repeat(np.arange(seg.shape[0]), steps)
        frac = (np.arange(idx.size) - np.repeat(np.cumsum(steps) - steps, steps)) / steps[idx]
        pts = px[idx] + seg[idx] * frac[:, None]
        along = np.concatenate(([0.0], np.cumsum(lengths)))[idx] + lengths[idx] * frac
        if finite[-1]:
            pts = np.vstack((pts, px[-1:]))
            along = np.append(along, along[-1] if along.size else 0.0)
    if dashed:
        keep = (along % 14.0) < 8.0
        pts = pts[keep]
    rad = max(width / 2.0, 0.5)
    r = int(np.ceil(rad))
    oy, ox = np.mgrid[-r : r + 1, -r : r + 1]
    pen = (ox**2 + oy**2) <= rad**2 + 0.25
    cols = (np.rint(pts[:, 0]).astype(np.intp)[:, None] + ox[pen][None, :]).ravel()
    rows = (np.rint(pts[:, 1]).astype(np.intp)[:, None] + oy[pen][None, :]).ravel()
    left, top, w, h = clip if clip is not None else (0, 0, canvas.shape[1], canvas.shape[0])
    ok = (cols >= left) & (cols < left + w) & (rows >= top) & (rows < top + h)
    canvas[rows[ok], cols[ok]] = colour


def _raster(canvas: npt.NDArray[np.uint8], lay: Layout, layer: Raster) -> None:
    x0, x1, y0, y1 = layer.extent
    corners = lay.to_px(np.array([[x0, y1], [x1, y0]]))
    c0, r0 = np.rint(corners[0]).astype(int)
    c1, r1 = np.rint(corners[1]).astype(int)
    if r1 <= r0 or c1 <= c0:
        return
    block = resample(layer.rgb[::-1], r1 - r0, c1 - c0)
    if block.ndim == 2:  # grey: broadcast into the three channels on assignment
        block = block[:, :, None]
    left, top, w, h = lay.box
    cr0, cc0 = max(r0, top), max(c0, left)
    cr1, cc1 = min(r1, top + h), min(c1, left + w)
    if cr1 > cr0 and cc1 > cc0:
        canvas[cr0:cr1, cc0:cc1] = block[cr0 - r0 : cr1 - r0, cc0 - c0 : cc1 - c0]


def _frame(canvas: npt.NDArray[np.uint8], box: tuple[int, int, int, int]) -> None:
    left, top, w, h = box
    canvas[top - 1 : top + 1, left - 1 : left + w + 1] = _INK
    canvas[top + h - 1 : top + h + 1, left - 1 : left + w + 1] = _INK
    canvas[top - 1 : top + h + 1, left - 1 : left + 1] = _INK
    canvas[top - 1 : top + h + 1, left + w - 1 : left + w + 1] = _INK


def to_png(fig: MapFigure, lay: Layout | None = None) -> bytes:
    """The figure as PNG bytes at :data:`~sonarproc.report.glyphs.DPI` dpi."""
    lay = lay or layout(fig)
    canvas = np.full((lay.height, lay.width, 3), 255, np.uint8)
    left, top, _w, h = lay.box
    for layer in fig.rasters:
        _raster(canvas, lay, layer)
    for line in fig.lines:
        _stroke(
            canvas, lay.to_px(line.xy), hex_rgb(line.colour), line.width,
            dashed=line.dashed, clip=lay.box,
        )  # fmt: skip
    _frame(canvas, lay.box)
    for x, s in lay.xticks:
        canvas[top + h : top + h + TICK, x - 1 : x + 1] = _INK
        _text(canvas, s, "tick", x, top + h + TICK + 4 + render_text(s, "tick")[1], anchor="centre")
    for y, s in lay.yticks:
        canvas[y - 1 : y + 1, left - TICK : left] = _INK
        _text(canvas, s, "tick", left - TICK - 4, y + 5, anchor="right")
    _text(canvas, fig.title, "title", *lay.title_xy, anchor="centre")
    _text(canvas, fig.xlabel, "label", *lay.xlabel_xy, anchor="centre")
    _text(canvas, fig.ylabel, "label", *lay.ylabel_xy, vertical=True)
    if fig.colourbar is not None and lay.cbar_box is not None:
        cb = fig.colourbar
        cx, cy, cw, ch = lay.cbar_box
        ramp = cb.ramp[np.linspace(255, 0, ch).astype(np.intp)]
        canvas[cy : cy + ch, cx : cx + cw] = ramp[:, None, :]
        _frame(canvas, lay.cbar_box)
        for y, s in lay.cbar_ticks:
            canvas[y - 1 : y + 1, cx + cw : cx + cw + TICK] = _INK
            _text(canvas, s, "tick", cx + cw + TICK + 4, y + 5)
        _text(canvas, cb.label, "label", *lay.cbar_label_xy, vertical=True)
    for x, y, entry in lay.legend:
        if isinstance(entry, Swatch):
            canvas[y - 11 : y + 1, x + 10 : x + 22] = hex_rgb(entry.colour)
        else:
            seg = np.array([[x + 2.0, y - 5.0], [x + 30.0, y - 5.0]])
            _stroke(canvas, seg, hex_rgb(entry.colour), entry.width, dashed=entry.dashed)
        _text(canvas, entry.label or "", "tick", x + 36, y)
    return encode_png(canvas, dpi=DPI)
