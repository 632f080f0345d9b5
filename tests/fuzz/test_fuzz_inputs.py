"""Every input a user hands us, mutated: the command lines exit 0, 1 or 2 and never crash.

Each test starts from a small valid file (so a run that accepts the mutation stays cheap),
lets hypothesis mutate it, and runs the command line in-process through ``main(argv)``;
:func:`fuzzing.check_outcome` states the contract. The examples are derandomized
(tests/conftest.py) and number ``FUZZ_EXAMPLES`` (300) per input kind.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
import yaml
from fuzzing import (
    FUZZ,
    WEIRD_TOKENS,
    check_outcome,
    mutated_bytes,
    mutated_text,
    mutated_yaml,
    run_main,
    scratch,
)
from hypothesis import given
from hypothesis import strategies as st

from sonard.cli import main as sonard_main
from sonarproc.cli import main as sonarproc_main

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


# ------------------------------------------------------------------------- valid inputs
@cache
def tiny_csv() -> str:
    """The example readings CSV, every tenth row (31 readings of the front sonars)."""
    lines = (CONFIGS / "sensors" / "example-readings.csv").read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("t,")]
    rows = [ln for ln in lines if ln and not ln.startswith(("#", "t,"))]
    return "\n".join(head + rows[::10]) + "\n"


@cache
def tiny_sensors() -> str:
    """The example sensors YAML, only the sonars the tiny CSV uses."""
    doc = yaml.safe_load((CONFIGS / "sensors" / "example-sensors.yaml").read_text())
    doc["sensors"] = [s for s in doc["sensors"] if s["id"] in (0, 1, 2, 14, 15)]
    return yaml.safe_dump(doc, sort_keys=False)


@cache
def tiny_scenario() -> str:
    """A scenario of three sonars at four places in the lab (a fraction of a second)."""
    doc = {
        "name": "tiny",
        "world": str(CONFIGS / "worlds" / "lab.yaml"),
        "array": {
            "type": "explicit",
            "sensors": [
                {"x": 0.0, "y": 0.0, "heading_deg": 80.0, "id": 0},
                {"x": 0.1, "y": 0.0, "heading_deg": 90.0, "id": 1},
                {"x": 0.2, "y": 0.0, "heading_deg": 100.0, "id": 2},
            ],
        },
        "sensor": {"half_beamwidth_deg": 12.5, "min_range": 0.15, "max_range": 10.7},
        "path": {"locations": {"start": [-0.5, 0.0], "end": [0.5, 0.0], "count": 4}},
        "pairs": "own",
        "imperfections": {"range_noise_sigma": 0.004},
        "seed": 3,
    }
    return yaml.safe_dump(doc, sort_keys=False)


@cache
def tiny_log(tmp: Path) -> Path:
    """A sonarlog of the tiny CSV run (written once per session directory)."""
    d = tmp / "valid"
    d.mkdir(exist_ok=True)
    (d / "r.csv").write_text(tiny_csv())
    (d / "s.yaml").write_text(tiny_sensors())
    from sonarlog.csvlog import read_csv_log
    from sonarlog.sources.dispatch import write_sonarlog

    lg = read_csv_log(d / "r.csv", d / "s.yaml")
    write_sonarlog(lg, d / "tiny.h5")
    return d / "tiny.h5"


#: figure formats a run draws: one run in three draws them. Figures cost nine tenths of an
#: accepted run, and the input is parsed, checked and mapped the same way without them, so
#: the other runs test the input at a tenth of the cost; about a hundred runs per input kind
#: still draw whatever the mutation left to draw.
FIGURES = st.sampled_from(["none", "none", "png"])


@pytest.fixture(scope="module")
def valid_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz-valid")


# ------------------------------------------------------------------ readings CSV + sensors
@FUZZ
@given(
    which=st.sampled_from(["csv", "sensors", "both"]),
    figures=FIGURES,
    data=st.data(),
)
def test_readings_csv_and_sensors(which: str, figures: str, data: st.DataObject) -> None:
    csv = data.draw(mutated_text(tiny_csv())) if which != "sensors" else tiny_csv()
    sensors = data.draw(mutated_yaml(tiny_sensors())) if which != "csv" else tiny_sensors()
    with scratch() as d:
        (d / "r.csv").write_text(csv)
        (d / "s.yaml").write_text(sensors)
        out = d / "report"
        argv = ["run", str(d / "r.csv"), "--sensors", str(d / "s.yaml"), "--out", str(out)]
        argv += ["--fit", "poly", "--order", "2", "--figures", figures]
        res = run_main(sonarproc_main, argv)
        check_outcome(res, [out], what=f"run CSV ({which} mutated, figures {figures})")


# ------------------------------------------------------------------------ scenario YAML
@FUZZ
@given(data=st.data())
def test_scenario_yaml(data: st.DataObject) -> None:
    text = data.draw(mutated_yaml(tiny_scenario()))
    with scratch() as d:
        (d / "scenario.yaml").write_text(text)
        out = d / "sim.h5"
        res = run_main(sonarproc_main, ["simulate", str(d / "scenario.yaml"), "--out", str(out)])
        check_outcome(res, [out], what="simulate")


# ------------------------------------------------------------------ world and plan YAML
@FUZZ
@given(kind=st.sampled_from(["plan", "world"]), data=st.data())
def test_plan_and_world_yaml(kind: str, data: st.DataObject, tmp_path: Path) -> None:
    plan = (CONFIGS / "plans" / "translate.yaml").read_text()
    world = (CONFIGS / "worlds" / "lab.yaml").read_text()
    if kind == "plan":
        plan = data.draw(mutated_yaml(plan))
    else:
        world = data.draw(mutated_yaml(world))
    with scratch() as d:
        (d / "plan.yaml").write_text(plan)
        (d / "world.yaml").write_text(world)
        out = d / "run.h5"
        argv = ["--port", str(d / "no-robot"), "--plan", str(d / "plan.yaml")]
        argv += ["--truth", str(d / "world.yaml"), "--out", str(out)]
        res = run_main(sonard_main, argv)
        check_outcome(res, [out], what=f"sonard ({kind} mutated)")
        # a valid plan and world get as far as the missing robot port: exit 1
        assert res.code != 0, res.stderr


# ------------------------------------------------------------------------ sonarlog HDF5
_H5_EDITS = ["drop", "retype", "values", "empty", "attr", "bytes"]
_DATASETS = ["readings", "sensors", "poses", "events"]


def _odd_array(kind: str, n: int, dtype: np.dtype[Any]) -> np.ndarray:
    if kind == "float32":
        return np.zeros(n, np.float32)
    if kind == "2d":
        return np.zeros((n, 3))
    if kind == "strings":
        return np.array([b"abc"] * n)
    names = list(dtype.names or ())
    if kind == "missing-field" and names:
        keep = [(nm, dtype[nm]) for nm in names[1:]]
        return np.zeros(n, np.dtype(keep))
    if kind == "string-field" and names:
        fields = [(nm, "S4" if i == 0 else dtype[nm]) for i, nm in enumerate(names)]
        return np.zeros(n, np.dtype(fields))
    return np.zeros(n, np.int8)


@FUZZ
@given(
    edit=st.sampled_from(_H5_EDITS),
    name=st.sampled_from(_DATASETS),
    data=st.data(),
)
def test_sonarlog_hdf5(edit: str, name: str, data: st.DataObject, valid_dir: Path) -> None:
    source = tiny_log(valid_dir).read_bytes()
    with scratch() as d:
        log = d / "log.h5"
        log.write_bytes(source)
        if edit == "bytes":
            log.write_bytes(data.draw(mutated_bytes(source)))
        else:
            with h5py.File(log, "r+") as f:
                _edit_h5(f, edit, name, data)
        command = data.draw(st.sampled_from(["import"] * 7 + ["run"]))  # a run costs 5 imports
        out = d / ("out.h5" if command == "import" else "report")
        argv = [command, str(log), "--out", str(out)]
        if command == "run":
            argv += ["--fit", "poly", "--order", "2", "--figures", data.draw(FIGURES)]
        res = run_main(sonarproc_main, argv)
        check_outcome(res, [out], what=f"{command} of a log ({edit} {name})")


def _edit_h5(f: h5py.File, edit: str, name: str, data: st.DataObject) -> None:
    if name not in f:
        return
    ds = f[name]
    if edit == "drop":
        del f[name]
    elif edit == "retype":
        kind = data.draw(
            st.sampled_from(["float32", "2d", "strings", "missing-field", "string-field", "int8"])
        )
        arr = _odd_array(kind, data.draw(st.integers(0, 40)), ds.dtype)
        del f[name]
        f.create_dataset(name, data=arr)
    elif edit == "empty":
        dtype = ds.dtype
        del f[name]
        f.create_dataset(name, shape=(0,), dtype=dtype)
    elif edit == "values":
        arr = ds[()]
        fields = list(arr.dtype.names or ())
        if not fields or not len(arr):
            return
        field = data.draw(st.sampled_from(fields))
        if arr.dtype[field].kind not in "fiu":
            return
        value = data.draw(
            st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, -1, 0, 1e9, 255])
        )
        rows = data.draw(st.sampled_from(["one", "all"]))
        with np.errstate(all="ignore"):
            cast = np.array(value).astype(arr.dtype[field])
        if rows == "one":
            arr[field][data.draw(st.integers(0, len(arr) - 1))] = cast
        else:
            arr[field][:] = cast
        del f[name]
        f.create_dataset(name, data=arr)
    elif edit == "attr":
        key = data.draw(st.sampled_from(["speed_of_sound", "format", "format_version", "robot"]))
        value = data.draw(st.sampled_from(["", "abc", -1.0, 0.0, math.nan, math.inf, 1e308, 99]))
        if data.draw(st.booleans()) and key in f.attrs:
            del f.attrs[key]
        else:
            f.attrs[key] = value


# ------------------------------------------------------------------ bag and Player logs
@cache
def _sim() -> Any:
    from bagbuilders import sim_run

    return sim_run(stops=3)


@cache
def valid_player_log(tmp: Path) -> str:
    from bagbuilders import write_player_log

    path = tmp / "valid.log"
    write_player_log(path, _sim())
    return path.read_text()


@cache
def valid_bags(tmp: Path) -> dict[str, bytes]:
    """A ROS 1 bag of Range messages, and one whose sonar topics carry other message types."""
    from bagbuilders import write_cloud_bag, write_range_bag

    out: dict[str, bytes] = {}
    for name, write in (("range", write_range_bag), ("cloud", write_cloud_bag)):
        path = tmp / f"{name}.bag"
        path.unlink(missing_ok=True)
        write(path, "ros1", _sim())
        out[name] = path.read_bytes()
    return out


@FUZZ
@given(data=st.data())
def test_player_log(data: st.DataObject, valid_dir: Path) -> None:
    text = data.draw(mutated_text(valid_player_log(valid_dir)))
    with scratch() as d:
        (d / "run.log").write_text(text)
        out = d / "out.h5"
        res = run_main(sonarproc_main, ["import", str(d / "run.log"), "--out", str(out)])
        check_outcome(res, [out], what="import of a Player log")


@FUZZ
@given(
    which=st.sampled_from(["range", "cloud"]),
    topics=st.sampled_from([None, "/odom", "/sonar", "/tf", "/nope"]),
    data=st.data(),
)
def test_ros1_bag(which: str, topics: str | None, data: st.DataObject, valid_dir: Path) -> None:
    """Truncated and damaged bags, and sonar topics of the wrong message type (a point
    cloud or an odometry topic named as the sonar)."""
    bag = data.draw(mutated_bytes(valid_bags(valid_dir)[which]))
    with scratch() as d:
        (d / "run.bag").write_bytes(bag)
        out = d / "out.h5"
        argv = ["import", str(d / "run.bag"), "--out", str(out)]
        if topics is not None:
            argv += ["--sonar-topic", topics]
        res = run_main(sonarproc_main, argv)
        check_outcome(res, [out], what=f"import of a {which} bag (sonar topic {topics})")


# -------------------------------------------------------------------------- report options
_RUN_OPTIONS: dict[str, list[str]] = {
    "--cell": ["0.01", "0.05", "0", "-1", "1e-9", "1e9"],
    "--bbox": ["-1,1,0,2", "1,-1,0,2", "0,0,0,0", "a,b,c,d", "1,2,3", "-1e308,1e308,0,1"],
    "--ops": ["closing,thinning:3", "vote:auto,ridge", "thinning:-1", "nope", "closing:1e9", ""],
    "--fit": ["poly", "spline", "polar", "auto", "cubic"],
    "--order": ["2", "9", "auto", "0", "-3", "1000"],
    "--smooth": ["0.1", "0", "-1", "1e308"],
    "--centre": ["0,1", "a,b", "0", "1e308,0"],
    "--robust": ["none", "huber", "maybe"],
    "--span": ["truth", "points", "all"],
    "--arc-step": ["1", "0", "-5", "1e-9", "720"],
    "--drop-crosstalk": [],
    "--json": [],
}


#: options that set the figures' extent or raster: a run given one always draws its figures
#: (an unbounded view once allocated without bound while drawing)
_VIEW_OPTIONS = {"--bbox", "--cell"}


@FUZZ
@given(
    options=st.lists(st.sampled_from(sorted(_RUN_OPTIONS)), min_size=1, max_size=4, unique=True),
    figures=FIGURES,
    data=st.data(),
)
def test_report_options(
    options: list[str], figures: str, data: st.DataObject, valid_dir: Path
) -> None:
    if _VIEW_OPTIONS & set(options):
        figures = "png"
    argv = ["run", str(tiny_log(valid_dir)), "--figures", figures]
    for opt in options:
        argv.append(opt)
        if _RUN_OPTIONS[opt]:
            argv.append(
                data.draw(st.sampled_from(_RUN_OPTIONS[opt]) | st.sampled_from(WEIRD_TOKENS))
            )
    if "--fit" not in options:
        argv += ["--fit", "poly", "--order", "2"]  # keep a valid run cheap
    with scratch() as d:
        out = d / "report"
        res = run_main(sonarproc_main, [*argv, "--out", str(out)])
        check_outcome(res, [out], what=" ".join(argv[4:]) + f" (figures {figures})")
