"""Mutations of valid input files, and the contract every command line keeps on them.

The fuzz tests (``tests/fuzz``) start from a valid file of each kind a user hands us, let
hypothesis mutate it (text edits, YAML structure edits, HDF5 dataset and attribute edits,
byte damage), run a command line on it in-process through its ``main(argv)``, and check
the contract of :func:`check_outcome`: exit code 0, 1 or 2, no traceback, at most two lines
on stderr on error, no partial output file, and a bounded run time.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import io
import logging
import os
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import typer.main
import yaml
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

#: examples per input kind: 300 under the CI profile (``HYPOTHESIS_PROFILE=ci``, fixed and
#: derandomized like every profile of tests/conftest.py), 100 otherwise; FUZZ_EXAMPLES wins
FUZZ_EXAMPLES = int(
    os.environ.get(
        "FUZZ_EXAMPLES", "300" if os.environ.get("HYPOTHESIS_PROFILE") == "ci" else "100"
    )
)

FUZZ = settings(
    max_examples=FUZZ_EXAMPLES,
    deadline=None,  # time is bounded by check_outcome, generously (a loaded machine)
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.function_scoped_fixture,
        HealthCheck.filter_too_much,
    ],
)

#: a run on these tiny inputs takes well under a second of CPU; 30 s means it loops without
#: end. CPU time, not wall time: beside two busy loops and other tests on 2 cores a run gets
#: a small share of a core and its wall time stretches by the machine's load, not its own
#: work (a run that waits for ever spends no CPU: the test's timeout catches it)
MAX_SECONDS = 30.0

#: tokens a user's file may hold where a number or name was expected
WEIRD_TOKENS = [
    "",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "-1",
    "65536",
    "2147483648",
    "9" * 40,
    "abc",
    "null",
    "true",
    "[]",
    "{}",
    "\x00",
    "é",
    ",",
    ":",
    "- ",
    "'",
    '"',
    "#",
    "0x10",
    "1,2",
]

#: values a YAML field may hold instead of the expected one
WEIRD_VALUES: list[Any] = [
    None,
    "",
    "abc",
    -1,
    0,
    1,
    2**63,
    1e308,
    -1e308,
    float("nan"),
    float("inf"),
    True,
    [],
    {},
    [1, 2],
    {"a": 1},
    "x" * 300,
    [[0.0, 0.0]],
]


# ----------------------------------------------------------------------------- text edits
_TOKEN = re.compile(r"[^\s,:\[\]{}]+")


@st.composite
def mutated_text(draw: st.DrawFn, text: str, max_edits: int = 4) -> str:
    """``text`` after 1 to ``max_edits`` edits: tokens replaced, lines dropped, duplicated,
    swapped, the file cut short, or odd characters inserted."""
    for _ in range(draw(st.integers(1, max_edits))):
        lines = text.splitlines(keepends=True)
        op = draw(
            st.sampled_from(["token", "token", "token", "drop", "dup", "swap", "cut", "insert"])
        )
        if op == "token":
            spans = [m.span() for m in _TOKEN.finditer(text)]
            if spans:
                a, b = spans[draw(st.integers(0, len(spans) - 1))]
                new = draw(st.sampled_from(WEIRD_TOKENS) | st.text(max_size=8))
                text = text[:a] + new + text[b:]
        elif op in ("drop", "dup", "swap") and lines:
            i = draw(st.integers(0, len(lines) - 1))
            if op == "drop":
                del lines[i]
            elif op == "dup":
                lines.insert(i, lines[i])
            else:
                j = draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            text = "".join(lines)
        elif op == "cut":
            text = text[: draw(st.integers(0, len(text)))]
        else:
            at = draw(st.integers(0, len(text)))
            text = text[:at] + draw(st.text(max_size=12)) + text[at:]
    return text


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


def _get(node: Any, path: Sequence[Any]) -> Any:
    for k in path:
        node = node[k]
    return node


def _weird(draw: st.DrawFn) -> Any:
    """An odd value, copied: edits later in the same document (``listify``, ``add``) change
    it in place, and the shared list must stay the same for every test case (hypothesis
    replays a case's draws and refuses strategies that depend on changed state)."""
    return copy.deepcopy(draw(st.sampled_from(WEIRD_VALUES)))


@st.composite
def mutated_yaml(draw: st.DrawFn, text: str, max_edits: int = 3) -> str:
    """A YAML document after structure edits (a value replaced by an odd one, a key dropped
    or added, a mapping turned into a list) or, one time in four, text edits."""
    if draw(st.integers(0, 3)) == 0:
        return draw(mutated_text(text))
    doc = yaml.safe_load(text)
    for _ in range(draw(st.integers(1, max_edits))):
        paths = list(_paths(doc))
        path = paths[draw(st.integers(0, len(paths) - 1))]
        op = draw(st.sampled_from(["value", "value", "drop", "add", "listify"]))
        if not path:
            if op == "value":
                doc = _weird(draw)
            continue
        parent, key = _get(doc, path[:-1]), path[-1]
        if op == "value":
            parent[key] = _weird(draw)
        elif op == "drop":
            del parent[key]
        elif op == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["extra", "x", "id", "type", ""]))] = _weird(draw)
        elif op == "listify":
            parent[key] = [parent[key]]
    return yaml.safe_dump(doc, allow_unicode=True, sort_keys=False)


