"""``scripts/sweep-slurm.sbatch`` on a real SLURM: a one-node cluster on this machine.

``scripts/slurm-test up`` installs ``slurm-wlm`` and ``munge`` where missing, writes a
one-node ``slurm.conf`` and starts munged, slurmctld and slurmd; the test submits the
sbatch script the way its header says (an array of 4 shards, then the merge job depending
on it), waits for both, and compares the merged table with a local ``sonarproc sweep`` of
the same grid, row for row; and that the ``slurm.conf`` shown in the docs is the one
``up`` wrote. ``scripts/slurm-test down`` stops the daemons whatever
happens. A machine that cannot run SLURM (not root, no apt-get, a daemon that will not
start) skips the test with the reason; with ``SONARMORPH_REQUIRE_SLURM=1`` in the
environment that is a failure instead.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
SLURM_TEST = ROOT / "scripts" / "slurm-test"
SBATCH_SCRIPT = ROOT / "scripts" / "sweep-slurm.sbatch"
DOC = ROOT / "docs" / "live-and-sweeps.md"

#: ``slurm-test``'s exit code for "this machine cannot run SLURM" (the reason on stderr).
CANNOT_RUN = 77
#: A tiny grid: 8 combinations, two per shard; sigma and seed make every shard simulate.
INPUTS = "configs/scenarios/fig12.yaml"
GRID = "sigma=0.01|0.05;seed=0..1;ops=thinning:3|thinning:5"
SHARDS = 4
#: The only column allowed to differ: CPU time of the processing, measured run by run.
IGNORED_COLUMNS = ("t_cpu_s",)
#: Bound on the jobs' wait: 8 small runs and 5 Python start-ups, on a busy machine.
JOBS_TIMEOUT_S = 300.0

# installing the packages (a minute or two on a cold machine) plus the jobs
pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]


def _cannot_run(reason: str) -> None:
    if os.environ.get("SONARMORPH_REQUIRE_SLURM") == "1":
        pytest.fail(f"SONARMORPH_REQUIRE_SLURM=1 but {reason}")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def slurm_conf(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A running one-node cluster: the path of its ``slurm.conf``."""
    cluster = tmp_path_factory.mktemp("slurm")
    try:
        # --owner: if this process dies before the finally, the cluster stops by itself
        up = subprocess.run(
            [str(SLURM_TEST), "up", str(cluster), "--owner", str(os.getpid())],
            capture_output=True,
            text=True,
            timeout=600,
        )
        if up.returncode == CANNOT_RUN:
            lines = up.stderr.strip().splitlines()
            _cannot_run(lines[-1] if lines else "scripts/slurm-test up: exit 77")
        if up.returncode != 0:
            pytest.fail(f"scripts/slurm-test up failed ({up.returncode}):\n{up.stderr}")
        yield cluster / "slurm.conf"
    finally:
        if (cluster / "slurm.conf").exists():
            down = subprocess.run(
                [str(SLURM_TEST), "down", str(cluster)], capture_output=True, text=True, timeout=120
            )
            assert down.returncode == 0, down.stderr


def _job_env(conf: Path, out: Path) -> dict[str, str]:
    """The environment sbatch passes to the jobs: this cluster, this venv, the sweep."""
    # a SLURM_* of an enclosing job (the suite run inside one) must not leak into ours
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "SBATCH_"))}
    env.update(
        SLURM_CONF=str(conf),
        REPO=str(ROOT),
        SONARPROC=_sonarproc(),
        INPUTS=INPUTS,
        GRID=GRID,
        OUT=str(out),
    )
    return env


def _sonarproc() -> str:
    """The ``sonarproc`` of the Python running the tests (the project's venv)."""
    beside = Path(sys.executable).parent / "sonarproc"
    found = str(beside) if beside.exists() else shutil.which("sonarproc")
    assert found, "no sonarproc next to the test interpreter or on PATH"
    return found


def _sbatch(args: list[str], env: dict[str, str], cwd: Path) -> str:
    done = subprocess.run(
        ["sbatch", "--parsable", *args], env=env, cwd=cwd, capture_output=True, text=True
    )
    assert done.returncode == 0, f"sbatch {' '.join(args)}: {done.stderr}"
    return done.stdout.strip().split(";")[0]  # "JOBID[;CLUSTER]"


def _jobs(job_id: str, env: dict[str, str]) -> list[dict[str, str]]:
    """``scontrol show job``: one dict per job (an array job: one per task)."""
    shown = subprocess.run(
        ["scontrol", "show", "job", "-o", job_id], env=env, capture_output=True, text=True
    )
    assert shown.returncode == 0, shown.stderr
    return [
        dict(field.split("=", 1) for field in line.split() if "=" in field)
        for line in shown.stdout.splitlines()
        if line.strip()
    ]


