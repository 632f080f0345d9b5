"""The report's figures: matplotlib Figures with labelled axes, clipped lines, one style.

Assertions are on the returned :class:`matplotlib.figure.Figure` objects (axes, titles,
labels, line data, legend entries, colours) and on the written files (PNG signature, size
and resolution; SVG parsed as XML), never on pixels.
"""

from __future__ import annotations

import dataclasses
import io
import struct
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from matplotlib.figure import Figure

from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarproc.errors import ParameterError
from sonarproc.fit import PolyFit, SplineFit
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, process
from sonarproc.report import write_report
from sonarproc.report.plots import (
    FIGURES,
    arcmap_figure,
    figure_bytes,
    fit_curve,
    fit_figure,
    fit_title,
    map_label,
    parse_figure_formats,
    processed_figure,
    render_figures,
)
from sonarproc.report.style import LINE_STYLES, SURFACE_COLOURS, surface_style
from sonarproc.report.view import clip_polyline, view_box

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"
SVG = "{http://www.w3.org/2000/svg}"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_info(data: bytes) -> tuple[int, int, float | None]:
    """Width, height and dots per inch (from ``pHYs``) of a PNG."""
    assert data[:8] == PNG_SIGNATURE
    pos, dpi, size = 8, None, (0, 0)
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]
        if kind == b"IHDR":
            size = struct.unpack(">II", body[:8])
        elif kind == b"pHYs":
            ppm, _, unit = struct.unpack(">IIB", body)
            dpi = round(ppm * 0.0254) if unit == 1 else None
        pos += 12 + n
    return size[0], size[1], dpi


def map_lines(fig: Figure) -> list:  # type: ignore[type-arg]
    """The lines drawn on the map axes (the first axes)."""
    return list(fig.axes[0].get_lines())


def legend_labels(fig: Figure) -> list[str]:
    return [t.get_text() for leg in fig.legends for t in leg.get_texts()]


def example_log(truth: bool = True):  # type: ignore[no-untyped-def]
    return read_csv_log(
        EXAMPLES / "example-readings.csv",
        EXAMPLES / "example-sensors.yaml",
        truth=read_truth_csv(EXAMPLES / "example-truth.csv") if truth else None,
    )


@pytest.fixture(scope="module")
def result() -> RunResult:
    return process(example_log(), RunParams(cell=0.02, order=6))


