"""Tests for sonarproc.report, report_html and plots: the report directory's files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, process
from sonarproc.report import REPORT_FILES, default_out_dir, report_dict, write_report
from sonarproc.report.html import render_html
from sonarproc.report.plots import block_max
from sonarproc.report.run_report import report_files
from sonarproc.report.units import length_cm

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"
PNG = b"\x89PNG\r\n\x1a\n"


def example_result(**kw: object) -> RunResult:
    lg = read_csv_log(
        EXAMPLES / "example-readings.csv",
        EXAMPLES / "example-sensors.yaml",
        truth=read_truth_csv(EXAMPLES / "example-truth.csv"),
    )
    return process(lg, RunParams(**{"cell": 0.02, "order": 6, **kw}))  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def result() -> RunResult:
    return example_result()


def test_report_dict_is_strict_json(result: RunResult) -> None:
    doc = report_dict(result)
    text = json.dumps(doc, allow_nan=False)
    back = json.loads(text)
    assert back["method"].startswith("morphological")
    assert back["parameters"]["order"] == 6 and back["parameters"]["cell"] == 0.02
    assert back["fit"]["kind"] == "poly" and len(back["fit"]["coefficients"]) == 7
    m = back["metrics"]
    assert {"e", "f_c", "t_cpu_s", "E1_m", "E2"} <= set(m)
    assert m["E1_m"] == pytest.approx(result.metrics.E1_m)
    c = back["counts"]
    assert c["readings_used"] + c["skipped_out_of_range"] == c["readings_total"] == 305


def test_no_truth_omits_E1_E2(result: RunResult) -> None:
    lg = read_csv_log(EXAMPLES / "example-readings.csv", EXAMPLES / "example-sensors.yaml")
    doc = report_dict(process(lg, RunParams(cell=0.02, order=6)))
    assert "E1_m" not in doc["metrics"] and doc["metrics"]["e"] is None
    assert 0 < doc["metrics"]["f_c"] <= 1
    assert doc["truth"] is False


def test_write_report_files(tmp_path: Path, result: RunResult) -> None:
    doc = write_report(result, tmp_path / "out")
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == sorted(report_files())
    assert report_files() == tuple(n for n in REPORT_FILES if not n.endswith(".svg"))
    assert json.loads((out / "report.json").read_text()) == json.loads(json.dumps(doc))
    for name in ("arcmap.png", "processed.png", "fit.png"):
        assert (out / name).read_bytes()[:8] == PNG
    lines = (out / "profile.csv").read_text().splitlines()
    assert lines[0] == "x,y"
    xy = np.loadtxt(out / "profile.csv", delimiter=",", skiprows=1)
    assert np.all(np.diff(xy[:, 0]) > 0)
    np.testing.assert_allclose(np.diff(xy[:, 0]), 0.02, atol=1e-6)
    assert xy[0, 0] == pytest.approx(doc["fit"]["domain"][0], abs=1e-6)
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 3
    assert length_cm(doc["metrics"]["E1_m"]) in html and "E1 (Eq. 3)" in html
    assert "<script" not in html and "http" not in html.split("<body>")[1]


def test_failed_fit_is_shown_not_drawn(tmp_path: Path) -> None:
    res = example_result(ops="erosion,erosion,erosion,erosion,erosion,erosion")
    doc = write_report(res, tmp_path)
    assert doc["fit"]["ok"] is False and "points" in doc["fit"]["reason"]
    assert (tmp_path / "profile.csv").read_text() == "x,y\n"
    assert "Fit failed" in (tmp_path / "report.html").read_text()
    assert doc["metrics"]["E1_m"] is None


def test_polar_profile_is_closed(tmp_path: Path) -> None:
    res = example_result(fit="polar", order=3, centre=(0.0, 0.0))
    write_report(res, tmp_path)
    xy = np.loadtxt(tmp_path / "profile.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(xy[0], xy[-1])


def test_render_html_escapes() -> None:
    doc = {
        "source": "<x>.h5",
        "method": "m & n",
        "software": {"sonarmorph": "0"},
        "metrics": {"e": None},
        "fit": {"kind": "poly", "ok": False, "reason": "<bad>"},
        "parameters": {},
        "counts": {},
        "grid": {},
        "timings_s": {},
    }
    html = render_html(doc, {"fit.png": PNG})
    assert "&lt;x&gt;.h5" in html and "&lt;bad&gt;" in html and "m &amp; n" in html


def test_block_max_keeps_every_set_cell() -> None:
    rng = np.random.default_rng(2)
    a = rng.random((2501, 1203)) > 0.9999
    b = block_max(a, limit=1000)
    assert max(b.shape) <= 1000 and b.sum() <= a.sum() and b.any() == a.any()
    assert block_max(a[:10, :10]) is not None


@pytest.mark.parametrize("shape", [(2001, 2001), (2501, 1203), (7, 1000), (1000, 1000)])
@pytest.mark.parametrize("dtype", [np.uint32, np.uint16, np.bool_])
def test_block_max_is_the_maximum_of_each_block(shape: tuple[int, int], dtype: type) -> None:
    rng = np.random.default_rng(shape[0] + shape[1])
    a = (rng.random(shape) > 0.97).astype(dtype) * (1 if dtype is np.bool_ else 7)
    a = a.astype(dtype)
    f = int(np.ceil(max(shape) / 300))
    padded = np.pad(a, ((0, (-shape[0]) % f), (0, (-shape[1]) % f)))
    want = padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f).max(axis=(1, 3))
    got = block_max(a, limit=300)
    assert got.dtype == a.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)


def test_default_out_dir() -> None:
    assert default_out_dir("/data/scan.h5") == Path("/data/scan_report")
