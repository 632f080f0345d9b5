"""Public real sonar logs the repository may not ship, evaluated from a path the user gives.

A log whose repository grants no licence may not be copied into ``tests/data``; its
source, exact file (SHA-256) and robot are recorded here instead, so that anyone who
fetches it can evaluate it the same way the shipped logs are (``sonarproc run`` with
default options, the figures of ``tools/real_logs/evaluate.py``)::

    python tools/real_logs/unshipped.py --list
    python tools/real_logs/unshipped.py NAME PATH [--work DIR]

The file must be the recorded one (same SHA-256). Figures go into docs/real-logs.md only
for a log whose terms allow it (:attr:`PublicLog.publish`); for the others the table and
the figure are written to the work folder and the table printed, and nothing else.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from dataclasses import dataclass
from pathlib import Path

#: Bytes read at a time while hashing a log.
_CHUNK = 1 << 20


@dataclass(frozen=True)
class PublicLog:
    """A public recording, where it is and what it holds.

    Attributes
    ----------
    name : str
        Short name (the column of the page, the name on the command line).
    repository : str
        The repository's address.
    commit : str
        The commit holding the file (40 hex digits).
    file : str
        The file's path in the repository.
    sha256 : str
        SHA-256 of the file (64 hex digits): the evaluation refuses any other file.
    size : int
        The file's size (bytes).
    robot : str
        The ``sonarproc`` mount preset of the recording's sonars.
    licence : str
        What the repository grants.
    publish : bool
        Whether its figures may be written into docs/real-logs.md.
    recording : str
        What was recorded, as the file shows it.
    mounts : str
        Why ``robot`` fits the recording.
    """

    name: str
    repository: str
    commit: str
    file: str
    sha256: str
    size: int
    robot: str
    licence: str
    publish: bool
    recording: str
    mounts: str

    @property
    def url(self) -> str:
        """The file at its commit."""
        return f"{self.repository}/blob/{self.commit}/{self.file}"

    @property
    def source(self) -> str:
        """The one-line source shown with the log's figures."""
        return f"{self.url} ({self.licence})"


PUBLIC_LOGS: tuple[PublicLog, ...] = (
    PublicLog(
        name="ufrgs-corridor",
        repository="https://github.com/fupbot/ROSActiveExplorationCMP545",
        commit="b16cbe4b9412538f7bac8787a4acb3884d3f2cbe",
        file="short_corredor_fast_250822.bag",
        sha256="81ced47aaf6eaeeafe8402226ff9e51c47b79cb69a3831b8b979c556a6c6133a",
        size=2_671_063,
        robot="pioneer3-dx",
        licence="no licence: not shippable, figures not published",
        publish=False,
        recording=(
            "ROS 1 bag of a Pioneer 3-DX run by RosAria (its rosaria_phi fork) along a "
            "corridor with a turn, 2022-08-25: 66 s, /RosAria/sonar (PointCloud, 663 "
            "clouds of 16 points: the front ring's 8 and the absent rear ring's 8 at the "
            "robot's centre) and /RosAria/pose (Odometry, 10 Hz); 1395 readings after the "
            "stale repeats are dropped, about 29 m of travel"
        ),
        mounts=(
            "the cloud's side points lie at x = 0.069 m, the x of ARIA's p3dx.p side "
            "sonars (SonarUnit 0 and 7), so the cloud frame is the robot base and the "
            "points follow ARIA's sonar order, as the pioneer3-dx preset assumes"
        ),
    ),
)


def find(name: str) -> PublicLog | None:
    """The recorded log called ``name``, if any.

    >>> find("ufrgs-corridor").robot
    'pioneer3-dx'
    >>> find("nowhere") is None
    True
    """
    return next((lg for lg in PUBLIC_LOGS if lg.name == name), None)


def sha256_of(path: Path) -> str:
    """SHA-256 of a file, hex."""
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        while block := fh.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def check_file(log: PublicLog, path: Path) -> str | None:
    """Why ``path`` is not the recorded file of ``log`` (None when it is)."""
    if not path.is_file():
        return f"{path}: no such file"
    if path.stat().st_size != log.size or sha256_of(path) != log.sha256:
        return (f"{path}: not the recorded {log.file} (SHA-256 {log.sha256[:12]}..., "
                f"{log.size} bytes); fetch it from {log.url}")  # fmt: skip
    return None


def listing() -> list[str]:
    """One paragraph per recorded log (``--list``)."""
    out = []
    for lg in PUBLIC_LOGS:
        out += [f"{lg.name}: {lg.url}", f"  licence: {lg.licence}", f"  robot: {lg.robot}",
                f"  sha256: {lg.sha256}", f"  {lg.recording}", ""]  # fmt: skip
    return out


def evaluate_one(log: PublicLog, path: Path, work: Path) -> list[str]:
    """Run and measure one log as evaluate.py does; the table and figure go to ``work``."""
    import evaluate as ev

    real = ev.RealLog(log.name, path, None, log.robot, log.source)
    out = work / log.name
    outcome = ev.run_log(real, out)
    ev.measure(outcome, out)
    ev.draw(outcome, work / f"{log.name}.png")
    lines = ev.table([outcome])
    (work / f"{log.name}.md").write_text("\n".join(lines) + "\n")
    return lines


def main(argv: list[str] | None = None) -> int:
    """List the recorded logs, or evaluate one from a path."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("name", nargs="?", help="a recorded log (see --list)")
    ap.add_argument("path", nargs="?", type=Path, help="the log's file, fetched by the user")
    ap.add_argument("--list", action="store_true", help="list the recorded logs and exit")
    ap.add_argument("--work", type=Path, default=Path("real-logs-work"),
                    help="folder for the run, the table and the figure "
                         "(default: ./real-logs-work)")  # fmt: skip
    args = ap.parse_args(argv)
    if args.list:
        print("\n".join(listing()).rstrip())
        return 0
    if args.name is None or args.path is None:
        print("unshipped: error: give NAME PATH, or --list", file=sys.stderr)
        return 2
    log = find(args.name)
    if log is None:
        names = ", ".join(lg.name for lg in PUBLIC_LOGS)
        print(f"unshipped: error: NAME {args.name!r}: not a recorded log (one of: {names})",
              file=sys.stderr)  # fmt: skip
        return 2
    why = check_file(log, args.path)
    if why is not None:
        print(f"unshipped: error: {why}", file=sys.stderr)
        return 2
    if log.publish:
        import evaluate as ev

        return ev.main(["--log", str(args.path), "--robot", log.robot, "--source", log.source,
                        "--work", str(args.work)])  # fmt: skip
    args.work.mkdir(parents=True, exist_ok=True)
    lines = evaluate_one(log, args.path, args.work)
    print("\n".join(lines))
    print(f"(not written into docs/real-logs.md: {log.licence}; "
          f"table and figure in {args.work})")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
