"""A Foxglove layout for terrapath's runs (``terrapath layout``): import it once in Foxglove
(*Layouts -> Import from file*) and every recorded run opens ready to look at.

The layout (Foxglove's layout JSON: ``configById`` -- each panel's settings under
``"<PanelType>!<id>"`` -- and ``layout``, the tree of row / column splits that places them):

- a **3D** panel in the ``map`` frame following ``base_link``, with the terrain mesh, the threats,
  the mission's waypoints, the flown track, the radar's detections and the avoider's orbits
  visible (:data:`SCENE_TOPICS`);
- **plots** from ``/vehicle/state``: altitude and its command, airspeed and its command, bank and
  its command (radians, as recorded; the protobuf field names of ``terrapath.VehicleState`` since
  recording format 2, the same paths as format 1's JSON keys); from ``/vehicle/separation``: the
  separation from the nearest active threat and from the nearest danger zone against the run's
  margin (written where it changes: Foxglove draws the line between the samples);
- a **raw messages** panel on ``/avoidance/decision``: each decision with its inputs, its
  command and its compute time.

Every topic and message path it names is one the recorder writes (:mod:`replay.record.topics`,
:data:`replay.record.messages.STATE_KEYS`, :data:`replay.flight.log.GUIDANCE_COLUMNS`,
:data:`replay.record.messages.SEPARATION_DOCS`): ``check_layout`` says so, and the tests hold it to
that.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from replay.record import topics as T

SCENE_TOPICS = (
    T.TERRAIN,
    T.THREATS,
    T.WAYPOINTS,
    T.VEHICLE_TRACK,
    T.VEHICLE_TRACK_OVERVIEW,
    T.DETECTIONS,
    T.GUIDANCE,
)
PANEL_3D = "3D!terrapath"
_S, _D = T.VEHICLE_STATE, T.SEPARATION
PLOTS = {
    "Plot!altitude": ("altitude (m AMSL)", (f"{_S}.alt", f"{_S}.extras.altitude_cmd")),
    "Plot!airspeed": ("airspeed (m/s)", (f"{_S}.airspeed", f"{_S}.extras.airspeed_cmd")),
    "Plot!bank": ("bank (rad)", (f"{_S}.phi", f"{_S}.extras.bank_cmd")),
    "Plot!separation": (
        "separation (m)",
        (f"{_D}.nearest_m", f"{_D}.zone_m", f"{_D}.margin_m"),
    ),
}
PANEL_DECISIONS = "RawMessages!decisions"
PANEL_TYPES = ("3D", "Plot", "RawMessages")


def foxglove_layout() -> dict[str, Any]:
    """The layout as a JSON-ready dict (module docstring)."""
    config: dict[str, Any] = {
        PANEL_3D: {
            "followTf": T.VEHICLE_FRAME,
            "followMode": "follow-position",
            "scene": {"transforms": {"showLabel": False}},
            "transforms": {},
            "topics": {topic: {"visible": True} for topic in SCENE_TOPICS},
            "layers": {},
            "cameraState": {
                "perspective": True,
                "distance": 3000.0,
                "phi": 55.0,
                "thetaOffset": 30.0,
                "targetOffset": [0.0, 0.0, 0.0],
                "target": [0.0, 0.0, 0.0],
                "targetOrientation": [0.0, 0.0, 0.0, 1.0],
                "fovy": 45.0,
                "near": 1.0,
                "far": 200_000.0,
            },
        },
        PANEL_DECISIONS: {"topicPath": T.DECISION, "diffEnabled": False},
    }
    for panel, (title, fields) in PLOTS.items():
        config[panel] = {
            "title": title,
            "paths": [
                {"value": path, "enabled": True, "timestampMethod": "receiveTime"}
                for path in fields
            ],
            "showLegend": True,
            "legendDisplay": "floating",
            "xAxisVal": "timestamp",
            "isSynced": True,
        }
    plots = list(PLOTS)
    right: Any = {
        "direction": "column",
        "first": plots[0],
        "second": {
            "direction": "column",
            "first": plots[1],
            "second": {
                "direction": "column",
                "first": plots[2],
                "second": {
                    "direction": "column",
                    "first": plots[3],
                    "second": PANEL_DECISIONS,
                    "splitPercentage": 50.0,
                },
                "splitPercentage": 25.0,
            },
            "splitPercentage": 22.0,
        },
        "splitPercentage": 18.0,
    }
    return {
        "configById": config,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1.0},
        "layout": {"direction": "row", "first": PANEL_3D, "second": right, "splitPercentage": 62.0},
    }


def _leaves(node: Any) -> list[str]:
    if isinstance(node, str):
        return [node]
    return [*_leaves(node["first"]), *_leaves(node["second"])]


def check_layout(layout: dict[str, Any]) -> list[str]:
    """What is wrong with ``layout`` (empty: nothing): the tree's panels and ``configById`` agree,
    each split has a direction and two children, the panel types are Foxglove's, and every topic
    and ``/vehicle/state`` path is one the recorder writes."""
    from replay.flight.log import GUIDANCE_COLUMNS
    from replay.record.messages import SEPARATION_DOCS, STATE_KEYS

    problems: list[str] = []
    config = layout.get("configById", {})
    leaves = _leaves(layout["layout"])
    if sorted(leaves) != sorted(config):
        problems.append(f"the tree places {sorted(leaves)} but configures {sorted(config)}")

    def splits(node: Any) -> None:
        if isinstance(node, str):
            return
        if (
            node.get("direction") not in ("row", "column")
            or not 0 < node.get("splitPercentage", 50) < 100
        ):
            problems.append(
                f"a split needs a direction (row/column) and 0 < splitPercentage < 100: {node}"
            )
        splits(node["first"])
        splits(node["second"])

    splits(layout["layout"])
    fields = {
        T.VEHICLE_STATE: {*STATE_KEYS, *(f"extras.{c}" for c in GUIDANCE_COLUMNS)},
        T.SEPARATION: set(SEPARATION_DOCS),
    }
    for panel, cfg in config.items():
        kind = panel.split("!", 1)[0]
        if kind not in PANEL_TYPES:
            problems.append(f"{panel}: unknown panel type {kind!r}")
        for topic in cfg.get("topics", {}):
            if topic not in T.SCHEMAS:
                problems.append(f"{panel}: no such topic {topic}")
        for path in cfg.get("paths", []):
            topic, _, field = path["value"].partition(".")
            if field not in fields.get(topic, ()):
                problems.append(f"{panel}: {path['value']} is not a recorded message field")
        if "topicPath" in cfg and cfg["topicPath"] not in T.SCHEMAS:
            problems.append(f"{panel}: no such topic {cfg['topicPath']}")
    return problems


def layout_json() -> str:
    return json.dumps(foxglove_layout(), indent=2) + "\n"


def write_layout(path: str | Path) -> Path:
    """Write the layout JSON through a temporary name."""
    from terrain.atomic import atomic_output

    out = Path(path)
    with atomic_output(out) as tmp:
        tmp.write_text(layout_json(), encoding="utf-8")
    return out


__all__ = ["check_layout", "foxglove_layout", "layout_json", "write_layout"]
