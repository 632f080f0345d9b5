"""Text for raster figures without a font engine: a pre-rendered glyph atlas.

Importing matplotlib costs more than a whole run's processing, so the run report draws
its PNGs itself (:mod:`sonarproc.report.canvas`). Its text comes from an atlas of DejaVu
Sans glyphs (the font matplotlib ships), rendered once at the figure sizes by
:func:`build_atlas_source` and stored in :mod:`sonarproc.report.glyph_data`. Letters are
placed by their advance widths (no kerning), which reads the same at these sizes.

>>> alpha, baseline = render_text("x (m)", "label")
>>> alpha.dtype, alpha.ndim, 0 < baseline <= alpha.shape[0]
(dtype('uint8'), 2, True)
>>> text_width("10", "tick") == 2 * text_width("1", "tick")
True
"""

from __future__ import annotations

import base64
import zlib
from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt

__all__ = [
    "CHARS",
    "DPI",
    "SIZES_PT",
    "build_atlas_source",
    "missing_glyphs",
    "render_text",
    "text_width",
]

#: The pixel density the atlas (and every raster figure) is drawn at.
DPI = 150
#: Font size (points) of each text role.
SIZES_PT = {"tick": 8.0, "label": 9.5, "title": 10.5}
#: Characters in the atlas: printable ASCII and the few symbols the figures use.
CHARS = "".join(chr(c) for c in range(32, 127)) + "—–−…×°µσ≥≤±²"


@dataclass(frozen=True)
class _Glyph:
    advance: int
    left: int
    top: int  # rows above the baseline
    bitmap: npt.NDArray[np.uint8]


@cache
def _atlas() -> dict[str, tuple[int, int, dict[str, _Glyph]]]:
    from sonarproc.report.glyph_data import ATLAS

    raw = zlib.decompress(base64.b64decode(ATLAS))
    out: dict[str, tuple[int, int, dict[str, _Glyph]]] = {}
    pos = 0
    header = np.frombuffer(raw[:12], dtype="<i4")
    pos = 12
    n_roles = int(header[0])
    for _ in range(n_roles):
        name_len = int(np.frombuffer(raw[pos : pos + 4], "<i4")[0])
        name = raw[pos + 4 : pos + 4 + name_len].decode()
        pos += 4 + name_len
        ascent, descent, count = (int(v) for v in np.frombuffer(raw[pos : pos + 12], "<i4"))
        pos += 12
        glyphs: dict[str, _Glyph] = {}
        for _ in range(count):
            code, adv, left, top, h, w = (int(v) for v in np.frombuffer(raw[pos : pos + 24], "<i4"))
            pos += 24
            bm = np.frombuffer(raw[pos : pos + h * w], np.uint8).reshape(h, w)
            pos += h * w
            glyphs[chr(code)] = _Glyph(adv, left, top, bm)
        out[name] = (ascent, descent, glyphs)
    return out


def missing_glyphs(text: str) -> str:
    """The characters of ``text`` the atlas lacks (drawn as ``?``).

    >>> missing_glyphs("x (m) −1.5 ≥ 3")
    ''
    """
    glyphs = _atlas()["tick"][2]
    return "".join(sorted({ch for ch in text if ch not in glyphs}))


def text_width(text: str, role: str) -> int:
    """Width in pixels of ``text`` in the font size of ``role`` (``tick``, ``label``, ``title``)."""
    glyphs = _atlas()[role][2]
    fallback = glyphs["?"]
    return sum(glyphs.get(ch, fallback).advance for ch in text)


def text_height(role: str) -> tuple[int, int]:
    """Ascent and descent (pixels) of the font size of ``role``."""
    ascent, descent, _ = _atlas()[role]
    return ascent, descent


def render_text(text: str, role: str) -> tuple[npt.NDArray[np.uint8], int]:
    """``text`` as an alpha mask (0 = paper, 255 = ink) and the row of its baseline."""
    ascent, descent, glyphs = _atlas()[role]
    fallback = glyphs["?"]
    width = max(text_width(text, role), 1) + 2
    img = np.zeros((ascent + descent, width), np.uint8)
    x = 0
    for ch in text:
        g = glyphs.get(ch, fallback)
        h, w = g.bitmap.shape
        r0, c0 = ascent - g.top, x + g.left
        r1, c1 = min(r0 + h, img.shape[0]), min(c0 + w, width)
        if h and w and r0 >= 0 and c0 >= 0 and r1 > r0 and c1 > c0:
            np.maximum(img[r0:r1, c0:c1], g.bitmap[: r1 - r0, : c1 - c0], out=img[r0:r1, c0:c1])
        x += g.advance
    return img, ascent


def build_atlas_source() -> str:
    """Render the atlas with matplotlib's FreeType wrapper; the source of ``glyph_data``.

    Run ``python -c "from sonarproc.report.glyphs import build_atlas_source as b;
    print(b(), end='')" > processing/sonarproc/report/glyph_data.py`` after changing
    :data:`SIZES_PT` or :data:`CHARS`.
    """
    import os

    import matplotlib
    from matplotlib.ft2font import FT2Font

    path = os.path.join(os.path.dirname(matplotlib.__file__), "mpl-data/fonts/ttf/DejaVuSans.ttf")
    font = FT2Font(path)
    parts = [np.array([len(SIZES_PT), 0, 0], "<i4").tobytes()]
    for role, pt in SIZES_PT.items():
        font.set_size(pt, DPI)
        ascent = int(np.ceil(font.ascender * pt * DPI / 72 / font.units_per_EM))
        descent = int(np.ceil(-font.descender * pt * DPI / 72 / font.units_per_EM))
        name = role.encode()
        parts.append(np.array([len(name)], "<i4").tobytes() + name)
        parts.append(np.array([ascent, descent, len(CHARS)], "<i4").tobytes())
        for ch in CHARS:
            g = font.load_char(ord(ch))
            font.set_text(ch, 0.0)
            font.draw_glyphs_to_bitmap(antialiased=True)
            img = np.asarray(font.get_image(), dtype=np.uint8)
            rows, cols = np.nonzero(img)
            if rows.size:
                img = img[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
            else:
                img = np.zeros((0, 0), np.uint8)
            meta = [ord(ch), round(g.horiAdvance / 64), round(g.horiBearingX / 64)]
            meta += [round(g.horiBearingY / 64), *img.shape]
            parts.append(np.array(meta, "<i4").tobytes() + np.ascontiguousarray(img).tobytes())
    blob = base64.b64encode(zlib.compress(b"".join(parts), 9)).decode("ascii")
    lines = [blob[i : i + 96] for i in range(0, len(blob), 96)]
    body = "\n".join(f'    "{line}"' for line in lines)
    return (
        '"""Generated by :func:`sonarproc.report.glyphs.build_atlas_source`: DejaVu Sans\n'
        'glyphs (Bitstream Vera licence) at the figure sizes, zlib-compressed, base64."""\n\n'
        f"ATLAS = (\n{body}\n)\n"
    )
