"""Names used inside a recorded run (``run.mcap``): topics, schemas, frames, metadata records.

One module, like mcap's ``well_known.py``: the recorder (:mod:`replay.record.recorder`) writes these names
and the reader (:mod:`replay.record.reader`) looks for them, so neither spells a topic twice.

Topics and their schemas (Foxglove schemas are protobuf, from ``foxglove-schemas-protobuf``, and so
is ``terrapath.VehicleState``; the other ``terrapath.*`` schemas are JSON Schema, messages JSON)::

    /tf                      foxglove.FrameTransform   map -> base_link, at the state log rate
    /tf_static               foxglove.FrameTransform   map -> world, once at t = 0
    /map/terrain             foxglove.SceneUpdate      terrain triangle mesh, once
    /vehicle/pose            foxglove.PoseInFrame      vehicle pose in ``map``, at the log rate
    /vehicle/separation      terrapath.Separation      nearest threat and zone, margin, where they change
    /vehicle/state           terrapath.VehicleState    full 12-state, controls, airspeed, extras
                                                       (protobuf, built in replay.record.messages)
    /vehicle/fix             foxglove.LocationFix      WGS84 position (georeferenced runs only)
    /vehicle/track           foxglove.SceneUpdate      flown track since the last overview (1 Hz)
    /vehicle/track_overview  foxglove.SceneUpdate      whole flown track, decimated (every 60 s)
    /mission/waypoints       foxglove.SceneUpdate      waypoint line strip and spheres
    /mission/waypoint_list   terrapath.WaypointList    waypoints, active index, reason of change
    /threats                 foxglove.SceneUpdate      threat shapes, with deletions
    /threats/list            terrapath.ThreatList      current threats, appeared/moved/removed ids
    /radar/detections        foxglove.SceneUpdate      one marker per detection of the last scan
                                                       (written when the markers change)
    /radar/detection_list    terrapath.DetectionList   the detections of the last scan
    /rangefinder/beams       foxglove.SceneUpdate      rangefinder beams of the last scan, a line
                                                       list: aircraft to hit (red) or full range
    /avoidance/decision      terrapath.Decision        one avoidance decision and its compute time
    /avoidance/guidance      foxglove.SceneUpdate      the avoider's orbit (CTGA's arc) as a circle,
                                                       FGA's collision cones as a line list,
                                                       the priority loop's set-points as a line
    /log                     foxglove.Log              human-readable events
    /metrics                 terrapath.Metrics         run metrics, once at the end

Frames: ``map`` (ENU, origin at the recorder's map origin so that coordinates in Foxglove stay
small; the root of the tree), ``world`` (the map CRS, metres; a child of ``map``) and ``base_link``
(the vehicle, FLU axes).

Metadata records: ``terrapath`` (run description: format version, seed, software version, command,
avoider, wall-clock start, CRS, map origin, rates) and ``metrics`` (each value JSON-encoded).
"""

from __future__ import annotations

# topics
TF = "/tf"
TF_STATIC = "/tf_static"
TERRAIN = "/map/terrain"
VEHICLE_POSE = "/vehicle/pose"
VEHICLE_STATE = "/vehicle/state"
SEPARATION = "/vehicle/separation"
VEHICLE_FIX = "/vehicle/fix"
VEHICLE_TRACK = "/vehicle/track"
VEHICLE_TRACK_OVERVIEW = "/vehicle/track_overview"
WAYPOINTS = "/mission/waypoints"
WAYPOINT_LIST = "/mission/waypoint_list"
THREATS = "/threats"
THREAT_LIST = "/threats/list"
DETECTIONS = "/radar/detections"
DETECTION_LIST = "/radar/detection_list"
RANGEFINDER_BEAMS = "/rangefinder/beams"
DECISION = "/avoidance/decision"
GUIDANCE = "/avoidance/guidance"
LOG = "/log"
METRICS = "/metrics"

