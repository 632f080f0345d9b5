"""``scripts/soak DURATION``: run sonard against a faulty emulator and check what it logged.

Usage::

    scripts/soak DURATION [--fault-every S] [--kill-trials N] [--dir DIR] [--keep]

``DURATION`` is ``90s``, ``5m``, ``1h`` (or plain seconds). One sonard runs a dwell plan for
``DURATION`` on the emulator (:mod:`sonard.soak.emulator`: a fault every ``--fault-every``
seconds, 60 by default, garbled, dropped, stalled and unplugged in turn), its RSS and open
file descriptors sampled meanwhile; it is stopped with SIGTERM. Then ``--kill-trials``
sonards are started one after the other and SIGKILLed at a random moment, with the
fault injection stopped (the loss measured is the crash's, not an outage's); each start
finalises the previous one's log.

Checks (exit 1 when one fails, 2 on bad arguments):

* every firing in the emulator's trace is in the log or inside a logged outage;
* no reading without a firing, and ``t`` never goes back;
* sonard's open file descriptors end where they started (after warm-up), and (runs of
  30 minutes or more) its RSS grows less than 1 MiB per hour;
* every killed log opens with plain ``h5py.File(path, "r")`` after the next start, reads as
  ``crashed``, and lost at most 1 s (``--max-loss``) of readings before its last poll
  (each is killed once it has polled for a random 1-4 s of robot time past that bound, so
  a sonard that never wrote its log fails; its last poll is the last GS the emulator heard
  before the kill, read from the trace once the emulator has exited).

A failure keeps the work directory and prints, for unaccounted firings, what surrounds
them (:mod:`sonard.soak.diagnosis`).

A rich progress display is shown when stdout is a terminal; otherwise only the summary.
The processes themselves are started and sampled by :mod:`sonard.soak.processes`.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import signal
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonard.soak.accounting import (
    account_firings,
    classify_firings,
    clock_offset,
    load_firings,
    slope_per_hour,
)
from sonard.soak.diagnosis import explain_unaccounted
from sonard.soak.emulator import EPISODE_S
from sonard.soak.processes import (
    INTERVAL,
    SONARS,
    Sample,
    SoakProcesses,
    sample_process,
    wait_polled,
    wait_running,
    write_plan,
)

__all__ = ["Sample", "SoakResult", "main", "parse_duration"]

#: RSS and fd samples before this are warm-up (s, or 10 % of the run if longer)
WARMUP_S = 60.0
RSS_LIMIT_MIB_PER_H = 1.0
RSS_CHECK_MIN_S = 1800.0
MAX_LOSS_S = 1.0


def parse_duration(text: str) -> float:
    """Seconds in ``"90"``, ``"90s"``, ``"5m"``, ``"1h"``, ``"1h30m"``.

    Examples
    --------
    >>> parse_duration("1h30m"), parse_duration("45s"), parse_duration("2")
    (5400.0, 45.0, 2.0)
    """
    parts = re.fullmatch(r"(?:(\d+(?:\.\d+)?)h)?(?:(\d+(?:\.\d+)?)m)?(?:(\d+(?:\.\d+)?)s?)?", text)
    if not text or parts is None or not any(parts.groups()):
        raise ValueError(f"DURATION: {text!r} is not a duration (e.g. 90s, 5m, 1h)")
    h, m, s = (float(g) if g else 0.0 for g in parts.groups())
    return h * 3600 + m * 60 + s


@dataclass
class SoakResult:
    """Figures and verdicts of one soak."""

    duration_s: float
    faults: int = 0
    figures: dict[str, Any] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    #: what explains a failure (unaccounted firings and their surroundings)
    diagnosis: list[str] = field(default_factory=list)


def _progress(tty: bool, duration: float) -> Any:
    if not tty:
        return None
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("[bold]soak[/]"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeRemainingColumn(),
        TextColumn("{task.fields[info]}"),
    )
    bar.start()
    bar.add_task("soak", total=duration, info="")
    return bar


def _long_run(procs: SoakProcesses, duration: float, result: SoakResult, tty: bool) -> Path:
    out = procs.work / "logs" / "soak.h5"
    samples: list[Sample] = []
    period = 2.0 if duration < 600 else 10.0
    with open(procs.work / "sonard.err", "w", encoding="utf-8") as err:
        proc = procs.sonard(out, err)
        bar = _progress(tty, duration)
        start = time.monotonic()
        try:
            while (elapsed := time.monotonic() - start) < duration:
                if proc.poll() is not None:
                    result.failures.append(f"sonard exited early with {proc.returncode}")
                    break
                s = sample_process(proc.pid)
                if s is not None:
                    samples.append(s)
                    if bar is not None:
                        info = f"RSS {s.rss_kib / 1024:.1f} MiB, {s.fds} fds"
                        bar.update(0, completed=elapsed, info=info)
                time.sleep(min(period, max(0.0, duration - elapsed)))
        finally:
            if bar is not None:
                bar.stop()
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
            code = proc.wait(30)
    if code != 0:
        result.failures.append(f"sonard exited {code} on SIGTERM (see {procs.work}/sonard.err)")
    _resources(samples, duration, result)
    return out


def _resources(samples: list[Sample], duration: float, result: SoakResult) -> None:
    if len(samples) < 3:
        result.failures.append("too few samples of sonard's RSS and fds")
        return
    t = np.array([s.t for s in samples]) - samples[0].t
    warm = t >= min(max(WARMUP_S, 0.1 * duration), 0.5 * t[-1])
    rss = np.array([s.rss_kib for s in samples], dtype=float) / 1024.0
    fds = np.array([s.fds for s in samples], dtype=float)
    rss_slope = slope_per_hour(t[warm], rss[warm])
    fd_slope = slope_per_hour(t[warm], fds[warm])
    # The serial link's descriptors are closed during an outage, so one sample can be low by
    # a few fds; the level to compare the end with is the highest seen by the end of the
    # warm-up (the link open at least once), and a leak still shows as growth beyond it.
    fds_base = float(fds[: int(np.argmax(warm)) + 1].max())
    result.figures.update(
        rss_start_mib=round(float(rss[warm][0]), 2),
        rss_end_mib=round(float(rss[-1]), 2),
        rss_slope_mib_per_h=round(rss_slope, 3),
        fds_start=int(fds_base),
        fds_end=int(fds[-1]),
        fds_max=int(fds.max()),
        fd_slope_per_h=round(fd_slope, 2),
    )
    if fds[-1] > fds_base + 2:
        result.failures.append(f"open fds grew from {fds_base:.0f} to {fds[-1]:.0f}")
    if duration >= RSS_CHECK_MIN_S and rss_slope >= RSS_LIMIT_MIB_PER_H:
        result.failures.append(f"RSS grows {rss_slope:.2f} MiB/h (limit {RSS_LIMIT_MIB_PER_H})")


def _check_log(procs: SoakProcesses, out: Path, result: SoakResult) -> float:
    """Account the long run's log; return its clock offset (NaN when it has none)."""
    from sonarlog import SonarLogError, read_log

    try:
        log = read_log(out)
    except (OSError, SonarLogError) as exc:
        result.failures.append(f"the soak log cannot be read: {exc}")
        return float("nan")
    fire_t, fire_sonar = load_firings(procs.trace)
    acc = account_firings(fire_t, fire_sonar, log, interval=INTERVAL)
    kinds = [bytes(k).decode() for k in log.events["kind"]] if log.events is not None else []
    result.faults = len(procs.faults.read_text(encoding="utf-8").splitlines())
    result.figures.update(
        readings=len(log.readings),
        firings=acc.firings,
        firings_logged=acc.logged,
        firings_in_outage=acc.in_outage,
        firings_unaccounted=acc.unaccounted,
        extra_readings=acc.extra_readings,
        gap_events=kinds.count("gap"),
        fault_events=kinds.count("fault"),
        reconnects=kinds.count("reconnect"),
        backward_steps=log.backward_steps,
        log_state=log.log_state,
    )
    if acc.unaccounted:
        result.failures.append(f"{acc.unaccounted} firings neither logged nor in an outage")
        classes = classify_firings(fire_t, fire_sonar, log, interval=INTERVAL)
        result.diagnosis += explain_unaccounted(
            classes, log, cycle=len(SONARS) * INTERVAL, trace=procs.trace, faults=procs.faults
        )
    if acc.extra_readings:
        result.failures.append(f"{acc.extra_readings} readings match no firing")
    if log.backward_steps:
        result.failures.append(f"t goes back {log.backward_steps} times")
    if log.log_state != "closed":
        result.failures.append(f"log state {log.log_state} after SIGTERM")
    if acc.firings == 0:
        result.failures.append("no firings in the run")
    try:
        return clock_offset(log)
    except ValueError:
        return float("nan")


