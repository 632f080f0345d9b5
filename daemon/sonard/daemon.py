"""One acquisition run from start to exit: log, port, signals, plan, stop, close.

Order of events: open the log (attributes carry the plan text, port, baud, software
version), open and configure the robot, tell systemd ``READY=1``, run the plan, and in
every case send ST, tell systemd ``STOPPING=1``, drain the writer thread and close the
log. SIGTERM and SIGINT only set an event; every wait in the loop wakes on it, so the
daemon stops the robot and exits 0 well within two seconds.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from sonard.acquisition import Acquisition, FaultAbort, Stopped
from sonard.motion import MotionError
from sonard.notify import Notifier
from sonard.plan import Plan
from sonard.ring import ring_sensors
from sonard.steps import run_plan
from sonard.writer_thread import LogSink
from sonarlog import LogWriter

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

    Returns
    -------
    RunResult
        ``code`` 0 when the plan completed or a stop was requested, 1 on a runtime failure.
    """
    stop = stop or threading.Event()
    notifier = notifier or Notifier()
    baud = baud or plan.baud
    if baud != plan.baud:
        plan = plan.model_copy(update={"baud": baud})
    old_handlers: dict[int, Any] = {}
    if install_signals:

        def _on_signal(signum: int, frame: FrameType | None) -> None:
            log.info("signal %d: stopping", signum)
            stop.set()

        for sig in (signal.SIGTERM, signal.SIGINT):
            old_handlers[sig] = signal.signal(sig, _on_signal)

    attrs: dict[str, str | int | float | bool] = {
        "plan": plan_text,
        "plan_name": plan.name,
        "port": port,
        "baud": baud,
        "firing_interval": plan.interval,
        "pose_attachments": plan.use_attachments,
        "acquired_by": "sonard",
    }
    writer = LogWriter(
        out,
        ring_sensors(),
        speed_of_sound=plan.speed_of_sound,
        robot="nomad200",
        attrs=attrs,
        flush_interval=FLUSH_INTERVAL_S,
        truth=truth,
    )
    sink = LogSink(writer)
    client = _client(port, baud)
    acq = Acquisition(
        client, plan, sink, stop=stop, notifier=notifier, fault_timeout_s=fault_timeout_s
    )
    code, reason = 0, "plan completed"
    t0 = time.monotonic()
    sink.event("start", f"plan={plan.name} port={port} baud={baud}")
    try:
        _start(acq, stop)
        notifier.ready(f"running plan {plan.name or out.name}")
        log.info("running plan %s on %s at %d baud -> %s", plan.name, port, baud, out)
        run_plan(acq, plan)
    except Stopped:
        reason = "stop requested"
    except FaultAbort as exc:
        code, reason = 1, str(exc)
    except MotionError as exc:
        code, reason = 1, f"motion failed: {exc}"
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
            code, reason = 1, f"log write failed: {exc}"
        for signum, handler in old_handlers.items():
            signal.signal(signum, handler)
        notifier.close()
    log.info(
        "%s: %d readings, %d faults, %.1f s",
        reason,
        sink.n_readings,
        acq.n_faults,
        time.monotonic() - t0,
    )
    return RunResult(code, sink.n_readings, acq.n_faults, reason)


def _start(acq: Acquisition, stop: threading.Event) -> None:
    """Open and configure the robot; a failure here ends the run (systemd restarts it)."""
    acq.start()
    acq.poll()


def _is_nomad_error(exc: BaseException) -> bool:
    from nomad200 import NomadError

    return isinstance(exc, NomadError)
