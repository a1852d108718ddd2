"""A campaign spec (``terrapath campaign SPEC.yaml``): which missions, threats, avoiders, how many
runs, from which seed -- validated at the edge, every problem a one-line error naming the file
and the field.

```yaml
terrapath: 1
name: pso-ca-fields
mission: data/missions/seed000-table4.yaml      # or several: missions: [...]
dem: null                                        # DEM tiles of missions of other tools
                                                 # (.plan, .waypoints, GeoJSON, KML): [a.tif]
threats:                                         # a generator, or files: [a.yaml, b.yaml]
  generator: seed000-normal                      # see GENERATORS
  counts: [10, 40, 70]                           # one row of the study per count
  sigma: 3000                                    # generator settings (replay.campaign.generators)
  keep_clear: 1500
avoiders:
  - {name: pso-ca, options: {optimizer: pso}}
  - {name: none}
sensor: radar                                    # or cooperative, or rangefinder (default:
                                                 # the avoiders' only sensor, else radar)
sensor_range: null                               # optional: the sensor's range (m)
runs: 10                                         # per (mission, row, avoider)
seed: 1
margin: 0                                        # optional: success margin (m)
duration: null                                   # optional: longest flight (s)
winds: [calm, "10,270", {speed: 10, from: 270, turbulence: moderate}]  # optional: rows per wind
```

``sensor_range`` is the radar's or the cooperative sensor's range (default 10 km), or with
``sensor: rangefinder`` (seed 003's beams, :mod:`replay.sensors.rangefinder`, whose hits reach the
avoiders as sensor returns) the beams' range R (default 20 m; four beams, gimballed, no noise).

Paths are relative to the spec's folder.  The study's **rows** are the counts (a generator) or the
files (each file one row, named by its stem); with ``winds`` each of them in each wind
(``40@calm``, ``40@10-270``: the same scenarios in every wind, success against the wind).  A **run** is (mission, row, avoider, run index);
its key reads ``mission/row/avoider/run`` (the mission by its file's stem, the avoider by its name
and options: ``pso-ca[optimizer=pso]``).

Seeds.  The threats of a run are drawn from the *scenario seed*, derived from the campaign seed,
the mission, the row and the run index -- not the avoider, so that every avoider of a row meets
the same scenarios (the papers compare them so).  The replay (radar noise, the avoider's own
randomness) takes the *run seed*, derived from the campaign seed and the whole key.  Both are the
first 8 bytes of SHA-256 of the text ``seed|part|part...`` read as an integer, masked to 63
bits: stable across machines, Python versions and executors.

A run's *identity* (``run_hash``) is the SHA-256 of everything its result depends on: the mission
file's bytes, the threat file's bytes or the generator and its settings, the avoider and its
options, the sensor, margin, duration and both seeds.  The store keeps one row per identity, so
changing ``runs`` or adding a count keeps every run already flown.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from replay.avoidance.registry import SENSORS, sensor_for
from replay.campaign.generators import (
    Params,
    case_generator,
    generator_names,
    generator_origin,
    threat_generator,
)
from terrain.docfile import parse_yaml
from terrain.errors import DataFileError, InputError, PluginError

SPEC_KEYS = (
    *("terrapath", "name", "mission", "missions", "dem", "threats", "avoiders"),
    *("sensor", "sensor_range", "runs", "seed", "margin", "duration", "winds"),
)
THREAT_KEYS = (
    *("generator", "counts", "dynamic", "maps", "files"),
    *("sigma", "keep_clear", "radius", "altitude", "box"),
)
# generators named by the issues but not built yet: said so when asked for
COMING: dict[str, str] = {}


@dataclass(frozen=True)
class Row:
    """One row of the study: a threat count of the generator, or a threat file."""

    label: str
    count: int | None = None
    file: Path | None = None
    dynamic: bool | None = None  # a case generator's row: its static or its dynamic set
    map: str | None = None  # own-scenarios' row: the map (own-buildings': the layout)
    # a spec's ``winds``: the row's air mass (replay.flight.wind.Wind; None: still air) and the
    # threat row's label without the wind's (its scenarios are the same in every wind)
    wind: Any = None
    threat_label: str | None = None

    @property
    def scenario_label(self) -> str:
        """The label the scenario seed is drawn from: the threat row's, whatever the wind."""
        return self.threat_label or self.label


