"""The Foxglove layout (issue 16): its tree and its panels agree, and every topic and message path
it names is one a replay MCAP has."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory

from replay.record.foxglove_layout import PANEL_3D, SCENE_TOPICS, check_layout, foxglove_layout
from terrapath.cli import main


def test_the_layout_names_only_what_the_recorder_writes() -> None:
    layout = foxglove_layout()
    assert check_layout(layout) == []
    cfg = layout["configById"][PANEL_3D]
    assert cfg["followTf"] == "base_link" and set(cfg["topics"]) == set(SCENE_TOPICS)
    assert all(v == {"visible": True} for v in cfg["topics"].values())
    assert layout["configById"]["RawMessages!decisions"]["topicPath"] == "/avoidance/decision"


def test_check_layout_finds_what_is_wrong() -> None:
    layout = foxglove_layout()
    layout["configById"]["Plot!altitude"]["paths"][0]["value"] = "/vehicle/state.altitude"
    layout["configById"][PANEL_3D]["topics"]["/no/such"] = {"visible": True}
    layout["configById"]["Gauge!x"] = {}
    problems = check_layout(layout)
    assert any("/vehicle/state.altitude is not a recorded message field" in p for p in problems)
    assert any("no such topic /no/such" in p for p in problems)
    assert any("unknown panel type 'Gauge'" in p for p in problems)
    assert any("the tree places" in p for p in problems)


def test_the_layout_topics_are_in_a_recorded_run(tmp_path: Path) -> None:
    """A real run has every topic the 3D panel shows (the guidance one once an orbit is flown)
    and every field the plots draw; its separation topic agrees with the run's metrics."""
    from mcap.reader import make_reader

    from replay.record.reader import load_run

    root = Path(__file__).resolve().parents[1] / "data" / "scenarios"
    out = tmp_path / "run.mcap"
    args = ["replay", str(root / "seed001-mission.yaml"), "--no-picture", "-o", str(out)]
    threats = ["--threats", str(root / "seed001-simple-threats.yaml"), "--avoid", "ctga"]
    main([*args, *threats, "--sensor", "cooperative"])
    with out.open("rb") as f:
        channels = {c.topic for c in make_reader(f).get_summary().channels.values()}
    assert set(SCENE_TOPICS) <= channels and "/avoidance/decision" in channels
    plotted = {
        p["value"] for cfg in foxglove_layout()["configById"].values() for p in cfg.get("paths", [])
    }
    found: set[str] = set()
    docs: dict[str, list[tuple[int, dict]]] = {}
    with out.open("rb") as f:
        topics = {p.partition(".")[0] for p in plotted}
        for schema, ch, msg in make_reader(f).iter_messages(topics=topics, log_time_order=True):
            if schema.encoding == "protobuf":  # /vehicle/state (format 2): by field name
                cls = message_factory.GetMessageClass(
                    _pool(schema).FindMessageTypeByName(schema.name)
                )
                doc = json_format.MessageToDict(
                    cls.FromString(msg.data), preserving_proto_field_name=True
                )
            else:
                doc = json.loads(msg.data)
            docs.setdefault(ch.topic, []).append((msg.log_time, doc))
            for path in plotted:
                topic, _, field = path.partition(".")
                node = doc
                for part in field.split("."):
                    node = node.get(part) if isinstance(node, dict) else None
                if topic == ch.topic and isinstance(node, (int, float)):
                    found.add(path)
    # the zone plot is empty here: the mission has no danger zones
    assert found == plotted - {"/vehicle/separation.zone_m"}
    seps = docs["/vehicle/separation"]
    states = docs["/vehicle/state"]
    # separations at state samples, where they change (format 2): the first and last, the least
    state_times = [t for t, _ in states]
    assert {t for t, _ in seps} <= set(state_times) and len(seps) < len(states)
    assert seps[0][0] == state_times[0]
    metrics = load_run(out, with_states=False).metrics
    for ident in ("obstacle-1", "obstacle-2"):
        low = min(d["threats"][ident] for _, d in seps if ident in d["threats"])
        assert low == pytest.approx(metrics["min_separation"][ident]["value"], abs=0.5)


def _pool(schema: Any) -> descriptor_pool.DescriptorPool:
    pool = descriptor_pool.DescriptorPool()
    for fd in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
        pool.Add(fd)
    return pool


def test_cli_prints_and_writes_the_layout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["layout"]) in (0, None)
    assert json.loads(capsys.readouterr().out) == foxglove_layout()
    out = tmp_path / "terrapath.json"
    assert main(["layout", "-o", str(out)]) in (0, None)
    assert json.loads(out.read_text()) == foxglove_layout()
    assert main(["layout", "-o", str(tmp_path / "x.txt")]) == 2
