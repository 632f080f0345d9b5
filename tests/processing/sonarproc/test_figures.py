"""The report's figures: labelled axes with units, colour bars, 150 dpi PNG + SVG, layout.

PNGs are decoded here (zlib + the "up" filter) so that pixel content can be asserted,
and SVGs parsed as XML.
"""

from __future__ import annotations

import dataclasses
import struct
import subprocess
import sys
import zlib
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, process
from sonarproc.report import write_report
from sonarproc.report.canvas import hex_rgb
from sonarproc.report.figure import layout, nice_ticks
from sonarproc.report.plots import (
    FIGURES,
    SURFACE_COLOURS,
    arcmap_figure,
    fit_curve,
    fit_figure,
    processed_figure,
    render,
)
from sonarproc.report.png import encode_png, png_dpi, png_size

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"
SVG = "{http://www.w3.org/2000/svg}"


def decode_png(data: bytes) -> np.ndarray:
    """Pixels of a PNG from :func:`encode_png` (8-bit grey or RGB, "up" filter)."""
    pos, idat, header = 8, b"", None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]
        assert zlib.crc32(kind + body) == struct.unpack(">I", data[pos + 8 + n : pos + 12 + n])[0]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    assert header is not None
    w, h, depth, colour = header[:4]
    channels = {0: 1, 2: 3}[colour]
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, w * channels + 1)
    assert depth == 8 and np.all(raw[:, 0] == 2)
    rows = np.cumsum(raw[:, 1:].astype(np.uint64), axis=0) % 256
    img = rows.astype(np.uint8).reshape(h, w, channels)
    return img[:, :, 0] if channels == 1 else img


@pytest.fixture(scope="module")
def result() -> RunResult:
    lg = read_csv_log(
        EXAMPLES / "example-readings.csv",
        EXAMPLES / "example-sensors.yaml",
        truth=read_truth_csv(EXAMPLES / "example-truth.csv"),
    )
    return process(lg, RunParams(cell=0.02, order=6))