@st.composite
def mutated_bytes(draw: st.DrawFn, data: bytes, max_edits: int = 3) -> bytes:
    """``data`` cut short, with bytes flipped, or with a run of bytes zeroed."""
    buf = bytearray(data)
    for _ in range(draw(st.integers(1, max_edits))):
        op = draw(st.sampled_from(["cut", "flip", "zero"]))
        if not buf:
            break
        at = draw(st.integers(0, len(buf) - 1))
        if op == "cut":
            del buf[at:]
        elif op == "flip":
            buf[at] ^= draw(st.integers(1, 255))
        else:
            del_len = draw(st.integers(1, 64))
            buf[at : at + del_len] = bytes(len(buf[at : at + del_len]))
    return bytes(buf)


# ------------------------------------------------------------------------- running a CLI
@dataclass(frozen=True)
class Outcome:
    """What one in-process command line run did."""

    code: Any
    stdout: str
    stderr: str
    #: CPU time of the run (this process, every thread), s
    seconds: float


@functools.cache
def _cached_command(app: Any) -> Any:
    return _build_command(app)


_build_command = typer.main.get_command


@contextlib.contextmanager
def _typer_built_once() -> Iterator[None]:
    """Build each typer app's click command once (it costs more than a small run)."""
    typer.main.get_command = _cached_command  # type: ignore[assignment]
    try:
        yield
    finally:
        typer.main.get_command = _build_command


def run_main(main: Callable[[list[str]], Any], argv: list[str]) -> Outcome:
    """Run ``main(argv)`` with stdout and stderr captured; restore logging afterwards."""
    out, err = io.StringIO(), io.StringIO()
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    t0 = time.process_time()
    try:
        with (
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
            _typer_built_once(),
        ):
            code = main(argv)
    finally:
        root.handlers[:] = handlers
        root.setLevel(level)
    return Outcome(code, out.getvalue(), err.getvalue(), time.process_time() - t0)


def check_outcome(res: Outcome, outputs: Sequence[Path], *, what: str) -> None:
    """The contract: exit 0/1/2 in bounded time, no traceback, two error lines at most, and
    no output left behind by a failed run."""
    assert res.code in (0, 1, 2), f"{what}: exit code {res.code!r}\n{res.stderr}"
    assert res.seconds < MAX_SECONDS, f"{what}: took {res.seconds:.1f} s of CPU"
    for stream in (res.stdout, res.stderr):
        assert "Traceback" not in stream, f"{what}: traceback\n{stream}"
    if res.code != 0:
        lines = [line for line in res.stderr.splitlines() if line.strip()]
        assert 1 <= len(lines) <= 2, f"{what}: exit {res.code} with stderr\n{res.stderr}"
        for out in outputs:
            left = out.exists() and (not out.is_dir() or any(out.iterdir()))
            assert not left, f"{what}: exit {res.code} left {out}\n{res.stderr}"


@contextlib.contextmanager
def scratch() -> Iterator[Path]:
    """A fresh directory per example (on a RAM disk when there is one: fsyncs are cheap)."""
    base = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
    d = Path(tempfile.mkdtemp(prefix="fuzz-", dir=base))
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)