@pytest.fixture(scope="module")
def report(result: RunResult, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("figs")
    write_report(result, out, figures=("png", "svg"))
    return out


def test_every_figure_is_a_150_dpi_png_and_an_svg(report: Path) -> None:
    for stem in FIGURES:
        w, h, dpi = png_info((report / f"{stem}.png").read_bytes())
        assert dpi == 150 and 600 <= w <= 1400 and 300 <= h <= 1800
        root = ElementTree.fromstring((report / f"{stem}.svg").read_bytes())
        assert root.tag == f"{SVG}svg" and root.get("width", "").endswith("pt")
        # text is drawn as paths: the SVG shows the font it was laid out with
        assert not list(root.iter(f"{SVG}text"))


def test_figures_are_labelled_maps_titled_with_the_log(result: RunResult) -> None:
    name = Path(result.source).name
    x0, x1, _, _ = result.grid.extent
    arc = arcmap_figure(result)
    assert len(arc.axes) == 2  # the map and its colour bar
    assert arc.axes[0].get_title().startswith(f"{name}: arc map")
    assert arc.axes[1].get_ylabel() == "arcs through the cell"
    for fig in (arc, processed_figure(result), fit_figure(result)):
        ax = fig.axes[0]
        assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
        assert ax.get_title().startswith(f"{name}: ")
        assert ax.get_xlim() == pytest.approx((x0, x1)) and ax.get_aspect() == 1.0
        assert all(line.get_antialiased() for line in ax.get_lines())


def test_fit_is_drawn_over_the_whole_truth_span_within_the_view(result: RunResult) -> None:
    assert result.truth is not None
    curve = fit_curve(result.fit, result.truth, result.grid.cell)
    assert curve[0, 0] <= result.truth[:, 0].min() + 1e-9
    assert curve[-1, 0] >= result.truth[:, 0].max() - 1e-9
    fig = fit_figure(result)
    assert legend_labels(fig) == ["processed map", "true surface", "poly fit"]
    drawn = next(ln for ln in map_lines(fig) if ln.get_label() == "poly fit")
    xy = drawn.get_xydata()
    vx0, vx1, vy0, vy1 = view_box(result.grid.extent)
    ok = np.isfinite(xy).all(axis=1)
    assert ok.sum() > 10
    assert np.all((xy[ok, 0] >= vx0) & (xy[ok, 0] <= vx1) & (xy[ok, 1] >= vy0) & (xy[ok, 1] <= vy1))


def wide_truth_result(order: int = 9) -> RunResult:
    """A polynomial fit drawn over a truth 40 m wide beside a map 1 m wide: it leaves the
    map by many orders of magnitude (the figure that once asked for terabytes)."""
    res = process(example_log(), RunParams(cell=0.02, order=order))
    x = np.linspace(-20.0, 20.0, 400)
    return dataclasses.replace(res, truth=np.column_stack((x, np.full_like(x, 0.5))))


def test_an_extrapolated_fit_is_clipped_before_drawing() -> None:
    res = wide_truth_result()
    curve = fit_curve(res.fit, res.truth, res.grid.cell)
    assert np.nanmax(np.abs(curve[:, 1])) > 1e6  # the fit really does run away
    fig = fit_figure(res)
    box = view_box(res.grid.extent)
    for line in map_lines(fig):
        xy = line.get_xydata()
        ok = np.isfinite(xy).all(axis=1)
        assert xy.shape[0] <= 2 * curve.shape[0] + 2
        assert np.all(xy[ok, 0] >= box[0]) and np.all(xy[ok, 0] <= box[1])
        assert np.all(xy[ok, 1] >= box[2]) and np.all(xy[ok, 1] <= box[3])
    w, h, _ = png_info(figure_bytes(fig, "png"))
    assert w * h < 4_000_000


@given(
    arrays(np.float64, st.tuples(st.integers(0, 40), st.just(2)),
           elements=st.floats(-1e12, 1e12) | st.just(np.nan) | st.just(np.inf)),
)  # fmt: skip
@settings(max_examples=200, deadline=None)
def test_clipped_polylines_stay_in_the_box(xy: np.ndarray) -> None:
    box = (-1.0, 2.0, -0.5, 0.5)
    out = clip_polyline(xy, box)
    ok = np.isfinite(out).all(axis=1)
    assert np.all(np.isnan(out[~ok]))  # breaks are NaN rows, never inf
    assert np.all((out[ok, 0] >= box[0]) & (out[ok, 0] <= box[1]))
    assert np.all((out[ok, 1] >= box[2]) & (out[ok, 1] <= box[3]))
    assert out.shape[0] <= 3 * max(xy.shape[0] - 1, 1)


def test_a_polyline_inside_the_box_is_unchanged() -> None:
    xy = np.column_stack((np.linspace(0, 1, 30), np.sin(np.linspace(0, 3, 30)) * 0.4))
    np.testing.assert_array_equal(clip_polyline(xy, (-1.0, 2.0, -0.5, 0.5)), xy)


def test_twenty_surfaces_get_twenty_colours_then_line_styles_differ() -> None:
    from matplotlib.colors import to_rgb
    from skimage.color import rgb2lab

    assert len(set(SURFACE_COLOURS)) == 20
    lab = rgb2lab(np.array([[to_rgb(c) for c in SURFACE_COLOURS]]))[0]
    gap = np.linalg.norm(lab[:, None] - lab[None], axis=2) + 1e9 * np.eye(20)
    assert gap.min() >= 15.0  # CIELAB distance: told apart at a glance
    styles = [surface_style(k) for k in range(20 * len(LINE_STYLES))]
    assert len(set(styles)) == len(styles)
    assert {s for _, s in styles[:20]} == {"-"} and {s for _, s in styles[20:40]} == {"--"}


def with_surfaces(result: RunResult, n: int, model: str = "line") -> RunResult:
    from sonarproc.surfaces import SurfaceFit, SurfaceSet

    x0, x1, y0, y1 = result.grid.extent
    ys = np.linspace(y0, y1, n + 2)[1:-1]
    fits = [
        SurfaceFit(model, np.column_stack((np.linspace(x0, x1, 20), np.full(20, y))), 1.0,
                   0.0, 10, 10)
        for y in ys
    ]  # fmt: skip
    surfaces = SurfaceSet(surfaces=fits, failures=[], cells_kept=10 * n, cells_assigned=10 * n)
    return dataclasses.replace(result, surfaces=surfaces)


def test_surfaces_are_numbered_from_zero_each_in_its_own_style(result: RunResult) -> None:
    fig = fit_figure(with_surfaces(result, 25))
    labels = legend_labels(fig)
    assert labels[:2] == ["processed map", "true surface"]
    assert labels[2:] == [f"surface {k} (line)" for k in range(25)]
    drawn = [ln for ln in map_lines(fig) if ln.get_label().startswith("surface")]
    looks = [(ln.get_color(), ln.get_linestyle()) for ln in drawn]
    assert len(set(looks)) == 25 and len({c for c, _ in looks[:20]}) == 20
    assert fig.axes[0].get_title().count("25 surfaces") == 1


def test_a_spline_is_called_a_spline(result: RunResult) -> None:
    fit = SplineFit(knots=np.zeros(8), coef=np.zeros(4), degree=3, domain=(0.0, 1.0), lam=None)
    spline = dataclasses.replace(result, fit=fit)
    assert fit_title(spline).startswith("spline fit") and "order" not in fit_title(spline)
    poly = PolyFit(order=4, coef=np.zeros(5), domain=(0.0, 1.0))
    assert fit_title(dataclasses.replace(result, fit=poly)).startswith("poly fit, order 4")


def test_the_processed_title_names_the_map_auto_chose(result: RunResult) -> None:
    auto = {"method": "arc-median", "options": {}}
    assert map_label(result.params.ops) == "thinning:3"
    title = processed_figure(result, auto=auto).axes[0].get_title()
    assert "after arc-median:" in title and "thinning" not in title
    paper = {"method": "morphological", "options": {"ops": "closing,thinning:2"}}
    assert "after closing,thinning:2:" in processed_figure(result, auto=paper).axes[0].get_title()


def test_unicode_labels_render_and_long_titles_wrap(result: RunResult) -> None:
    # warnings are errors in this suite: a glyph missing from the font would fail here
    fig = fit_figure(result)
    fig.axes[0].set_xlabel("x (µm), σ = 2°, −1 ≥ …")
    assert figure_bytes(fig, "png")[:8] == PNG_SIGNATURE
    for name in ("a very long log name " * 12, "no_spaces_at_all_" * 15):
        for fig in (arcmap_figure(dataclasses.replace(result, source=name + ".h5")),
                    fit_figure(dataclasses.replace(result, source=name + ".h5"))):  # fmt: skip
            ax = fig.axes[0]
            assert ax.get_title().count("\n") >= 2
            fig.canvas.draw()
            box = ax.title.get_window_extent(fig.canvas.get_renderer())  # type: ignore[attr-defined]
            assert box.x0 >= 0 and box.x1 <= fig.bbox.width  # never cut at the edges
            assert box.y1 <= fig.bbox.height


def test_figure_formats_are_parsed_with_a_clear_error() -> None:
    assert parse_figure_formats("png,svg") == ("png", "svg")
    assert parse_figure_formats("SVG") == ("svg",)
    assert parse_figure_formats("none") == ()
    for bad in ("", "jpg", "png,none", "pdf,svg"):
        with pytest.raises(ParameterError, match="png,svg, png, svg or none") as err:
            parse_figure_formats(bad)
        assert err.value.parameter == "figures"


def test_render_figures_writes_the_asked_formats(result: RunResult) -> None:
    assert render_figures(result, ()) == {}
    only_svg = render_figures(result, ("svg",))
    assert sorted(only_svg) == ["arcmap.svg", "fit.svg", "processed.svg"]
    for data in only_svg.values():
        ElementTree.fromstring(data)


def test_render_figures_pngs_are_what_savefig_writes(result: RunResult) -> None:
    # the PNGs are encoded on a worker thread from the Agg pixels: the same bytes as a
    # plain savefig of the same figure (same size, resolution, metadata and compression)
    drawn = render_figures(result, ("png", "svg"))
    assert sorted(drawn) == sorted(f"{s}.{f}" for s in FIGURES for f in ("png", "svg"))
    for name, make in [("arcmap.png", arcmap_figure), ("fit.png", fit_figure)]:
        fig = make(result)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=150, metadata={"Software": "sonarmorph"},
                    pil_kwargs={"compress_level": 3})  # fmt: skip
        assert drawn[name] == buf.getvalue() == figure_bytes(fig, "png")
        assert fig.dpi == 150


