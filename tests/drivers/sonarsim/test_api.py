"""The minimum API the emulator codes against."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonarsim import World, echoes, first_echo_path, load_world

ROOT = Path(__file__).resolve().parents[3]


def test_lab_world_loads_with_start_pose() -> None:
    world = load_world(ROOT / "configs/worlds/lab.yaml")
    assert isinstance(world, World)
    x, y, theta = world.start_pose
    assert (x, y, theta) == (-0.75, 0.0, 0.0)
    assert world.start_turret is not None
    assert np.isclose(world.start_turret, np.pi / 2)


def test_first_echo_path_single_firing_in_lab() -> None:
    world = load_world(ROOT / "configs/worlds/lab.yaml")
    # Sonar pointing straight at the left wall (x = -3) from x = -1: range 2 m.
    p = first_echo_path(world, [-1.0, 0.0], np.pi, [-1.0, 0.0], np.pi)
    assert p.shape == (1,)
    np.testing.assert_allclose(p, [4.0], atol=1e-9)


def test_first_echo_path_hits_the_cardboard() -> None:
    world = load_world(ROOT / "configs/worlds/lab.yaml")
    # Near x = 0 the curve's slope is small, so a sonar looking up sees it near-normally.
    p = first_echo_path(world, [[0.0, 0.0]], [np.pi / 2], [[0.0, 0.0]], [np.pi / 2])
    assert np.isfinite(p[0])
    assert 2 * 1.29 < p[0] < 2 * 1.31


def test_echoes_time_order_and_fields() -> None:
    world = load_world(ROOT / "configs/worlds/lab.yaml")
    ang = np.deg2rad(90 + 22.5 * np.arange(16))
    xy = np.c_[0.22 * np.cos(ang), 0.22 * np.sin(ang)]
    ev = echoes(world, xy, ang, xy, ang, max_order=2)
    assert len(ev) > 0
    assert np.all(np.diff(ev.firing) >= 0)
    same = np.diff(ev.firing) == 0
    assert np.all(np.diff(ev.path)[same] > 0)
    assert set(np.unique(ev.order)).issubset({1, 2})
    first = first_echo_path(world, xy, ang, xy, ang, max_order=2)
    got = np.full(16, np.nan)
    f = ev.first()
    got[f.firing] = f.path
    np.testing.assert_array_equal(got, first)


def test_beam_model_alone_does_not_load_the_simulator() -> None:
    # sonarproc's surfaces import the beam model (sonarsim.transducer) on every run: the
    # package's names load on first use, so that import loads no world, scenario or YAML
    import subprocess
    import sys

    code = (
        "import sys, sonarsim.transducer; "
        "print(sorted(m for m in sys.modules if m.startswith(('sonarsim', 'yaml'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['sonarsim', 'sonarsim.geometry', 'sonarsim.transducer']"
    import sonarsim

    assert sonarsim.World is World and "simulate" in dir(sonarsim)


def test_every_exported_name_loads_from_the_module_the_table_names() -> None:
    # the lazy package lists its names three times (type-checking imports, the loader's
    # table, __all__): the table and __all__ must agree, and each name must resolve
    import importlib

    import sonarsim

    table = sonarsim._EXPORTS  # type: ignore[attr-defined]
    assert sorted(table) == sorted(sonarsim.__all__)
    for name, module in table.items():
        assert getattr(sonarsim, name) is getattr(importlib.import_module(module), name)
