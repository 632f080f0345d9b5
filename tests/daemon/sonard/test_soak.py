"""The soak, short: real emulator and sonard processes, faults, kills, accounting."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonard.soak.accounting import account_firings, slope_per_hour
from sonard.soak.processes import Sample
from sonard.soak.runner import SoakResult, _resources, main, parse_duration
from sonarlog import SENSOR_DTYPE, SonarLog, empty_readings
from sonarlog.schema import EVENT_DTYPE


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_short_soak_passes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    work = tmp_path / "soak"
    # A kill loses at most 1 s on a machine with a core to spare (0.38 s worst in the hour
    # soak); the suite shares 2 cores with two busy loops and other tests, and a starved
    # writer thread flushes late by the scheduler's delay: 1 s more is allowed for it.
    argv = ["45s", "--fault-every", "9", "--kill-trials", "2", "--dir", str(work)]
    rc = main([*argv, "--max-loss", "2.0"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "firings_unaccounted: 0" in out and "soak: PASS" in out
    figures = dict(line.strip().split(": ", 1) for line in out.splitlines() if ": " in line)
    assert int(figures["firings"]) > 500 and int(figures["firings_in_outage"]) > 0
    assert int(figures["gap_events"]) >= 1  # the faults showed up as logged outages


def _log(t: np.ndarray, rx: np.ndarray, events: list[tuple[float, str, str]]) -> SonarLog:
    r = empty_readings(len(t))
    r["t"], r["rx"], r["tx"] = t, rx, rx
    ev = np.zeros(len(events), EVENT_DTYPE)
    for i, (et, kind, detail) in enumerate(events):
        ev[i] = (et, kind.encode(), detail.encode())
    return SonarLog(Path("x.h5"), {}, np.zeros(1, SENSOR_DTYPE), r, events=ev)


def test_accounting_splits_firings_into_logged_outage_and_lost() -> None:
    offset = 1000.0
    fire_t = np.arange(0.0, 2.0, 0.04)  # robot clock
    fire_sonar = np.arange(len(fire_t)) % 5
    keep = np.ones(len(fire_t), dtype=bool)
    keep[10:15] = False  # inside the gap below
    keep[30] = False  # lost silently
    events = [
        (offset, "clock", f"robot clock 0 is UNIX time {offset:.6f}"),
        (offset + 0.40, "gap", f"until {offset + 0.58:.6f}: 0.18 s without a good reply"),
    ]
    log = _log(offset + fire_t[keep], fire_sonar[keep], events)
    acc = account_firings(fire_t, fire_sonar, log, interval=0.04)
    assert (acc.firings, acc.logged, acc.in_outage, acc.unaccounted) == (50, 44, 5, 1)
    assert acc.extra_readings == 0 and acc.examples[0][0] == 0


def test_slope_and_duration_parsing() -> None:
    t = np.linspace(0, 600, 61)
    assert slope_per_hour(t, 50 + t / 3600) == pytest.approx(1.0)
    assert parse_duration("5m") == 300 and parse_duration("1h") == 3600
    with pytest.raises(ValueError, match="DURATION"):
        parse_duration("soon")
    assert main(["soon"]) == 2


def _fd_samples(fds: list[int]) -> list[Sample]:
    return [Sample(float(i), 80_000, n) for i, n in enumerate(fds)]


def test_an_outage_at_the_end_of_warm_up_is_not_a_leak() -> None:
    # 40 samples a second apart: warm-up ends at 20 s, when the link was down (6 fds)
    fds = [12] * 20 + [6] + [12] * 19
    result = SoakResult(40.0)
    _resources(_fd_samples(fds), 40.0, result)
    assert result.failures == [] and result.figures["fds_start"] == 12


def test_descriptors_that_pile_up_are_a_leak() -> None:
    fds = [12] * 20 + [12 + k // 5 for k in range(20)]
    result = SoakResult(40.0)
    _resources(_fd_samples(fds), 40.0, result)
    assert result.failures == ["open fds grew from 12 to 15"]
