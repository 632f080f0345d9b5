"""Saving several figures at once: the same files whether the SVGs are drawn in a forked
child or here, a failed child costs nothing but time, and no fork beside another thread."""

from __future__ import annotations

import os
import sys
import threading
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


def tags(svg: bytes) -> Counter[str]:
    return Counter(e.tag for e in ElementTree.fromstring(svg).iter())


def serial(monkeypatch: pytest.MonkeyPatch) -> dict[str, bytes]:
    with monkeypatch.context() as m:
        m.setattr(drawing, "_can_fork", lambda formats: False)
        return drawing.figures_bytes(figures(), ("png", "svg"))


@needs_fork
def test_files_from_the_child_are_those_drawn_here(monkeypatch: pytest.MonkeyPatch) -> None:
    if not drawing._can_fork(("png", "svg")):
        pytest.skip("another thread runs in this test process: no fork")
    forked = drawing.figures_bytes(figures(), ("png", "svg"))
    here = serial(monkeypatch)
    assert list(forked) == ["f0.png", "f0.svg", "f1.png", "f1.svg", "f2.png", "f2.svg"]
    assert list(forked) == list(here)
    for name, data in forked.items():
        if name.endswith(".png"):
            assert data == here[name]
        else:  # SVG ids are salted at random: compare the element trees' make-up
            assert tags(data) == tags(here[name]) and len(tags(data)) > 5


@needs_fork
def test_a_failed_child_leaves_its_share_to_this_process(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(forked, "_child_main", lambda *args: os._exit(3))
    drawn = drawing.figures_bytes(figures(), ("png", "svg"))
    assert sorted(drawn) == ["f0.png", "f0.svg", "f1.png", "f1.svg", "f2.png", "f2.svg"]
    for name in ("f0.svg", "f2.svg"):
        assert tags(drawn[name]) == tags(serial(monkeypatch)[name])


def test_no_fork_for_one_format_or_beside_another_thread() -> None:
    assert not drawing._can_fork(("svg",)) and not drawing._can_fork(("png",))
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        assert not drawing._can_fork(("png", "svg"))
    finally:
        stop.set()
        other.join()
