"""Every user mistake on the command line: exit code 2, one stderr line naming it, no traceback.

One table of bad inputs across ``sonarproc``'s commands (and the emulator's): each row is
the arguments (``{log}``, ``{dir}``, ... are files made by the fixture), the exit code and
words the one error line must contain (the flag or field, the path, what is allowed).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from sonarlog import LogWriter
from sonarlog.csvlog import read_csv_log
from sonarproc.cli import main

CONFIGS = Path(__file__).resolve().parents[3] / "configs"
READINGS = CONFIGS / "sensors" / "example-readings.csv"
SENSORS = CONFIGS / "sensors" / "example-sensors.yaml"
TRUTH = CONFIGS / "sensors" / "example-truth.csv"
SCENARIO = CONFIGS / "scenarios" / "fig02.yaml"


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The files the table's arguments name."""
    d = tmp_path_factory.mktemp("bad")
    lg = read_csv_log(READINGS, SENSORS)
    log = d / "scan.h5"
    with LogWriter(log, lg.sensors, speed_of_sound=lg.speed_of_sound) as w:
        w.append(lg.readings)
    (d / "README.md").write_text("not a directory\n")
    (d / "header-only.csv").write_text("x,y\n")
    (d / "no-y.csv").write_text("x,z\n0,1\n1,2\n")
    (d / "notes.txt").write_text("hello\n")
    (d / "empty").mkdir()
    text = SCENARIO.read_text()
    base = f"world: {CONFIGS / 'worlds'}/"
    text = text.replace("world: ../worlds/", base)
    (d / "typo.yaml").write_text(text.replace("count:", "cuont:", 1))
    (d / "badtype.yaml").write_text(text.replace("count: 20", "count: many", 1))
    (d / "notyaml.yaml").write_text("name: [unclosed\n")
    return {
        "log": str(log),
        "dir": str(d),
        "file": str(d / "README.md"),
        "truth0": str(d / "header-only.csv"),
        "truthxz": str(d / "no-y.csv"),
        "txt": str(d / "notes.txt"),
        "empty": str(d / "empty"),
        "typo": str(d / "typo.yaml"),
        "badtype": str(d / "badtype.yaml"),
        "notyaml": str(d / "notyaml.yaml"),
        "csv": str(READINGS),
        "truth": str(TRUTH),
    }