# Foxglove protobuf schema names (the full names of the foxglove_schemas_protobuf messages)
FRAME_TRANSFORM = "foxglove.FrameTransform"
POSE_IN_FRAME = "foxglove.PoseInFrame"
LOCATION_FIX = "foxglove.LocationFix"
SCENE_UPDATE = "foxglove.SceneUpdate"
LOG_SCHEMA = "foxglove.Log"

# terrapath JSON Schema names
STATE_SCHEMA = "terrapath.VehicleState"
WAYPOINT_LIST_SCHEMA = "terrapath.WaypointList"
THREAT_LIST_SCHEMA = "terrapath.ThreatList"
DETECTION_LIST_SCHEMA = "terrapath.DetectionList"
DECISION_SCHEMA = "terrapath.Decision"
METRICS_SCHEMA = "terrapath.Metrics"
SEPARATION_SCHEMA = "terrapath.Separation"

# schema and message encodings (MCAP registry names)
PROTOBUF = "protobuf"
JSONSCHEMA = "jsonschema"
JSON = "json"

# topic -> schema name, in the order the channels are registered
SCHEMAS: dict[str, str] = {
    TF: FRAME_TRANSFORM,
    TF_STATIC: FRAME_TRANSFORM,
    TERRAIN: SCENE_UPDATE,
    VEHICLE_POSE: POSE_IN_FRAME,
    VEHICLE_STATE: STATE_SCHEMA,
    SEPARATION: SEPARATION_SCHEMA,
    VEHICLE_FIX: LOCATION_FIX,
    VEHICLE_TRACK: SCENE_UPDATE,
    VEHICLE_TRACK_OVERVIEW: SCENE_UPDATE,
    WAYPOINTS: SCENE_UPDATE,
    WAYPOINT_LIST: WAYPOINT_LIST_SCHEMA,
    THREATS: SCENE_UPDATE,
    THREAT_LIST: THREAT_LIST_SCHEMA,
    DETECTIONS: SCENE_UPDATE,
    DETECTION_LIST: DETECTION_LIST_SCHEMA,
    RANGEFINDER_BEAMS: SCENE_UPDATE,
    DECISION: DECISION_SCHEMA,
    GUIDANCE: SCENE_UPDATE,
    LOG: LOG_SCHEMA,
    METRICS: METRICS_SCHEMA,
}

# the topics the reader decodes; the recorder keeps them in chunks of their own, so that reading
# them back does not decompress and parse the high-rate display topics (/tf, /vehicle/pose...)
DATA_TOPICS = (
    VEHICLE_STATE,
    WAYPOINT_LIST,
    THREAT_LIST,
    DETECTION_LIST,
    DECISION,
    LOG,
    METRICS,
)

# frames
WORLD_FRAME = "world"
MAP_FRAME = "map"
VEHICLE_FRAME = "base_link"

# metadata records
RUN_METADATA = "terrapath"
METRICS_METADATA = "metrics"
# the recording format (metadata "terrapath"): 1 had /vehicle/state as JSON text and
# /vehicle/separation at every state sample; 2 (issue 38) has /vehicle/state as protobuf
# (terrapath.VehicleState) and /vehicle/separation where it changes.  The reader reads both.
# /radar/detections (markers, not read back) is written only when a scan's markers differ from
# those shown: the entity has no lifetime, so Foxglove shows the same at every time, and the
# markers at a time are still the last message before it -- no reader needs to know (format 2).
FORMAT_VERSION = "2"
READABLE_FORMATS = ("1", "2")

# MCAP header profile (empty: not ROS) and the library string prefix
PROFILE = ""
LIBRARY = "terrapath replay.record.recorder"

# names of the 12 state and 4 control fields in the state message, in vector order (replay.frames)
STATE_FIELDS = ("pn", "pe", "pd", "u", "v", "w", "phi", "theta", "psi", "p", "q", "r")
CONTROL_FIELDS = ("delta_e", "delta_a", "delta_r", "delta_t")
