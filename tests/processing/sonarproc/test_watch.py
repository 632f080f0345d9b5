"""``sonarproc watch`` against a real SWMR writer in another process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from procs import stop_process

from sonarproc.cli import main
from sonarproc.report import report_files
from sonarproc.simulate import simulate_to_log

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"

# Copies a finished log's readings into a new log in CHUNKS appends over ~DURATION s,
# flushing often, then closes it (or, with HOLD, keeps it open until killed). With a
# REPORT path it waits, after the first chunk and after half of them, until watch has
# published that many updates there: a loaded machine may start watch after a fast
# writer has finished, and the test is about a log that grows while it is watched.
WRITER = textwrap.dedent(
    """
    import json, os, sys, time
    import numpy as np
    from sonarlog import LogWriter, read_log
    src, dst, chunks, duration, hold = sys.argv[1], sys.argv[2], int(sys.argv[3]), \\
        float(sys.argv[4]), sys.argv[5] == "1"
    report = sys.argv[6] if len(sys.argv) > 6 else None

    def wait_for_updates(n, timeout=120.0):
        end = time.monotonic() + timeout
        while report and time.monotonic() < end:
            try:
                with open(report, encoding="utf-8") as f:
                    if json.load(f)["live"]["updates"] >= n:
                        return
            except (OSError, ValueError, KeyError):
                pass
            time.sleep(0.02)

    lg = read_log(src)
    w = LogWriter(dst, lg.sensors, speed_of_sound=lg.speed_of_sound, truth=lg.truth,
                  flush_interval=0.1)
    w.flush()
    print("ready", flush=True)
    for i, part in enumerate(np.array_split(lg.readings, chunks)):
        w.append(part)
        w.flush()
        if i in (0, chunks // 2):
            wait_for_updates(1 if i == 0 else 2)
        time.sleep(duration / chunks)
    if hold:
        print("holding", flush=True)
        time.sleep(3600)
    w.close()
    """
)

WATCH = "import sys; from sonarproc.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.fixture(scope="module")
def source_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("src") / "fig12.h5"
    simulate_to_log(SCENARIOS / "fig12.yaml", path)
    return path


def start_writer(
    src: Path, dst: Path, *, hold: bool = False, report: Path | None = None
) -> subprocess.Popen[str]:
    args = [str(src), str(dst), "12", "2.0", "1" if hold else "0"]
    args += [str(report)] if report is not None else []
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, *args],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    return proc


def start_watch(log: Path, out: Path, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", WATCH, "watch", str(log), "--out", str(out), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def poll_reports(
    out: Path, proc: subprocess.Popen[str], timeout: float
) -> tuple[list[dict], int, list[str]]:
    """Read report.json and report.html as fast as possible while ``proc`` runs.

    Every read must parse: a half-written file would fail ``json.loads`` or lack the
    closing tag. Returns the distinct updates, the number of reads, and the pages seen.
    """
    seen: list[dict] = []
    pages: list[str] = []
    reads = 0
    deadline = time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < deadline:
        path = out / "report.json"
        if path.exists():
            doc = json.loads(path.read_text(encoding="utf-8"))
            page = (out / "report.html").read_text(encoding="utf-8")
            assert page.rstrip().endswith("</html>")
            reads += 1
            if not seen or doc["live"]["updates"] != seen[-1]["live"]["updates"]:
                seen.append(doc)
                pages.append(page)
        time.sleep(0.002)
    return seen, reads, pages


def batch_report(log: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> dict:
    # the metrics are compared with the live ones, not figures: none are drawn
    assert main(["run", str(log), "--paper", "--out", str(out), "--json", "--figures", "none"]) == 0
    return json.loads(capsys.readouterr().out)


def assert_same_result(live: dict, batch: dict) -> None:
    assert live["counts"] == batch["counts"]
    assert live["grid"] == batch["grid"]
    assert live["fit"]["ok"] == batch["fit"]["ok"]
    assert live["fit"]["coefficients"] == pytest.approx(batch["fit"]["coefficients"], rel=1e-9)
    for key in ("e", "f_c", "E1_m", "E2", "N", "N_k"):
        assert live["metrics"][key] == pytest.approx(batch["metrics"][key], rel=1e-9), key


def test_watch_follows_a_live_writer_until_it_closes(
    source_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    live_log, out = tmp_path / "live.h5", tmp_path / "live_report"
    writer = start_writer(source_log, live_log, report=out / "report.json")
    watch = start_watch(live_log, out, "--interval", "0.2", "--idle", "0.6")
    try:
        # generous bounds: an update of this log takes seconds of CPU, and the suite may run
        # beside two busy loops on 2 cores (scripts/test --under-load)
        seen, reads, pages = poll_reports(out, watch, timeout=120)
        assert watch.wait(120) == 0, watch.stderr.read() if watch.stderr else ""
        assert writer.wait(60) == 0
    finally:
        stop_process(watch)
        stop_process(writer)
    final = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert final["live"]["final"] is True and final["live"]["writer_closed"] is True
    # it processed the log while it grew: several updates with rising reading counts
    assert len(seen) >= 3 and reads > 100
    assert 'http-equiv="refresh" content="1"' in pages[0]  # reloads while watching
    used = [d["counts"]["readings_total"] for d in seen]
    assert used == sorted(used) and used[0] < used[-1]
    total = final["counts"]["readings_total"]
    assert final["live"]["readings_seen"] == total == 10787
    html = (out / "report.html").read_text(encoding="utf-8")
    assert 'http-equiv="refresh"' not in html  # the final page stops reloading
    assert not [p for p in out.iterdir() if p.name.startswith(".watch-")]
    assert_same_result(final, batch_report(live_log, tmp_path / "batch", capsys))


def test_watch_stops_on_sigterm_with_a_final_report(
    source_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    live_log, out = tmp_path / "live.h5", tmp_path / "live_report"
    writer = start_writer(source_log, live_log, hold=True)
    watch = start_watch(live_log, out, "--interval", "0.3", "--idle", "0")
    try:
        assert writer.stdout is not None
        assert writer.stdout.readline().strip() == "holding"  # all written, still open
        deadline = time.monotonic() + 120  # generous: a loaded machine (see above)
        while time.monotonic() < deadline:  # wait until watch has seen every reading
            doc_path = out / "report.json"
            if doc_path.exists():
                doc = json.loads(doc_path.read_text(encoding="utf-8"))
                if doc["live"]["readings_seen"] == 10787:
                    break
            time.sleep(0.05)
        assert watch.poll() is None  # the writer holds the log open: watch keeps going
        watch.send_signal(signal.SIGTERM)
        stdout, _ = watch.communicate(timeout=120)
        assert watch.returncode == 0
    finally:
        stop_process(watch)
        stop_process(writer)
    final = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert final["live"]["final"] is True and final["live"]["writer_closed"] is False
    assert "stopped (signal)" in stdout
    assert_same_result(final, batch_report(source_log, tmp_path / "batch", capsys))


def test_watch_once_on_a_finished_log(
    source_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "once"
    code = main(["watch", str(source_log), "--out", str(out), "--once", "--ops", "thinning:6"])
    assert code == 0
    assert "stopped (once) after 1 update(s), 10787 readings" in capsys.readouterr().out
    live = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert sorted(os.listdir(out)) == sorted(report_files())  # the PNGs only, by default
    batch_args = ["--ops", "thinning:6", "--figures", "none"]  # results compared, not figures
    assert main(["run", str(source_log), "--out", str(tmp_path / "b"), *batch_args]) == 0
    capsys.readouterr()
    batch = json.loads((tmp_path / "b" / "report.json").read_text(encoding="utf-8"))
    assert_same_result(live, batch)
    assert (out / "profile.csv").read_text() == (tmp_path / "b" / "profile.csv").read_text()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--interval", "0"], "--interval must be > 0 s"),
        (["--ops", "thinning:9"], "thinning"),
        (["--cell", "-1"], "cell: must be > 0"),
    ],
)
def test_watch_usage_errors(
    source_log: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    message: str,
) -> None:
    assert main(["watch", str(source_log), "--out", str(tmp_path / "o"), "--once", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sonarproc: error: ") and message in err[0]


def test_watch_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["watch", str(tmp_path / "nope.h5"), "--once"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_watch_once_on_a_log_without_readings(
    source_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from sonarlog import LogWriter, read_log

    lg = read_log(source_log)
    empty = tmp_path / "empty.h5"
    with LogWriter(empty, lg.sensors, speed_of_sound=lg.speed_of_sound):
        pass
    assert main(["watch", str(empty), "--out", str(tmp_path / "o"), "--once"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds no readings" in err[0]
    assert not (tmp_path / "o" / "report.json").exists()