def _kill_trials(
    procs: SoakProcesses, n: int, seed: int, result: SoakResult, max_loss_s: float
) -> list[Kill]:
    """Start sonard, SIGKILL it at a random moment, repeat; the next start finalises.

    The moment is 1-4 s of robot time past ``max_loss_s`` after its first poll: a kill any
    sooner could not tell a sonard that never wrote its log from one that lost little.
    """
    rng = np.random.default_rng(seed)
    killed: list[Kill] = []
    with open(procs.work / "kills.err", "w", encoding="utf-8") as err:
        for i in range(n + 1):
            out = procs.work / "logs" / f"kill-{i:03d}.h5"
            start = procs.trace.stat().st_size if procs.trace.exists() else 0
            proc = procs.sonard(out, err)
            try:
                if i == n:  # the last start only finalises the last killed log
                    wait_running(procs.work / "lock", proc)
                    proc.send_signal(signal.SIGTERM)
                    proc.wait(30)
                    break
                after = float(rng.uniform(max_loss_s + 1.0, max_loss_s + 4.0))
                polled = wait_polled(procs.trace, start, after, proc)
                killed_at = time.time()
            finally:  # also when the soak itself is interrupted: no sonard outlives it
                if proc.poll() is None:
                    proc.kill()
                proc.wait(10)
            if polled is None:
                result.failures.append(f"{out.name}: sonard did not poll for long enough")
            else:
                # the file's last write before the next start finalises it: pushes that
                # stopped, or a disk or scheduler that held them back, show against the kill
                written = out.stat().st_mtime if out.exists() else float("nan")
                killed.append(Kill(out, polled[0], killed_at, killed_at - written))
    return killed