def _wait_for(job_ids: list[str], env: dict[str, str], work: Path) -> None:
    """Poll squeue until none of the jobs is pending or running (bounded)."""
    deadline = time.monotonic() + JOBS_TIMEOUT_S
    while True:
        queued = subprocess.run(
            ["squeue", "-h", "-j", ",".join(job_ids), "-o", "%i %T %r"],
            env=env,
            capture_output=True,
            text=True,
        )
        if queued.returncode == 0 and not queued.stdout.strip():
            return
        if time.monotonic() > deadline:
            outputs = "\n".join(f"--- {p.name}\n{p.read_text()}" for p in work.glob("*.out"))
            pytest.fail(
                f"jobs {job_ids} not finished after {JOBS_TIMEOUT_S:.0f} s:\n"
                f"{queued.stdout}{queued.stderr}\n{outputs}"
            )
        time.sleep(1.0)


def _jsonl(path: Path) -> list[dict[str, Any]]:
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [{k: v for k, v in r.items() if k not in IGNORED_COLUMNS} for r in rows]


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    return [{k: v for k, v in r.items() if k not in IGNORED_COLUMNS} for r in rows]


def _machine_free(conf: str, cluster_dir: str, host: str) -> list[str]:
    """A slurm.conf's lines with its directory, host, ports and node hardware blanked."""
    text = conf.replace(cluster_dir, "DIR")
    text = re.sub(rf"(SlurmctldHost=|NodeName=|Nodes=){re.escape(host)}\b", r"\1HOST", text)
    text = re.sub(r"Port=\d+", "Port=N", text)
    text = re.sub(r"(NodeAddr=127\.0\.0\.1) .* (State=UNKNOWN)", r"\1 HW \2", text)
    return text.strip().splitlines()


def _assert_docs_show(slurm_conf: Path) -> None:
    """The docs' example slurm.conf is the one ``up`` wrote, up to this machine."""
    doc = DOC.read_text()
    first = "# A one-node SLURM cluster on this machine, written by scripts/slurm-test."
    start = doc.index(first)
    shown = doc[start : doc.index("```", start)]
    written = slurm_conf.read_text()
    assert written.startswith(first)
    host = socket.gethostname().split(".")[0]  # what `hostname -s` gives the script
    assert _machine_free(shown, "/tmp/slurm", "mybox") == _machine_free(
        written, str(slurm_conf.parent), host
    )


def test_array_sweep_and_merge_equal_a_local_sweep(slurm_conf: Path, tmp_path: Path) -> None:
    # one test, so that parallel test workers do not start two clusters
    _assert_docs_show(slurm_conf)
    work, out = tmp_path / "submit", tmp_path / "sweep-out"
    work.mkdir()
    env = _job_env(slurm_conf, out)
    # as the script's header says; one CPU and a little memory per task instead of its
    # #SBATCH defaults (4 CPUs, 4 GB), so that four tasks fit a small machine
    small = ["--cpus-per-task=1", "--mem=500M"]
    array = _sbatch([f"--array=0-{SHARDS - 1}", *small, str(SBATCH_SCRIPT)], env, work)
    merge = _sbatch(
        [
            f"--dependency=afterany:{array}",
            *small,
            "--output=sweep-merge-%j.out",
            str(SBATCH_SCRIPT),
            "merge",
        ],
        env,
        work,
    )
    # the local sweep runs while the cluster works
    local = tmp_path / "local"
    swept = subprocess.run(
        [_sonarproc(), "sweep", *INPUTS.split(), "--grid", GRID, "--out", str(local)],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert swept.returncode == 0, swept.stderr
    _wait_for([array, merge], env, work)

    tasks = _jobs(array, env)
    logs = {p.name: p.read_text() for p in work.glob("*.out")}
    assert sorted(int(t["ArrayTaskId"]) for t in tasks) == list(range(SHARDS)), logs
    for t in tasks:
        assert (t["JobName"], t["JobState"], t["ExitCode"]) == (
            "sonarproc-sweep",
            "COMPLETED",
            "0:0",
        ), logs
    (merged_job,) = _jobs(merge, env)
    assert (merged_job["JobState"], merged_job["ExitCode"]) == ("COMPLETED", "0:0"), logs
    assert sorted(logs) == sorted(
        [f"sweep-{array}_{i}.out" for i in range(SHARDS)] + [f"sweep-merge-{merge}.out"]
    )

    # every shard ran its own quarter of the grid
    for i in range(SHARDS):
        manifest = json.loads(
            (out / f"shard-{i}" / f"results.shard-{i}-of-{SHARDS}.json").read_text()
        )
        assert (manifest["shard"], manifest["total"], manifest["rows"]) == ([i, SHARDS], 8, 2)
    best = json.loads((out / "best.json").read_text())
    assert (best["total"], best["rows"], best["missing"], best["duplicates"]) == (8, 8, [], [])

    expected_jsonl = _jsonl(local / "results.jsonl")
    assert len(expected_jsonl) == 8
    assert _jsonl(out / "merged.jsonl") == expected_jsonl
    assert _csv(out / "merged.csv") == _csv(local / "results.csv")