# (arguments, exit code, words the error line contains)
CASES: list[tuple[str, int, list[str]]] = [
    # the reported ones
    ("run {dir}", 2, ["is a directory", "{dir}"]),
    ("recover {log} --out /nonexistent-dir/x.h5", 2, ["--out", "does not exist"]),
    ("run {log} --out {file}", 2, ["--out", "README.md", "is a file"]),
    ("simulate {typo} --out {dir}/t.h5", 2, ["typo.yaml", "cuont", "unknown field"]),
    ("run {log} --ops=", 2, ["--ops", "empty", "thinning:3"]),
    ("run {log} --truth {truth0}", 2, ["header-only.csv", "at least 2"]),
    ("run {log} --json true", 2, ["true", "take no value"]),
    # more: run's parameters
    ("run {dir}/missing.h5", 2, ["missing.h5", "no such file"]),
    ("run {log} --cell -1", 2, ["--cell", "> 0"]),
    ("run {log} --cell abc", 2, ["--cell", "number"]),
    ("run {log} --bbox 1,2,3", 2, ["--bbox"]),
    ("run {log} --bbox 2,1,0,1", 2, ["--bbox"]),
    ("run {log} --fit cubic", 2, ["--fit", "poly"]),
    ("run {log} --order x", 2, ["--order", "auto"]),
    ("run {log} --order -2", 2, ["--order"]),
    ("run {log} --ops dilate:x", 2, ["--ops"]),
    ("run {log} --ops frobnicate", 2, ["--ops", "frobnicate"]),
    ("run {log} --robust maybe", 2, ["--robust", "huber"]),
    ("run {log} --span all", 2, ["--span", "truth"]),
    ("run {log} --arc-step 0", 2, ["--arc-step"]),
    ("run {log} --centre 1", 2, ["--centre"]),
    ("run {log} --truth {truthxz}", 2, ["no-y.csv", "x and y"]),
    ("run {log} --truth {dir}/none.csv", 2, ["none.csv", "no such file"]),
    ("run {txt}", 2, ["notes.txt"]),
    ("run {csv}", 2, ["--sensors"]),
    ("run {csv} --sensors {dir}/none.yaml", 2, ["none.yaml", "no such sensors file"]),
    ("run {log} --bogus", 2, ["--bogus", "No such option"]),
    ("run", 2, ["Missing argument"]),
    ("frobnicate", 2, ["No such command", "frobnicate"]),
    # compare, export
    ("compare {log} --methods nosuch", 2, ["--methods", "nosuch"]),
    ("compare {log} --set nosuch.x=1", 2, ["--set", "nosuch"]),
    ("compare {log} --out {file}", 2, ["--out", "is a file"]),
    ("compare {log} --order x", 2, ["--order"]),
    ("export {log} --format nope", 2, ["--format", "nope"]),
    ("export {log} --method morphological,histogram", 2, ["--method", "one method"]),
    # sweep, watch
    ("sweep {log} --grid bad", 2, ["--grid"]),
    ("sweep {log} --grid ops=thinning:1 --shard 3/2", 2, ["--shard"]),
    ("sweep {log} --grid ops=thinning:1 --jobs -1", 2, ["--jobs", ">= 0"]),
    ("sweep {log} --grid ops=thinning:1 --out {file}", 2, ["--out", "is a file"]),
    ("sweep-merge {empty}", 2, ["no sweep outputs"]),
    ("watch {log} --interval 0", 2, ["--interval", "> 0"]),
    ("watch {log} --once --out {file}", 2, ["--out", "is a file"]),
    # simulate, import, recover
    ("simulate {dir}/none.yaml --out {dir}/n.h5", 2, ["none.yaml"]),
    ("simulate {badtype} --out {dir}/b.h5", 2, ["count", "integer"]),
    ("simulate {notyaml} --out {dir}/y.h5", 2, ["notyaml.yaml", "YAML"]),
    ("simulate fig02 --out {empty}", 2, ["--out", "is a directory"]),
    ("simulate fig02 --out /nonexistent-dir/f.h5", 2, ["--out", "does not exist"]),
    ("simulate fig02 --out {dir}/s.h5 --seed -1", 2, ["--seed"]),
    ("import {log}", 2, ["--out is required"]),
    ("import {log} --out {empty}", 2, ["--out", "is a directory"]),
    ("recover {dir}/none.h5", 2, ["none.h5", "no such file"]),
    ("recover {log} --out {empty}", 2, ["--out", "is a directory"]),
]


def _args(template: str, files: dict[str, str]) -> list[str]:
    return [part.format(**files) for part in template.split()]


@pytest.mark.parametrize(("template", "code", "words"), CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line(
    template: str,
    code: int,
    words: list[str],
    files: dict[str, str],
    capsys: pytest.CaptureFixture[str],
) -> None:
    rc = main(_args(template, files))
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert rc == code, err
    assert len(lines) == 1, err
    assert "Traceback" not in err and "[Errno" not in err and "None:" not in err
    assert lines[0].startswith("sonarproc"), lines[0]
    assert ": error: " in lines[0]
    for word in words:
        assert word.format(**files) in lines[0], lines[0]


def test_the_table_is_large() -> None:
    assert len(CASES) >= 7 + 20


EMULATOR: list[tuple[list[str], list[str]]] = [
    (["--baud", "1234"], ["--baud", "1234", "9600"]),
    (["--world", "lab", "--link", "/nonexistent-dir/dir/tty"], ["--link", "/nonexistent-dir/dir"]),
    (["--world", "nowhere-world"], ["nowhere-world"]),
]


@pytest.mark.parametrize(("argv", "words"), EMULATOR, ids=[" ".join(a) for a, _ in EMULATOR])
def test_emulator_bad_input_is_one_line(
    argv: list[str], words: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    from nomad200.emulator_cli import main as emulator_main

    run: Callable[[list[str]], int] = emulator_main
    try:
        rc = run(argv)
    except SystemExit as exc:  # argparse refuses a bad value by exiting (code 2)
        rc = int(exc.code or 0)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert rc == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in lines[0], lines[0]
