"""The Foxglove live view's messages, the MCAP export, the layout file and the CLI flags."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from protowire import ProtoSchema

from sonarproc.cli import main
from sonarproc.errors import ParameterError
from sonarproc.live import parse_endpoint
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log, process
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"
LAYOUT = ROOT / "configs" / "foxglove" / "sonarmorph-layout.json"
TOPICS = {
    "/sonar/readings": "foxglove.SceneUpdate",
    "/sonar/raw": "sonarmorph.Reading",
    "/robot/pose": "foxglove.PoseInFrame",
    "/robot/path": "foxglove.PosesInFrame",
    "/tf": "foxglove.FrameTransforms",
    "/map/arcs": "foxglove.Grid",
    "/map/processed": "foxglove.Grid",
    "/map/surfaces": "foxglove.SceneUpdate",
    "/map/quality": "sonarmorph.Quality",
}


@pytest.fixture(scope="module")
def room_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A room with several walls: a run with several surfaces."""
    path = tmp_path_factory.mktemp("room") / "room-box.h5"
    simulate_to_log(SCENARIOS / "room-box.yaml", path)
    return path


def test_parse_endpoint() -> None:
    assert parse_endpoint("9000") == ("127.0.0.1", 9000)
    assert parse_endpoint("0.0.0.0:0") == ("0.0.0.0", 0)
    assert parse_endpoint("") == ("127.0.0.1", 8765)
    for bad in ("x", "70000", ":80", "host:-1"):
        with pytest.raises(ParameterError, match="--foxglove"):
            parse_endpoint(bad)


def test_beam_outline_lies_on_the_echo_ellipse() -> None:
    from sonarlog.foxglove_messages import beam_outline

    tx, rx = np.array([0.0, 0.0]), np.array([0.3, 0.0])
    pts = beam_outline(tx, rx, np.pi / 2, 0.2, 2.0)
    arc = pts[1:-1]
    total = np.hypot(*(arc - tx).T) + np.hypot(*(arc - rx).T)
    np.testing.assert_allclose(total, 2.0, atol=1e-12)
    np.testing.assert_array_equal(pts[0], tx)
    np.testing.assert_array_equal(pts[-1], rx)


def _read_mcap(path: Path) -> tuple[dict[str, Any], list[tuple[str, int, Any]]]:
    from mcap.reader import make_reader

    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        channels = {}
        decoders = {}
        for ch in summary.channels.values():
            schema = summary.schemas[ch.schema_id]
            channels[ch.topic] = (ch.message_encoding, schema.name, schema.encoding)
            if ch.message_encoding == "protobuf":
                proto = ProtoSchema(schema.data)
                decoders[ch.id] = lambda b, p=proto, n=schema.name: p.decode(n, b)
            else:
                decoders[ch.id] = lambda b: json.loads(b)
        messages = [
            (channel.topic, message.log_time, decoders[channel.id](message.data))
            for _, channel, message in reader.iter_messages(log_time_order=True)
        ]
    return channels, messages