@dataclass(frozen=True)
class Kill:
    """One kill trial: its log, its first poll (robot clock, s), the kill (UNIX s), and how
    long before the kill the log file was last written (s)."""

    log: Path
    first_poll: float
    killed_at: float
    written_before: float = float("nan")


def _kill_losses(
    trace: Path, killed: list[Kill], result: SoakResult, max_loss_s: float, offset: float
) -> None:
    """Check every killed log, and how much of what its sonard polled it lost.

    Read once the emulator has exited: its trace is buffered, so only then does it hold
    every poll. A sonard's last poll is the last GS the robot heard before the kill (robot
    clock, through the log's ``clock`` event, or ``offset`` for a log that is gone); the
    loss is from there back to the log's last reading (the time order's hold, the writer's
    flush interval and the host's delays), or to its first poll when it logged nothing.
    """
    import h5py

    from sonarlog import read_log

    polls = np.array(
        [float(json.loads(line)["t"]) for line in _lines(trace) if b'"GS"' in line], dtype=float
    )
    losses: list[float] = []
    details: list[str] = []
    for k in killed:
        if not k.log.exists():  # nothing written: the next start removed the empty log
            losses.append(_last_poll(polls, k, offset) - k.first_poll)
            details.append(f"{k.log.name}: no log, polled {losses[-1]:.2f} s")
            continue
        try:
            with h5py.File(k.log, "r") as f:
                n_rows = f["readings"].shape[0]
        except OSError as exc:
            result.failures.append(f"{k.log.name}: plain h5py cannot open it ({exc})")
            continue
        log = read_log(k.log)
        if log.log_state != "crashed" or n_rows != len(log.readings):
            result.failures.append(f"{k.log.name}: state {log.log_state}, {n_rows} rows")
        if len(log.readings):
            own = clock_offset(log)
            last = _last_poll(polls, k, own)
            losses.append(last - (float(log.readings["t"].max()) - own))
        else:
            last = _last_poll(polls, k, offset)
            losses.append(last - k.first_poll)
        details.append(
            f"{k.log.name}: polled {last - k.first_poll:.2f} s, {len(log.readings)} readings, "
            f"lost {losses[-1]:.2f} s, file last written {k.written_before:.2f} s before the kill"
        )
    worst = max(losses, default=0.0)
    result.figures.update(
        kill_trials=len(killed),
        worst_loss_s=round(worst, 3),
        kill_losses_s=" ".join(f"{x:.3f}" for x in losses[:10]),
    )
    if losses:
        result.figures["worst_kill"] = details[int(np.argmax(losses))]
    if worst > max_loss_s:
        result.failures.append(f"a kill lost {worst:.2f} s of readings (limit {max_loss_s:g} s)")