@dataclass(frozen=True)
class Avoider:
    name: str
    options: tuple[tuple[str, Any], ...] = ()

    @property
    def label(self) -> str:
        if not self.options:
            return self.name
        return f"{self.name}[{','.join(f'{k}={v}' for k, v in self.options)}]"


@dataclass(frozen=True)
class Run:
    """One replay of the campaign (everything a worker needs; picklable)."""

    key: str
    mission: Path
    row: Row
    avoider: Avoider
    index: int
    seed: int
    scenario_seed: int
    run_hash: str
    generator: str | None
    params: Params
    sensor: str
    margin: float
    duration: float | None
    sensor_range: float | None = None  # None: the replay's default
    dem: tuple[str, ...] = ()  # the DEM tiles of a mission of another tool

    @property
    def makes_cases(self) -> bool:
        """The generator makes the whole case (its mission too): ``mission`` names it."""
        return case_generator(self.generator) is not None


@dataclass(frozen=True)
class Spec:
    path: Path
    name: str
    missions: tuple[Path, ...]
    generator: str | None
    params: Params
    rows: tuple[Row, ...]
    avoiders: tuple[Avoider, ...]
    sensor: str
    runs: int
    seed: int
    margin: float = 0.0
    duration: float | None = None
    spec_hash: str = ""
    digests: dict[str, str] = field(default_factory=dict)  # file -> SHA-256 of its bytes
    sensor_range: float | None = None
    dem: tuple[str, ...] = ()  # DEM tiles for missions of other tools (absolute paths)

    def content_hash(self) -> str:
        """SHA-256 of what the spec asks for (files by their bytes' digests)."""
        canonical = {
            "name": self.name,
            "missions": [self.digests[str(m)] for m in self.missions],
            "threats": [
                self.generator,
                _plain(self.params),
                [[r.label, r.count, self.digests.get(str(r.file))] for r in self.rows],
            ],
            "avoiders": [[a.name, [list(o) for o in a.options]] for a in self.avoiders],
            "sensor": self.sensor,
            "runs": self.runs,
            "seed": self.seed,
            "margin": self.margin,
            "duration": self.duration,
            **({"sensor_range": self.sensor_range} if self.sensor_range is not None else {}),
            **({"dem": list(self.dem)} if self.dem else {}),
            **(
                {"dynamic": [r.dynamic for r in self.rows]}
                if case_generator(self.generator) is not None
                else {}
            ),
            **({"maps": [r.map for r in self.rows]} if any(r.map for r in self.rows) else {}),
            **(
                {"winds": [r.wind.to_dict() if r.wind else None for r in self.rows]}
                if any(r.wind is not None for r in self.rows)
                else {}
            ),
        }
        return hashlib.sha256(json.dumps(canonical, sort_keys=True).encode()).hexdigest()

    def narrowed(
        self, runs: int | None = None, avoiders: tuple[Avoider, ...] | None = None
    ) -> Spec:
        """The spec with fewer runs or avoiders (a quick version: its runs keep their identity)."""
        spec = replace(
            self,
            runs=self.runs if runs is None else runs,
            avoiders=self.avoiders if avoiders is None else avoiders,
        )
        return replace(spec, spec_hash=spec.content_hash())

    def all_runs(self) -> list[Run]:
        """Every run, in a fixed order: mission, row, avoider, run index."""
        out = []
        for m in self.missions:
            for row in self.rows:
                for av in self.avoiders:
                    for i in range(self.runs):
                        out.append(self.run(m, row, av, i))
        return out

    def run(self, mission: Path, row: Row, avoider: Avoider, index: int) -> Run:
        key = f"{mission.stem}/{row.label}/{avoider.label}/{index}"
        scenario = derive_seed(self.seed, "scenario", mission.stem, row.scenario_label, index)
        seed = derive_seed(self.seed, key)
        identity: dict[str, Any] = {
            "mission": self.digests[str(mission)],
            "threats": self.digests[str(row.file)]
            if row.file is not None
            else {"generator": self.generator, "count": row.count, **_plain(self.params)},
            "avoider": [avoider.name, [list(o) for o in avoider.options]],
            "sensor": self.sensor,
            "margin": self.margin,
            "duration": self.duration,
            "seeds": [scenario, seed],
        }
        if row.dynamic is not None:
            identity["dynamic"] = row.dynamic
        if row.map is not None:
            identity["map"] = row.map
        if row.wind is not None:
            identity["wind"] = row.wind.to_dict()
        if self.sensor_range is not None:
            identity["sensor_range"] = self.sensor_range
        if self.dem:
            identity["dem"] = list(self.dem)
        plugins = _plugin_origins(avoider.name, self.generator)
        if plugins:  # an installed package's new version flies its runs again
            identity["plugins"] = plugins
        run_hash = hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()
        return Run(
            key,
            mission,
            row,
            avoider,
            index,
            seed,
            scenario,
            run_hash,
            self.generator,
            self.params,
            self.sensor,
            self.margin,
            self.duration,
            self.sensor_range,
            self.dem,
        )

    def find(self, key: str) -> Run:
        """The run of ``key``; an error listing a few valid keys when there is none."""
        runs = self.all_runs()
        for r in runs:
            if r.key == key:
                return r
        some = ", ".join(r.key for r in runs[:3])
        raise InputError(
            f"{self.path}: no run {key!r} in this campaign (its {len(runs)} keys read "
            f"mission/row/avoider/run, e.g. {some})"
        )