def _replay_entities(updates: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The entities a viewer shows after applying every SceneUpdate in order."""
    shown: dict[str, dict[str, Any]] = {}
    for u in updates:
        for d in u.get("deletions", []):
            shown.pop(d.get("id", ""), None)
        for e in u.get("entities", []):
            shown[e["id"]] = e
    return shown


def test_mcap_export_holds_the_run(room_log: Path, tmp_path: Path) -> None:
    pytest.importorskip("foxglove")
    out = tmp_path / "export"
    assert main(["export", str(room_log), "--format", "mcap", "--out", str(out)]) == 0
    path = out / "morphological.mcap"
    channels, messages = _read_mcap(path)
    assert {t: c[1] for t, c in channels.items()} == TOPICS
    assert channels["/sonar/raw"][:1] == ("json",) and channels["/map/arcs"][0] == "protobuf"
    lg = load_log(room_log)
    counts: dict[str, int] = {}
    for topic, _, _ in messages:
        counts[topic] = counts.get(topic, 0) + 1
    # one beam and one raw row per reading of the log
    assert counts["/sonar/readings"] == counts["/sonar/raw"] == len(lg.readings)
    raw = [m for t, _, m in messages if t == "/sonar/raw"]
    np.testing.assert_array_equal([r["tx"] for r in raw], lg.readings["tx"])
    times = [lt for t, lt, _ in messages if t == "/sonar/raw"]
    np.testing.assert_array_equal(times, np.round(lg.readings["t"] * 1e9).astype(np.int64))
    assert counts["/map/arcs"] >= 2  # the map grows, then the final result
    # the surfaces, replayed, are the run's surfaces
    result = process(lg, RunParams(ops="thinning:3", fit="auto"))
    assert result.surfaces is not None and len(result.surfaces.surfaces) >= 3
    shown = _replay_entities([m for t, _, m in messages if t == "/map/surfaces"])
    assert sorted(shown) == sorted(f"surface/{i}" for i in range(len(result.surfaces.surfaces)))
    for i, s in enumerate(result.surfaces.surfaces):
        e = shown[f"surface/{i}"]
        meta = {kv["key"]: kv["value"] for kv in e["metadata"]}
        assert meta["kind"] == ("plane" if s.model == "line" else "curve")
        assert meta["model"] == s.model and int(meta["support"]) == s.support
        assert float(meta["length_m"]) == pytest.approx(s.length_m, abs=1e-4)
        assert float(meta["rms_m"]) == pytest.approx(s.rms_m, abs=1e-5)
        pts = np.array([[p.get("x", 0.0), p.get("y", 0.0)] for p in e["lines"][0]["points"]])
        np.testing.assert_array_equal(pts, s.polyline)
    # the last count map is the run's, cell for cell
    grid = [m for t, _, m in messages if t == "/map/arcs"][-1]
    assert grid["column_count"] == result.grid.nx
    cells = np.frombuffer(grid["data"], dtype="<u2").reshape(result.grid.ny, result.grid.nx)
    np.testing.assert_array_equal(cells, np.minimum(result.counts_map, 65535))
    quality = [m for t, _, m in messages if t == "/map/quality"][-1]
    assert quality["surfaces"] == len(result.surfaces.surfaces)
    # no partial file, and an existing one is kept without --force
    assert [p.name for p in out.iterdir()] == ["morphological.mcap"]
    assert main(["export", str(room_log), "--format", "mcap", "--out", str(out)]) == 2


def test_map_publisher_sends_only_what_changed(room_log: Path) -> None:
    pytest.importorskip("foxglove")
    import foxglove

    from sonarproc.live.map_messages import MapPublisher

    lg = load_log(room_log)
    result = process(lg, RunParams(ops="thinning:3", fit="auto"))
    pub = MapPublisher(context=foxglove.Context())
    first = pub.publish(result, t=1.0)
    assert first["grids"] == 2 and first["surfaces"] == len(result.surfaces.surfaces)
    assert pub.publish(result, t=2.0) == {"grids": 0, "surfaces": 0, "deleted": 0}
    fewer = process(lg.__class__(**{**lg.__dict__, "readings": lg.readings[::2]}), result.params)
    again = pub.publish(fewer, t=3.0)
    assert again["grids"] == 2 and again["surfaces"] + again["deleted"] > 0


def test_surface_kinds_and_colours() -> None:
    from sonarproc.live.map_messages import KIND_COLORS, surface_kind
    from sonarproc.surfaces import SurfaceFit

    line = SurfaceFit("line", np.zeros((2, 2)), 1.0, 0.0, 5, 5)
    arc = SurfaceFit("arc", np.zeros((2, 2)), 1.0, 0.0, 5, 5)
    assert (surface_kind(line), surface_kind(arc)) == ("plane", "cylinder")
    assert set(KIND_COLORS) == {"plane", "curve", "cylinder", "corner", "edge"}
    assert len(set(KIND_COLORS.values())) == 5


def test_layout_is_a_foxglove_layout() -> None:
    doc = json.loads(LAYOUT.read_text(encoding="utf-8"))
    assert set(doc) >= {"configById", "layout", "globalVariables", "userNodes"}

    def leaves(node: Any) -> list[str]:
        if isinstance(node, str):
            return [node]
        assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
        return leaves(node["first"]) + leaves(node["second"])

    panels = leaves(doc["layout"])
    assert sorted(panels) == sorted(doc["configById"])
    kinds = {p.split("!")[0] for p in panels}
    assert {"3D", "Plot", "Table"} <= kinds
    three = doc["configById"]["3D!sonarmorph"]
    assert {"/map/arcs", "/map/surfaces", "/sonar/readings", "/robot/path"} <= set(three["topics"])
    referenced = set(three["topics"])
    referenced |= {p["value"].split(".")[0] for p in doc["configById"]["Plot!quality"]["paths"]}
    referenced |= {c["topicPath"] for k, c in doc["configById"].items() if "topicPath" in c}
    assert referenced <= set(TOPICS)


def test_flags_without_the_sdk_say_how_to_install(
    room_log: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import sonarproc.live.endpoint as endpoint

    monkeypatch.setattr(endpoint, "foxglove_missing", lambda: True)
    for argv in (
        ["watch", str(room_log), "--foxglove", "0", "--once", "--out", str(tmp_path / "w")],
        ["run", str(room_log), "--foxglove", "0", "--out", str(tmp_path / "r")],
        ["export", str(room_log), "--format", "mcap", "--out", str(tmp_path / "e")],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1] == (
            "sonarproc: error: --foxglove needs the Foxglove SDK: pip install 'sonarmorph[live]'"
        )
    monkeypatch.undo()
    assert main(["watch", str(room_log), "--foxglove", "70000", "--once"]) == 2
    assert "port must be 0..65535" in capsys.readouterr().err


def test_watch_once_serves_and_stops(room_log: Path, tmp_path: Path) -> None:
    pytest.importorskip("foxglove")
    out = tmp_path / "report"
    argv = ["watch", str(room_log), "--foxglove", "127.0.0.1:0", "--once", "--out", str(out)]
    assert main(argv) == 0
    doc = json.loads((out / "report.json").read_text())
    assert doc["live"]["final"] is True and doc["live"]["readings_seen"] > 0
