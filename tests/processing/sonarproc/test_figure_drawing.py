"""Saving several figures at once: the same files whether a share of them (the SVGs, or
every other figure) is drawn in a forked child or here, a failed child costs nothing but
time, and no fork beside another thread."""

from __future__ import annotations

import os
import sys
import threading
import time
from collections import Counter
from xml.etree import ElementTree

import numpy as np
import pytest
from matplotlib.figure import Figure

from sonarproc import forked
from sonarproc.report import drawing, style

needs_fork = pytest.mark.skipif(
    sys.platform != "linux" or len(os.sched_getaffinity(0)) < 2,
    reason="the SVGs are drawn in a child on Linux with two cores only",
)


def figures() -> list[tuple[str, Figure]]:
    out = []
    rng = np.random.default_rng(3)
    for k in range(3):
        fig, ax, _ = style.map_figure((0.0, 4.0, 0.0, 2.0), f"map {k}", legend_entries=1)
        ax.imshow(style.cells_rgba(rng.random((20, 40)) < 0.3, "black"), extent=(0, 4, 0, 2))
        style.legend_below(fig, ax.plot([0.5, 3.5], [0.5, 1.5 - 0.2 * k], label=f"line {k}"))
        out.append((f"f{k}", fig))
    return out


def alone(timeout: float = 60.0) -> None:
    """Wait for threads an earlier test in this worker left ending; skip, naming them, if not.

    A writer or server thread joined with a timeout can outlive its test on a loaded
    machine by seconds; this process may only fork once it is the sole thread.
    """
    deadline = time.monotonic() + timeout
    while threading.active_count() > 1 and time.monotonic() < deadline:
        time.sleep(0.1)
    others = [t.name for t in threading.enumerate() if t is not threading.current_thread()]
    if others:
        pytest.skip(f"threads still running in this test process after {timeout:g} s: {others}")


def tags(svg: bytes) -> Counter[str]:
    return Counter(e.tag for e in ElementTree.fromstring(svg).iter())


def serial(
    monkeypatch: pytest.MonkeyPatch, formats: tuple[str, ...] = ("png", "svg")
) -> dict[str, bytes]:
    with monkeypatch.context() as m:
        m.setattr(drawing, "fork_is_safe", lambda: False)
        return drawing.figures_bytes(figures(), formats)


def share(formats: tuple[str, ...], stems: tuple[str, ...] = ("f0", "f1", "f2")) -> list[str]:
    """The names of the files :func:`drawing._childs_share` gives a child."""
    jobs = [(f"{stem}.{fmt}", None, fmt) for stem in stems for fmt in formats]
    return [name for name, _, _ in drawing._childs_share(jobs, stems, formats)]  # type: ignore[arg-type]


@needs_fork
@pytest.mark.parametrize("formats", [("png", "svg"), ("png",)])
def test_files_from_the_child_are_those_drawn_here(
    formats: tuple[str, ...], monkeypatch: pytest.MonkeyPatch
) -> None:
    alone()
    assert share(formats)
    forked = drawing.figures_bytes(figures(), formats)
    here = serial(monkeypatch, formats)
    assert list(forked) == [f"f{k}.{fmt}" for k in range(3) for fmt in formats]
    assert list(forked) == list(here)
    for name, data in forked.items():
        if name.endswith(".png"):
            assert data == here[name]
        else:  # SVG ids are salted at random: compare the element trees' make-up
            assert tags(data) == tags(here[name]) and len(tags(data)) > 5


@needs_fork
def test_a_failed_child_leaves_its_share_to_this_process(monkeypatch: pytest.MonkeyPatch) -> None:
    alone()
    monkeypatch.setattr(forked, "_child_main", lambda *args: os._exit(3))
    drawn = drawing.figures_bytes(figures(), ("png", "svg"))
    assert sorted(drawn) == ["f0.png", "f0.svg", "f1.png", "f1.svg", "f2.png", "f2.svg"]
    for name in ("f0.svg", "f2.svg"):
        assert tags(drawn[name]) == tags(serial(monkeypatch)[name])


@needs_fork
def test_the_child_draws_the_svgs_or_every_other_figure_but_the_last() -> None:
    alone()
    assert share(("png", "svg")) == ["f0.svg", "f1.svg", "f2.svg"]
    assert share(("png",)) == ["f1.png"]
    assert share(("svg",), ("a", "b", "c", "d")) == ["a.svg", "c.svg"]
    assert share(("png",), ("fit",)) == [] and share(("svg",), ("fit",)) == []


def test_no_fork_for_one_figure_in_one_format_or_beside_another_thread() -> None:
    assert share(("png",), ("fit",)) == [] and share(("svg",), ("fit",)) == []
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert share(("png", "svg")) == [] and share(("png",)) == []
    finally:
        stop.set()
        other.join()
