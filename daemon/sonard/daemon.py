"""One acquisition run from start to exit: log, port, signals, plan, stop, close.

Order of events: lock the log file (:mod:`sonard.log_lock`), finalise crashed logs of
earlier runs in its directory (:mod:`sonard.crashed_logs`), lock the robot port
(:mod:`sonard.port_lock`): all before a byte goes to the robot. Then open the log
(attributes carry the plan text, port, baud, temperature, software version), open and
configure the robot, tell systemd ``READY=1``, run the plan, and in every case send ST,
tell systemd ``STOPPING=1``, drain the writer thread and close the log. A run that fails
before its first reading removes its log. SIGTERM and SIGINT only set an event; every
wait in the loop wakes on it, so the daemon stops the robot and exits 0 well within two seconds.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

import numpy as np

from sonard.acquisition import Acquisition, FaultAbort, Resume, Stopped
from sonard.crashed_logs import finalise_crashed_logs
from sonard.log_lock import LogLock
from sonard.motion import MotionError
from sonard.notify import Notifier
from sonard.plan import Plan
from sonard.port_lock import ExclusiveClient, PortLock
from sonard.ring import ring_sensors
from sonard.steps import run_plan
from sonard.writer_thread import LogSink, LogWriteError
from sonarlog import LogWriter
from sonarlog.space import RESERVE_BYTES

if TYPE_CHECKING:
    from sonard.live_view import LiveView

__all__ = ["RunResult", "run"]

log = logging.getLogger(__name__)

#: how often the log writer flushes and fsyncs (s): bounds what SIGKILL or power loss loses
FLUSH_INTERVAL_S = 0.25
#: serial reply timeout (s): short, so a stop request is never stuck behind a dead line
REPLY_TIMEOUT = 0.5


@dataclass(frozen=True)
class RunResult:
    """How a run ended: exit code, readings queued, faults seen, and a one-line reason."""

    code: int
    readings: int
    faults: int
    reason: str


def _client(port: str, baud: int) -> Any:
    from nomad200 import Client

    return Client(port, baud=baud, timeout=REPLY_TIMEOUT, retries=1)


def run(
    port: str,
    plan: Plan,
    out: Path,
    *,
    plan_text: str = "",
    baud: int | None = None,
    fault_timeout_s: float | None = None,
    stop: threading.Event | None = None,
    notifier: Notifier | None = None,
    install_signals: bool = True,
    truth: np.ndarray | None = None,
    live: LiveView | None = None,
) -> RunResult:
    """Run ``plan`` on the robot at ``port`` and log to ``out``.

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    plan : Plan
        Validated plan.
    out : Path
        The sonarlog file to create.
    plan_text : str
        The plan's YAML, stored as a root attribute.
    baud : int, optional
        Overrides the plan's baud rate.
    fault_timeout_s : float, optional
        Overrides the plan's fault timeout.
    stop : threading.Event, optional
        Set it to stop the run (the signal handlers set it).
    notifier : Notifier, optional
        Defaults to one reading ``$NOTIFY_SOCKET``.
    install_signals : bool
        Install SIGTERM/SIGINT handlers (main thread only).
    truth : ndarray, optional
        (N, 2) true surface profile to store (simulated runs).
    live : sonard.live_view.LiveView, optional
        A Foxglove live view shown every reading and pose written to the log.

    Returns
    -------
    RunResult
        ``code`` 0 when the plan completed or a stop was requested, 1 on a runtime failure.

    Raises
    ------
    sonard.log_lock.LockBusy
        Another sonard writes ``out``, or another process holds the port (the message
        names its PID); nothing was sent to the robot.
    sonard.log_lock.LogExists
        ``out`` already holds data.
    sonard.port_lock.PortUnavailable
        The port's device cannot be opened (missing, no permission).
    OSError
        ``out`` cannot be created.
    """
    stop = stop or threading.Event()
    # handlers first: a SIGTERM during start-up (finalising old logs) still unlocks cleanly
    old_handlers = _install_signal_handlers(stop) if install_signals else {}
    try:
        return _run_with_locks(
            port,
            plan,
            out,
            plan_text=plan_text,
            baud=baud,
            fault_timeout_s=fault_timeout_s,
            stop=stop,
            notifier=notifier,
            truth=truth,
            live=live,
        )
    finally:
        for signum, handler in old_handlers.items():
            signal.signal(signum, handler)


def _install_signal_handlers(stop: threading.Event) -> dict[int, Any]:
    def _on_signal(signum: int, frame: FrameType | None) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    return {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGTERM, signal.SIGINT)}


def _run_with_locks(
    port: str,
    plan: Plan,
    out: Path,
    *,
    plan_text: str,
    baud: int | None,
    fault_timeout_s: float | None,
    stop: threading.Event,
    notifier: Notifier | None,
    truth: np.ndarray | None,
    live: LiveView | None = None,
) -> RunResult:
    log_lock = LogLock(out)
    try:
        finalise_crashed_logs(out.parent, skip=out)
        port_lock = PortLock(port)
        port_lock.acquire()
    except BaseException:
        log_lock.release(remove=True)
        raise
    result = None
    try:
        if stop.is_set():
            raise Stopped
        result = _run_locked(
            port,
            plan,
            out,
            ExclusiveClient(_client(port, baud or plan.baud), port_lock),
            plan_text=plan_text,
            baud=baud,
            fault_timeout_s=fault_timeout_s,
            stop=stop,
            notifier=notifier,
            truth=truth,
            live=live,
        )
    except Stopped:
        pass  # stopped during start-up: nothing was written
    finally:
        port_lock.release()
        # a run that failed before its first reading leaves no log to trip the next one
        log_lock.release(remove=result is None or (result.code != 0 and result.readings == 0))
    return result or RunResult(0, 0, 0, "stop requested")


def _run_locked(
    port: str,
    plan: Plan,
    out: Path,
    client: Any,
    *,
    plan_text: str,
    baud: int | None,
    fault_timeout_s: float | None,
    stop: threading.Event,
    notifier: Notifier | None,
    truth: np.ndarray | None,
    live: LiveView | None = None,
) -> RunResult:
    notifier = notifier or Notifier()
    baud = baud or plan.baud
    if baud != plan.baud:
        plan = plan.model_copy(update={"baud": baud})

    attrs: dict[str, str | int | float | bool] = {
        "plan": plan_text,
        "plan_name": plan.name,
        "port": port,
        "baud": baud,
        "firing_interval": plan.interval,
        "pose_attachments": plan.use_attachments,
        "acquired_by": "sonard",
    }
    if plan.temperature_c is not None:
        attrs["temperature_c"] = plan.temperature_c
    writer = LogWriter(
        out,
        ring_sensors(),
        speed_of_sound=plan.speed_of_sound,
        robot="nomad200",
        attrs=attrs,
        flush_interval=FLUSH_INTERVAL_S,
        reserve_bytes=RESERVE_BYTES,  # room to close the log when the disk fills
        truth=truth,
    )
    sink = LogSink(writer if live is None else live.tee(writer))
    acq = Acquisition(
        client, plan, sink, stop=stop, notifier=notifier, fault_timeout_s=fault_timeout_s
    )
    code, reason = 0, "plan completed"
    t0 = time.monotonic()
    sink.event("start", f"plan={plan.name} port={port} baud={baud}")
    try:
        try:
            _start(acq, stop)
        except Exception as exc:
            if not _is_nomad_error(exc):
                raise
            raise _PortFailure(f"cannot reach the robot on {port}: {_os_reason(exc)}") from exc
        notifier.ready(f"running plan {plan.name or out.name}")
        log.info("running plan %s on %s at %d baud -> %s", plan.name, port, baud, out)
        run_plan(acq, plan)
    except Stopped:
        reason = "stop requested"
    except FaultAbort as exc:
        code, reason = 1, str(exc)
    except _PortFailure as exc:
        code, reason = 1, str(exc)
        sink.event("error", reason[:200])
    except MotionError as exc:
        code, reason = 1, f"motion failed: {exc}"
        sink.event("error", reason[:200])
    except LogWriteError as exc:
        code, reason = 1, f"cannot write the log {out}: {exc.reason}"
        sink.event("error", reason[:200])
    except Exception as exc:  # a driver or programming error: still stop the robot
        if not _is_nomad_error(exc):
            log.exception("unexpected error")
        code, reason = 1, f"{type(exc).__name__}: {exc}"
        sink.event("error", reason[:200])
    finally:
        notifier.stopping(reason)
        stopped = acq.stop_robot() if client.is_open else False
        acq.drain()
        sink.event("stop", f"{reason}; robot {'stopped' if stopped else 'not answering'}")
        try:
            client.close()
        except Exception as exc:
            log.debug("close: %s", exc)
        try:
            sink.close()
        except Exception as exc:
            if code == 0:  # otherwise the first failure is the reason (a full disk, say)
                code, reason = 1, f"log write failed: {exc}"
        notifier.close()
    if code == 0 or sink.n_readings:
        log.info(
            "%s: %d readings, %d faults, %.1f s",
            reason,
            sink.n_readings,
            acq.n_faults,
            time.monotonic() - t0,
        )
    return RunResult(code, sink.n_readings, acq.n_faults, reason)


def _start(acq: Acquisition, stop: threading.Event) -> None:
    """Open and configure the robot, then poll it once; a failure here ends the run.

    A link fault in that first poll that sonard recovered from (``Resume``: the robot was
    stopped and configured again) is no failure, and there is no step to resume yet: it
    polls again. A fault it does not recover from raises ``FaultAbort`` (systemd restarts
    the service).
    """
    acq.start()
    while True:
        try:
            acq.poll()
            return
        except Resume:
            log.info("link fault before the plan began; the robot is configured again")


class _PortFailure(RuntimeError):
    """The robot port could not be opened or the robot never answered."""


def _os_reason(exc: BaseException) -> str:
    """The operating system's words for why ``exc`` happened, without nested wrappers."""
    chain: list[BaseException] = []
    seen: BaseException | None = exc
    while seen is not None and seen not in chain:
        chain.append(seen)
        seen = seen.__cause__ or seen.__context__
    codes = [e.errno for e in chain if isinstance(e, OSError) and isinstance(e.errno, int)]
    if codes:
        return os.strerror(codes[-1])
    if isinstance(exc, TimeoutError):
        return "the robot does not answer"
    return str(exc)


def _is_nomad_error(exc: BaseException) -> bool:
    from nomad200 import NomadError

    return isinstance(exc, NomadError)