def derive_seed(seed: int, *parts: Any) -> int:
    """A 63-bit seed from the campaign seed and the parts (module docstring)."""
    text = "|".join(str(p) for p in (seed, *parts))
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big") & (2**63 - 1)


def _plain(p: Params) -> dict[str, Any]:
    return {
        "sigma": p.sigma,
        "keep_clear": p.keep_clear,
        "radius": p.radius,
        "altitude": p.altitude,
        "box": list(p.box) if p.box is not None else None,
    }


def _fail(path: Path, fld: str, msg: str) -> InputError:
    return InputError(f"{path}, field '{fld}': {msg}")


def _number(path: Path, fld: str, value: Any, *, minimum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(path, fld, f"expected a number, found {value!r}")
    if minimum is not None and value < minimum:
        raise _fail(path, fld, f"expected a number >= {minimum:g}, found {value!r}")
    return float(value)


# Runs one campaign may hold (missions x rows x avoiders x runs): each run is seconds to minutes
# of flight, so a million is months of computing; the list of runs is made in memory.
MAX_RUNS = 1_000_000


def _integer(path: Path, fld: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(path, fld, f"expected a whole number, found {value!r}")
    if value < minimum:
        raise _fail(path, fld, f"expected a whole number >= {minimum}, found {value}")
    return value


def _file(path: Path, fld: str, value: Any) -> Path:
    if not isinstance(value, str) or not value:
        raise _fail(path, fld, f"expected a file path, found {value!r}")
    p = Path(value)
    if not p.is_absolute():
        p = path.parent / p
    if not p.is_file():
        raise _fail(path, fld, f"no such file {value!r} (looked for {p})")
    return p


def load_spec(path: str | Path) -> Spec:
    """Read and validate a campaign spec (module docstring)."""
    from replay.avoidance.registry import AVOIDERS, REGISTRY

    src = Path(path)
    try:
        text = src.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{src}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"{src}: cannot read the campaign spec ({exc})") from None
    doc = parse_yaml(text, str(src))
    if not isinstance(doc, dict):
        raise InputError(f"{src}: a campaign spec is a mapping (terrapath: 1, name, mission, ...)")
    unknown = sorted(set(doc) - set(SPEC_KEYS))
    if unknown:
        raise InputError(
            f"{src}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(SPEC_KEYS)}"
        )
    if doc.get("terrapath") != 1:
        raise _fail(
            src, "terrapath", f"expected 1 (the spec format), found {doc.get('terrapath')!r}"
        )
    name = doc.get("name")
    if not isinstance(name, str) or not name.strip():
        raise _fail(src, "name", f"expected the campaign's name, found {name!r}")
    threats_doc = doc.get("threats")
    gen_name = threats_doc.get("generator") if isinstance(threats_doc, dict) else None
    try:
        cases = case_generator(gen_name) is not None
    except PluginError as exc:  # an installed package's generator that cannot be used
        raise _fail(src, "threats.generator", str(exc)) from None
    missions: tuple[Path, ...]
    if cases:
        if "mission" in doc or "missions" in doc:
            raise _fail(
                src,
                "mission",
                f"the generator {gen_name!r} makes each case's mission: name no mission",
            )
        missions = (Path(str(gen_name)),)
    elif ("mission" in doc) == ("missions" in doc):
        raise InputError(f"{src}: give either 'mission' (one file) or 'missions' (a list)")
    elif "mission" in doc:
        missions = (_file(src, "mission", doc["mission"]),)
    else:
        items = doc["missions"]
        if not isinstance(items, list) or not items:
            raise _fail(src, "missions", f"expected a list of mission files, found {items!r}")
        missions = tuple(_file(src, f"missions[{i}]", v) for i, v in enumerate(items))
    stems = [m.stem for m in missions]
    if len(set(stems)) != len(stems):
        raise _fail(src, "missions", f"two missions share a file name ({stems}): keys name them so")
    dem = _dem(src, doc.get("dem"), missions if not cases else ())
    generator, params, rows = _threats(src, doc.get("threats"))
    _check_files(missions if not cases else (), rows, dem)
    if "winds" in doc:
        rows = _by_wind(src, doc["winds"], rows)
    avoiders = _avoiders(src, doc.get("avoiders"), [*AVOIDERS, *REGISTRY.plugin_names()])
    sensor = doc.get("sensor")
    if sensor is not None and sensor not in SENSORS:
        raise _fail(src, "sensor", f"expected one of {', '.join(SENSORS)}, found {sensor!r}")
    try:  # absent: the one sensor every avoider works with (priority: rangefinder), else radar
        sensor = sensor_for((a.name for a in avoiders), sensor)
    except InputError as exc:
        raise _fail(src, "sensor", str(exc)) from None
    runs = _integer(src, "runs", doc.get("runs"), 1)
    total = len(missions) * len(rows) * len(avoiders) * runs
    if total > MAX_RUNS:  # refused before the list of runs is made (1e9 runs filled the memory)
        raise _fail(
            src,
            "runs",
            f"{runs:,} runs of {len(missions)} mission(s) x {len(rows)} threat row(s) x "
            f"{len(avoiders)} avoider(s) make {total:,} runs; at most {MAX_RUNS:,} a campaign",
        )
    seed = _integer(src, "seed", doc.get("seed", 0), 0)
    margin = _number(src, "margin", doc.get("margin", 0.0), minimum=0.0)
    duration = doc.get("duration")
    if duration is not None:
        duration = _number(src, "duration", duration, minimum=1.0)
    sensor_range = doc.get("sensor_range")
    if sensor_range is not None:
        sensor_range = _number(src, "sensor_range", sensor_range, minimum=1.0)
    digests = {}
    if cases:  # the cases are the generator's: its name and version stand for the mission file
        g = case_generator(gen_name)
        assert g is not None
        made = f"{gen_name} v{g.version}"
        digests[str(missions[0])] = hashlib.sha256(made.encode()).hexdigest()
    for f in [
        *(m for m in missions if not cases),
        *(r.file for r in rows if r.file is not None),
    ]:
        digests[str(f)] = hashlib.sha256(f.read_bytes()).hexdigest()
    spec = Spec(
        src,
        name.strip(),
        missions,
        generator,
        params,
        rows,
        avoiders,
        sensor,
        runs,
        seed,
        margin,
        duration,
        "",
        digests,
        sensor_range,
        dem,
    )
    return replace(spec, spec_hash=spec.content_hash())


def _by_wind(src: Path, value: Any, rows: tuple[Row, ...]) -> tuple[Row, ...]:
    """Every threat row in each wind of the spec's ``winds:`` -- ``calm``, ``SPEED,FROM_DEG``
    (as ``--wind``) or a mapping ``{speed, from, up, profile, turbulence}`` -- labelled
    ``ROW@WIND`` (``40@calm``, ``40@10-270``, ``40@10-270-moderate``); the scenarios of a threat
    row are the same in every wind."""
    from replay.flight.wind import PROFILES, SEVERITIES, Wind, parse_wind

    if not isinstance(value, list) or not value:
        raise _fail(
            src, "winds", f"expected a list of winds (calm, '10,270', ...), found {value!r}"
        )
    winds: list[tuple[str, Wind | None]] = []
    for i, item in enumerate(value):
        fld = f"winds[{i}]"
        try:
            if item in ("calm", 0):
                winds.append(("calm", None))
                continue
            if isinstance(item, str):
                w = parse_wind(item)
            elif isinstance(item, dict):
                unknown = sorted(set(item) - {"speed", "from", "up", "profile", "turbulence"})
                if unknown:
                    raise InputError(
                        f"unknown key(s) {', '.join(unknown)}; allowed: speed, from, up, "
                        "profile, turbulence"
                    )
                turb = item.get("turbulence")
                if turb is not None and turb not in SEVERITIES:
                    raise InputError(f"turbulence: expected one of {', '.join(SEVERITIES)}")
                profile = item.get("profile", "uniform")
                if profile not in PROFILES:
                    raise InputError(f"profile: expected one of {', '.join(PROFILES)}")
                w = parse_wind(
                    f"{item.get('speed', 0)},{item.get('from', 0)},{item.get('up', 0)}",
                    profile,
                    turb,
                )
            else:
                raise InputError(f"expected calm, 'SPEED,FROM_DEG' or a mapping, found {item!r}")
        except InputError as exc:
            raise _fail(src, fld, str(exc)) from None
        label = f"{w.speed:g}-{w.from_deg:g}" + (f"-{w.profile}" if w.profile != "uniform" else "")
        label += f"-{w.turbulence}" if w.turbulence else ""
        winds.append((label, w))
    labels = [lab for lab, _ in winds]
    if len(set(labels)) != len(labels):
        raise _fail(src, "winds", f"a wind is given twice ({labels})")
    return tuple(
        replace(r, label=f"{r.label}@{lab}", wind=w, threat_label=r.label)
        for r in rows
        for lab, w in winds
    )


def _dem(src: Path, value: Any, missions: tuple[Path, ...]) -> tuple[str, ...]:
    """The spec's ``dem:`` (absolute paths), required when a mission is another tool's."""
    from planner.imports import FORMAT_NAMES, is_foreign, read_foreign

    tiles: tuple[str, ...] = ()
    if value is not None:
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not items:
            raise _fail(src, "dem", f"expected a list of DEM files, found {value!r}")
        tiles = tuple(str(_file(src, f"dem[{i}]", v).resolve()) for i, v in enumerate(items))
    for i, m in enumerate(missions):
        if is_foreign(m) and not tiles:
            kind = FORMAT_NAMES[read_foreign(m).format]
            fld = "mission" if len(missions) == 1 else f"missions[{i}]"
            raise _fail(
                src,
                fld,
                f"a {kind} mission holds lon/lat and names no terrain: give the spec "
                "'dem: [tile, ...]'",
            )
    return tiles


def _threats(src: Path, doc: Any) -> tuple[str | None, Params, tuple[Row, ...]]:
    if not isinstance(doc, dict):
        raise _fail(src, "threats", "expected a generator (generator, counts, ...) or files: [...]")
    unknown = sorted(set(doc) - set(THREAT_KEYS))
    if unknown:
        raise _fail(
            src,
            "threats",
            f"unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(THREAT_KEYS)}",
        )
    if ("generator" in doc) == ("files" in doc):
        raise _fail(src, "threats", "give either 'generator' (with 'counts') or 'files'")
    if "files" in doc:
        files = doc["files"]
        if not isinstance(files, list) or not files:
            raise _fail(src, "threats.files", f"expected a list of threat files, found {files!r}")
        paths = [_file(src, f"threats.files[{i}]", v) for i, v in enumerate(files)]
        labels = [p.stem for p in paths]
        if len(set(labels)) != len(labels):
            raise _fail(
                src, "threats.files", f"two files share a name ({labels}): rows are named by it"
            )
        return None, Params(), tuple(Row(p.stem, None, p) for p in paths)
    gen = doc["generator"]
    try:
        case = case_generator(gen)
        known = case is not None or threat_generator(gen) is not None
    except PluginError as exc:  # an installed package's generator that cannot be used
        raise _fail(src, "threats.generator", str(exc)) from None
    if not known:
        later = f" ({gen}: {COMING[gen]})" if gen in COMING else ""
        raise _fail(
            src,
            "threats.generator",
            f"unknown generator {gen!r}{later}; valid: {', '.join(generator_names())}",
        )
    if case is not None and case.rows == "maps":
        return gen, Params(), _map_rows(src, gen, doc)
    if "maps" in doc:
        names = [k for k in generator_names() if getattr(case_generator(k), "rows", "") == "maps"]
        takes = ", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1 else names[0]
        raise _fail(src, "threats.maps", f"only {takes} take it, not {gen!r}")
    if case is not None:
        if "counts" in doc:
            raise _fail(
                src, "threats.counts", f"{gen!r} draws its own obstacles: give 'dynamic' instead"
            )
        flags = doc.get("dynamic", [False, True])
        if not isinstance(flags, list) or not flags or not all(isinstance(f, bool) for f in flags):
            raise _fail(
                src,
                "threats.dynamic",
                f"expected a list like [false, true] (the static and the dynamic set), found "
                f"{flags!r}",
            )
        if len(set(flags)) != len(flags):
            raise _fail(src, "threats.dynamic", f"a set is repeated: {flags}")
        return gen, Params(), tuple(Row("dynamic" if f else "static", dynamic=f) for f in flags)
    if "dynamic" in doc:
        raise _fail(src, "threats.dynamic", f"only a case generator takes it, not {gen!r}")
    counts = doc.get("counts")
    if not isinstance(counts, list) or not counts:
        raise _fail(src, "threats.counts", f"expected a list of threat counts, found {counts!r}")
    values = [_integer(src, f"threats.counts[{i}]", c, 0) for i, c in enumerate(counts)]
    if len(set(values)) != len(values):
        raise _fail(src, "threats.counts", f"a count is repeated: {values}")
    box = doc.get("box")
    if box is not None:
        if not isinstance(box, list) or len(box) != 4:
            raise _fail(src, "threats.box", f"expected [xmin, ymin, xmax, ymax], found {box!r}")
        b = [_number(src, f"threats.box[{i}]", v) for i, v in enumerate(box)]
        if not (b[0] < b[2] and b[1] < b[3]):
            raise _fail(src, "threats.box", f"expected xmin < xmax and ymin < ymax, found {box}")
        box = tuple(b)
    altitude = doc.get("altitude")
    params = Params(
        sigma=_number(src, "threats.sigma", doc.get("sigma", Params.sigma), minimum=0.0),
        keep_clear=_number(
            src, "threats.keep_clear", doc.get("keep_clear", Params.keep_clear), minimum=0.0
        ),
        radius=_number(src, "threats.radius", doc.get("radius", Params.radius), minimum=0.0),
        altitude=None if altitude is None else _number(src, "threats.altitude", altitude),
        box=box,
    )
    return gen, params, tuple(Row(str(c), c) for c in values)


def _map_rows(src: Path, gen: str, doc: dict[str, Any]) -> tuple[Row, ...]:
    """A map-row generator's rows (``own-scenarios``: the maps; ``own-buildings``: the
    layouts), default every one, each present on this machine."""
    g = case_generator(gen)
    assert g is not None
    for key in ("counts", "dynamic"):
        if key in doc:
            raise _fail(src, f"threats.{key}", f"{gen!r} draws its own cases: give 'maps' instead")
    names = doc.get("maps", list(g.maps))
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise _fail(src, "threats.maps", f"expected a list of map names, found {names!r}")
    if len(set(names)) != len(names):
        raise _fail(src, "threats.maps", f"a map is repeated: {names}")
    for i, n in enumerate(names):
        try:
            if g.check is not None:
                g.check(n)
        except InputError as exc:
            raise _fail(src, f"threats.maps[{i}]", str(exc)) from None
    return tuple(Row(n, map=n) for n in names)


def _plugin_origins(avoider: str, generator: str | None) -> list[str]:
    """The installed packages a run's avoider and generator come from (``package NAME
    VERSION``; none for terrapath's own)."""
    from replay.avoidance.registry import AVOIDERS, avoider_plugin

    out = []
    if avoider not in AVOIDERS:
        out.append(f"avoider {avoider}: {avoider_plugin(avoider).origin}")
    origin = generator_origin(generator)
    if origin is not None:
        out.append(f"generator {generator}: {origin}")
    return out


def _check_files(
    missions: tuple[Path, ...], rows: tuple[Row, ...], dem: tuple[str, ...] = ()
) -> None:
    """Read every mission of another tool on the spec's DEM, and every threat file over every
    mission's map, now: a bad file is an error before the first run, not in it (lon/lat
    positions need the map)."""
    from planner.imports import is_foreign
    from replay.source import mission_on_terrain

    files = [r.file for r in rows if r.file is not None]
    if not files and not any(is_foreign(m) for m in missions):
        return
    from replay.threats.file import load_threats

    for m in missions:
        if not files and not is_foreign(m):
            continue
        _, grid, *_ = mission_on_terrain(str(m), dem if is_foreign(m) else (), None, None)
        for f in files:
            load_threats(f, grid)


def _avoiders(src: Path, doc: Any, known: Any) -> tuple[Avoider, ...]:
    from replay.avoidance import make_avoider

    if not isinstance(doc, list) or not doc:
        raise _fail(
            src,
            "avoiders",
            f"expected a list like [{{name: pso-ca}}, {{name: none}}], found {doc!r}",
        )
    out = []
    for i, item in enumerate(doc):
        fld = f"avoiders[{i}]"
        if not isinstance(item, dict) or not set(item) <= {"name", "options"}:
            raise _fail(src, fld, f"expected {{name: ..., options: {{...}}}}, found {item!r}")
        name = item.get("name")
        if not isinstance(name, str) or name not in known:
            raise _fail(src, f"{fld}.name", f"unknown avoider {name!r}; valid: {', '.join(known)}")
        options = item.get("options") or {}
        if not isinstance(options, dict) or not all(isinstance(k, str) for k in options):
            raise _fail(src, f"{fld}.options", f"expected a mapping of options, found {options!r}")
        try:  # the options are checked now, not in the first run an hour from now
            make_avoider(name, **options)
        except PluginError as exc:  # an installed package's avoider that cannot be used
            raise _fail(src, f"{fld}.name", str(exc)) from None
        except (InputError, TypeError, ValueError) as exc:
            raise _fail(src, f"{fld}.options", str(exc)) from None
        out.append(Avoider(name, tuple(sorted(options.items()))))
    labels = [a.label for a in out]
    if len(set(labels)) != len(labels):
        raise _fail(src, "avoiders", f"an avoider is listed twice: {labels}")
    return tuple(out)


__all__ = ["Avoider", "Row", "Run", "Spec", "derive_seed", "load_spec"]