@pytest.fixture(scope="module")
def report(result: RunResult, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("figs")
    write_report(result, out)
    return out


@given(arrays(np.uint8, st.tuples(st.integers(1, 9), st.integers(1, 9), st.just(3))))
@settings(max_examples=40, deadline=None)
def test_png_round_trips(img: np.ndarray) -> None:
    data = encode_png(img, dpi=150)
    np.testing.assert_array_equal(decode_png(data), img)
    assert png_size(data) == (img.shape[1], img.shape[0]) and png_dpi(data) == 150.0


def test_every_figure_is_a_150_dpi_png_and_an_svg(result: RunResult, report: Path) -> None:
    name = Path(result.source).name
    for stem in FIGURES:
        png = (report / f"{stem}.png").read_bytes()
        assert png_dpi(png) is not None and png_dpi(png) >= 150  # type: ignore[operator]
        w, h = png_size(png)
        assert 400 <= w <= 1400 and 250 <= h <= 1400
        root = ElementTree.fromstring((report / f"{stem}.svg").read_bytes())
        texts = [t.text for t in root.iter(f"{SVG}text")]
        assert "x (m)" in texts and "y (m)" in texts
        assert any(t and t.startswith(f"{name}: ") for t in texts)  # the title names the log
        assert root.get("width", "").endswith("pt")


def test_titles_name_the_log_and_counts_get_a_colour_bar(result: RunResult, report: Path) -> None:
    name = Path(result.source).name
    arc = arcmap_figure(result)
    assert arc.title.startswith(f"{name}: arc map")
    assert arc.colourbar is not None and arc.colourbar.label == "arcs through the cell"
    assert arc.colourbar.vmax >= 1
    svg = (report / "arcmap.svg").read_text()
    assert "linearGradient" in svg and "arcs through the cell" in svg
    for fig in (arc, processed_figure(result), fit_figure(result)):
        assert fig.xlabel == "x (m)" and fig.ylabel == "y (m)" and fig.title.startswith(name)


def test_colour_bar_pixels_run_white_to_black(result: RunResult) -> None:
    fig = arcmap_figure(result)
    lay = layout(fig)
    img = decode_png(render(fig)[0])
    assert lay.cbar_box is not None
    x, y, w, h = lay.cbar_box
    column = img[y + 2 : y + h - 2, x + w // 2, 0].astype(int)
    assert column[0] < 10 and column[-1] > 245 and np.all(np.diff(column) >= 0)


def test_layout_follows_the_map_aspect_and_keeps_the_legend_off_the_data(
    result: RunResult,
) -> None:
    fig = fit_figure(result)
    lay = layout(fig)
    left, top, w, h = lay.box
    (x0, x1), (y0, y1) = lay.xlim, lay.ylim
    assert w / h == pytest.approx((x1 - x0) / (y1 - y0), rel=0.02)
    labels = [e.label for _, _, e in lay.legend]
    assert "true surface" in labels and "processed map" in labels
    assert all(y > top + h for _, y, _ in lay.legend)  # below the axes, not over data
    assert lay.width >= left + w and lay.height > top + h
    # ticks lie on the axes, labelled
    assert all(left <= x <= left + w for x, _ in lay.xticks) and len(lay.xticks) >= 3


def test_fit_is_drawn_over_the_whole_truth_span(result: RunResult) -> None:
    assert result.truth is not None
    curve = fit_curve(result.fit, result.truth, result.grid.cell)
    assert curve[0, 0] <= result.truth[:, 0].min() + 1e-9
    assert curve[-1, 0] >= result.truth[:, 0].max() - 1e-9
    fig = fit_figure(result)
    drawn = next(ln for ln in fig.lines if ln.label and "fit" in ln.label)
    np.testing.assert_allclose(drawn.xy, curve)


def test_processed_cells_are_visible_in_fit_png(result: RunResult) -> None:
    img = decode_png(render(fit_figure(result))[0])
    grey = np.all(img == 0x9A, axis=2)
    assert grey.sum() >= result.counts["processed_cells"] // 4


def test_each_surface_is_drawn_in_its_own_colour(result: RunResult) -> None:
    from sonarproc.surfaces import SurfaceFit, SurfaceSet

    x0, x1, y0, y1 = result.grid.extent
    a = np.column_stack((np.linspace(x0, x1, 50), np.full(50, (y0 + y1) / 2)))
    b = np.column_stack((np.full(50, (x0 + x1) / 2), np.linspace(y0, y1, 50)))
    surfaces = SurfaceSet(
        surfaces=[SurfaceFit("line", a, 1.0, 0.0, 10, 10), SurfaceFit("line", b, 1.0, 0.0, 10, 10)],
        failures=[],
        cells_kept=20,
        cells_assigned=20,
    )
    multi = dataclasses.replace(result, surfaces=surfaces)
    fig = fit_figure(multi)
    drawn = [ln for ln in fig.lines if ln.label and ln.label.startswith("surface")]
    assert [ln.colour for ln in drawn] == list(SURFACE_COLOURS[:2])
    img = decode_png(render(fig)[0])
    for colour in SURFACE_COLOURS[:2]:
        assert np.all(img == hex_rgb(colour), axis=2).sum() > 50


def test_every_label_has_its_glyphs(result: RunResult) -> None:
    from sonarproc.report.figure import tick_labels
    from sonarproc.report.glyphs import missing_glyphs

    for fig in (arcmap_figure(result), processed_figure(result), fit_figure(result)):
        lay = layout(fig)
        texts = [fig.title, fig.xlabel, fig.ylabel, *(s for _, s in lay.xticks + lay.yticks)]
        texts += [e.label or "" for _, _, e in lay.legend]
        assert missing_glyphs("".join(texts)) == ""
    assert missing_glyphs("".join(tick_labels([-1.5, -1.0, -0.5]))) == ""


def test_nice_ticks_are_round_and_inside() -> None:
    assert nice_ticks(0.13, 4.87, 6) == [1.0, 2.0, 3.0, 4.0]
    assert nice_ticks(-1.0, 1.0, 5) == [-1.0, -0.5, 0.0, 0.5, 1.0]


def test_run_report_does_not_import_matplotlib(result: RunResult, tmp_path: Path) -> None:
    code = (
        "import sys\n"
        "from sonarlog.csvlog import read_csv_log\n"
        "from sonarproc.params import RunParams\n"
        "from sonarproc.pipeline import process\n"
        "from sonarproc.report import write_report\n"
        f"lg = read_csv_log({str(EXAMPLES / 'example-readings.csv')!r}, "
        f"{str(EXAMPLES / 'example-sensors.yaml')!r})\n"
        f"write_report(process(lg, RunParams(cell=0.05, order=4)), {str(tmp_path)!r})\n"
        "print(sorted(m for m in sys.modules if m.startswith('matplotlib')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    assert (tmp_path / "fit.svg").exists()


def test_compare_figure_is_a_labelled_grid(tmp_path: Path) -> None:
    from sonarproc.methods import make_method
    from sonarproc.methods.compare import compare
    from sonarproc.report.comparison import compare_figure, write_comparison

    lg = read_csv_log(
        EXAMPLES / "example-readings.csv",
        EXAMPLES / "example-sensors.yaml",
        truth=read_truth_csv(EXAMPLES / "example-truth.csv"),
    )
    params = RunParams(cell=0.02, order=6)
    names = ["morphological", "arc-vote", "line-of-sight", "histogram", "occupancy"]
    results = compare(lg, params, [make_method(n) for n in names])
    fig = compare_figure(results, "scan.h5")
    panels = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title().split("\n")[0] for ax in panels] == names
    assert all(ax.get_title().count("cm") == 1 for ax in panels)
    assert all(ax.get_ylabel() in ("", "y (m)") for ax in panels)
    assert any(ax.get_xlabel() == "x (m)" for ax in panels)
    assert len({ax.get_xlim() for ax in panels}) == 1  # one shared scale
    spare = [ax for ax in fig.axes if not ax.axison]
    assert len(spare) <= 1 and all(ax.get_legend() is not None for ax in spare)
    write_comparison("scan.h5", params, results, tmp_path)
    assert png_dpi((tmp_path / "compare.png").read_bytes()) == 150.0
    root = ElementTree.fromstring((tmp_path / "compare.svg").read_bytes())
    assert root.tag == f"{SVG}svg"
