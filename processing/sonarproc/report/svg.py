"""Write a :class:`~sonarproc.report.figure.MapFigure` as SVG: vector axes, text and lines.

The same :class:`~sonarproc.report.figure.Layout` as the PNG, in pixel units at
:data:`~sonarproc.report.glyphs.DPI` with the page size in points, so the SVG prints at
the PNG's size. Raster layers (the maps, which are cells by nature) are embedded as PNG
at the map's own resolution and drawn without smoothing; everything else is vector.
"""

from __future__ import annotations

import base64
import html

import numpy as np

from sonarproc.report.figure import TICK, Layout, Line, MapFigure, Swatch, layout
from sonarproc.report.glyphs import DPI
from sonarproc.report.png import encode_png

__all__ = ["to_svg"]

_INK = "#222222"
_FONT = "DejaVu Sans, Arial, Helvetica, sans-serif"
_PT = {"tick": 8.0, "label": 9.5, "title": 10.5}


def _fs(role: str) -> str:
    return f"{_PT[role] * DPI / 72:.2f}"


def _text(
    s: str, role: str, x: float, y: float, anchor: str = "start", rotate: bool = False
) -> str:
    rot = f' transform="rotate(-90 {x:.1f} {y:.1f})"' if rotate else ""
    return (
        f'<text x="{x:.1f}" y="{y:.1f}" font-size="{_fs(role)}" text-anchor="{anchor}"{rot}>'
        f"{html.escape(s)}</text>"
    )


def _points(px: np.ndarray) -> str:
    px = px[np.all(np.isfinite(px), axis=1)]
    # Python floats format several times faster than numpy scalars
    return " ".join(f"{c:.1f},{r:.1f}" for c, r in px.tolist())


def _line(entry: Line, pts: str, clip: bool = True) -> str:
    dash = ' stroke-dasharray="8 6"' if entry.dashed else ""
    cp = ' clip-path="url(#plot)"' if clip else ""
    return (
        f'<polyline points="{pts}" fill="none" stroke="{entry.colour}" '
        f'stroke-width="{entry.width:.1f}" stroke-linejoin="round"{dash}{cp}/>'
    )


def to_svg(fig: MapFigure, lay: Layout | None = None, *, max_points: int = 2000) -> str:
    """The figure as an SVG document (lines thinned to at most ``max_points`` vertices)."""
    lay = lay or layout(fig)
    left, top, w, h = lay.box
    wpt, hpt = lay.width * 72 / DPI, lay.height * 72 / DPI
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{wpt:.1f}pt" height="{hpt:.1f}pt" '
        f'viewBox="0 0 {lay.width} {lay.height}" font-family="{_FONT}" fill="{_INK}">',
        f"<title>{html.escape(fig.title)}</title>",
        f'<defs><clipPath id="plot"><rect x="{left}" y="{top}" width="{w}" height="{h}"/>'
        "</clipPath></defs>",
        f'<rect width="{lay.width}" height="{lay.height}" fill="#ffffff"/>',
    ]
    for layer in fig.rasters:
        x0, x1, y0, y1 = layer.extent
        (c0, r0), (c1, r1) = lay.to_px(np.array([[x0, y1], [x1, y0]]))
        uri = base64.b64encode(encode_png(layer.rgb[::-1], dpi=DPI)).decode("ascii")
        out.append(
            f'<image x="{c0:.1f}" y="{r0:.1f}" width="{c1 - c0:.1f}" height="{r1 - r0:.1f}" '
            'preserveAspectRatio="none" style="image-rendering:pixelated" '
            f'clip-path="url(#plot)" href="data:image/png;base64,{uri}"/>'
        )
    for line in fig.lines:
        xy = line.xy[:: max(line.xy.shape[0] // max_points, 1)]
        breaks = np.flatnonzero(~np.all(np.isfinite(xy), axis=1))
        for piece in np.split(xy, breaks):  # a NaN row breaks the line
            piece = piece[np.all(np.isfinite(piece), axis=1)]
            if piece.shape[0] >= 2:
                out.append(_line(line, _points(lay.to_px(piece))))
    out.append(
        f'<rect x="{left}" y="{top}" width="{w}" height="{h}" fill="none" '
        f'stroke="{_INK}" stroke-width="1.5"/>'
    )
    ticks = [f"M{x} {top + h}v{TICK}" for x, _ in lay.xticks]
    ticks += [f"M{left} {y}h{-TICK}" for y, _ in lay.yticks]
    for x, s in lay.xticks:
        out.append(_text(s, "tick", x, top + h + TICK + 4 + 14, "middle"))
    for y, s in lay.yticks:
        out.append(_text(s, "tick", left - TICK - 4, y + 5, "end"))
    out.append(_text(fig.title, "title", *lay.title_xy, "middle"))
    out.append(_text(fig.xlabel, "label", *lay.xlabel_xy, "middle"))
    out.append(_text(fig.ylabel, "label", *lay.ylabel_xy, "middle", rotate=True))
    if fig.colourbar is not None and lay.cbar_box is not None:
        cb = fig.colourbar
        cx, cy, cw, ch = lay.cbar_box
        hexes = ["#" + "".join(f"{v:02x}" for v in cb.ramp[k * 255 // 8]) for k in range(9)]
        hexes = ["#" + "".join(f"{v:02x}" for v in cb.ramp[k * 255 // 8]) for k in range(9)]
        stops = "".join(
            f'<stop offset="{k / 8:.3f}" stop-color="{c}"/>' for k, c in enumerate(hexes)
        )
        out.append(
            f'<defs><linearGradient id="cbar" x1="0" y1="1" x2="0" y2="0">{stops}'
            "</linearGradient></defs>"
            f'<rect x="{cx}" y="{cy}" width="{cw}" height="{ch}" fill="url(#cbar)" '
            f'stroke="{_INK}" stroke-width="1.5"/>'
        )
        ticks += [f"M{cx + cw} {y}h{TICK}" for y, _ in lay.cbar_ticks]
        for y, s in lay.cbar_ticks:
            out.append(_text(s, "tick", cx + cw + TICK + 4, y + 5))
        out.append(_text(cb.label, "label", *lay.cbar_label_xy, "middle", rotate=True))
    out.append(f'<path d="{"".join(ticks)}" stroke="{_INK}" stroke-width="1.5"/>')
    for x, y, entry in lay.legend:
        if isinstance(entry, Swatch):
            out.append(
                f'<rect x="{x + 10}" y="{y - 11}" width="12" height="12" fill="{entry.colour}"/>'
            )
        else:
            out.append(_line(entry, f"{x + 2},{y - 5} {x + 30},{y - 5}", clip=False))
        out.append(_text(entry.label or "", "tick", x + 36, y))
    out.append("</svg>\n")
    return "\n".join(out)