def _last_poll(polls: np.ndarray, kill: Kill, offset: float) -> float:
    """Robot time of the last poll from ``kill``'s sonard (robot clock 0 at UNIX ``offset``)."""
    mine = polls[(polls >= kill.first_poll) & (polls <= kill.killed_at - offset)]
    return float(mine.max(initial=kill.first_poll))


def _lines(path: Path) -> list[bytes]:
    return path.read_bytes().split(b"\n") if path.exists() else []


def soak(
    duration: float,
    *,
    fault_every: float,
    kill_trials: int,
    work: Path,
    seed: int = 0,
    tty: bool = False,
    max_loss_s: float = MAX_LOSS_S,
) -> SoakResult:
    """Run the soak in ``work``; return its figures and failures.

    ``max_loss_s`` is the most a SIGKILL may lose; a machine busy with other work delays
    the writer's flushes by its scheduling latency, which a caller may allow for.
    """
    result = SoakResult(duration)
    write_plan(work / "plan.yaml", duration)
    procs = SoakProcesses(work, fault_every)
    killed: list[Kill] = []
    try:
        out = _long_run(procs, duration, result, tty)
        if kill_trials:
            procs.emulator.send_signal(signal.SIGUSR1)  # no more faults ...
            time.sleep(EPISODE_S + 1.0)  # ... once the one under way is over
            killed = _kill_trials(procs, kill_trials, seed, result, max_loss_s)
    finally:
        procs.close()
    offset = _check_log(procs, out, result)
    if kill_trials:
        _kill_losses(procs.trace, killed, result, max_loss_s, offset)
    return result


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="soak",
        description="Soak sonard against the emulator with a fault every minute; check the log.",
    )
    p.add_argument("duration", metavar="DURATION", help="how long sonard runs: 90s, 5m, 1h")
    p.add_argument("--fault-every", type=float, default=60.0, metavar="S", help="default 60")
    p.add_argument("--kill-trials", type=int, default=30, metavar="N", help="default 30")
    p.add_argument("--dir", type=Path, help="work directory (default: a new temporary one)")
    p.add_argument("--keep", action="store_true", help="keep the work directory on success")
    p.add_argument("--seed", type=int, default=0, help="kill moments")
    p.add_argument(
        "--max-loss",
        type=float,
        default=MAX_LOSS_S,
        metavar="S",
        help=f"most a kill may lose (default {MAX_LOSS_S:g} s)",
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the soak command line; return the exit code (0 pass, 1 a check failed, 2 usage)."""
    try:
        args = _parser().parse_args(argv)
        duration = parse_duration(args.duration)
    except SystemExit as exc:
        return int(exc.code or 0)
    except ValueError as exc:
        print(f"soak: {exc}", file=sys.stderr)
        return 2
    if args.fault_every <= 0 or args.kill_trials < 0 or not args.max_loss > 0:
        print(
            "soak: --fault-every and --max-loss must be > 0 and --kill-trials >= 0",
            file=sys.stderr,
        )
        return 2
    work = args.dir or Path(tempfile.mkdtemp(prefix="sonard-soak-"))
    work.mkdir(parents=True, exist_ok=True)
    result = soak(
        duration,
        fault_every=args.fault_every,
        kill_trials=args.kill_trials,
        work=work,
        seed=args.seed,
        tty=sys.stdout.isatty(),
        max_loss_s=args.max_loss,
    )
    print(f"soak: {duration:.0f} s, {result.faults} faults injected, work directory {work}")
    for key, value in result.figures.items():
        print(f"  {key}: {value}")
    for failure in result.failures:
        print(f"FAIL: {failure}")
    for line in result.diagnosis:
        print(f"  {line}")
    if result.failures:
        print(f"soak: FAIL (logs, trace and faults kept in {work})")
    else:
        print("soak: PASS")
    if not result.failures and not args.keep and args.dir is None:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if result.failures else 0