RUN_WITHOUT_FIGURES = (
    "import sys\n"
    "from sonarlog.csvlog import read_csv_log\n"
    "from sonarproc.params import RunParams\n"
    "from sonarproc.pipeline import process\n"
    "from sonarproc.report import write_report\n"
    "lg = read_csv_log({readings!r}, {sensors!r})\n"
    "write_report(process(lg, RunParams(cell=0.05, order=4)), {out!r}, figures={figures!r})\n"
    "print(sorted(m for m in sys.modules if m.startswith('matplotlib'))[:1])\n"
)


@pytest.mark.parametrize(("figures", "imported"), [((), False), (("png",), True)])
def test_matplotlib_is_imported_only_to_write_figures(
    tmp_path: Path, figures: tuple[str, ...], imported: bool
) -> None:
    code = RUN_WITHOUT_FIGURES.format(
        readings=str(EXAMPLES / "example-readings.csv"),
        sensors=str(EXAMPLES / "example-sensors.yaml"),
        out=str(tmp_path),
        figures=figures,
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert (out.stdout.strip() != "[]") is imported
    assert (tmp_path / "fit.png").exists() is imported
    assert (tmp_path / "report.html").exists()


def test_compare_figure_is_a_labelled_grid(tmp_path: Path) -> None:
    from sonarproc.methods import make_method
    from sonarproc.methods.compare import compare
    from sonarproc.report.comparison import compare_figure, write_comparison

    params = RunParams(cell=0.02, order=6)
    names = ["morphological", "arc-vote", "line-of-sight", "histogram", "occupancy"]
    results = compare(example_log(), params, [make_method(n) for n in names])
    fig = compare_figure(results, "scan.h5")
    panels = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title().split("\n")[0] for ax in panels] == names
    assert all(ax.get_title().count("cm") == 1 for ax in panels)
    assert all(ax.get_ylabel() in ("", "y (m)") for ax in panels)
    assert any(ax.get_xlabel() == "x (m)" for ax in panels)
    assert len({ax.get_xlim() for ax in panels}) == 1  # one shared scale
    spare = [ax for ax in fig.axes if not ax.axison]
    assert len(spare) <= 1 and all(ax.get_legend() is not None for ax in spare)
    box = view_box(results[0].run.grid.extent)
    for ax in panels:
        for line in ax.get_lines():
            xy = line.get_xydata()
            ok = np.isfinite(xy).all(axis=1)
            assert np.all((xy[ok, 0] >= box[0]) & (xy[ok, 0] <= box[1]))
    write_comparison("scan.h5", params, results, tmp_path, figures=("png", "svg"))
    assert png_info((tmp_path / "compare.png").read_bytes())[2] == 150
    root = ElementTree.fromstring((tmp_path / "compare.svg").read_bytes())
    assert root.tag == f"{SVG}svg"
    page = (tmp_path / "compare.html").read_text()
    assert page.count("data:image/png;base64,") == 1
    write_comparison("scan.h5", params, results, tmp_path / "none", figures=())
    assert sorted(p.name for p in (tmp_path / "none").iterdir()) == [
        "compare.csv", "compare.html", "compare.json"
    ]  # fmt: skip
    assert "<img" not in (tmp_path / "none" / "compare.html").read_text()


def test_compare_panels_draw_each_methods_surfaces(result: RunResult) -> None:
    from sonarproc.methods.base import MethodResult
    from sonarproc.report.comparison import FIT_LABEL, compare_figure

    runs = [MethodResult("a", {}, with_surfaces(result, 3)), MethodResult("b", {}, result)]
    fig = compare_figure(runs, "room.h5")
    first, second = (ax for ax in fig.axes if ax.axison)
    assert first.get_title() == "a\n" + first.get_title().split("\n")[1]
    assert "3 surfaces" in first.get_title() and "E1" in second.get_title()
    colours = [ln.get_color() for ln in first.get_lines()[1:]]  # after the truth
    assert colours == list(SURFACE_COLOURS[:3])
    legend = [
        t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()
    ]
    legend += legend_labels(fig)
    assert "surfaces (one colour each)" in legend and FIT_LABEL in legend
