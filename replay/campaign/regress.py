"""``terrapath regress``: a named suite of campaigns flown with the avoiders asked for, each result
compared with a stored baseline (issue 39).

A suite (``suites/NAME.yaml`` beside this module, or any file in its format) lists *cases*, each a
campaign (:mod:`replay.campaign.spec`) the regression flies:

- ``mission`` + ``threats``: a fixed mission file and threat file of the suite (the reference
  maps' golden plans and threat sets, ``suites/reference/``; made by ``python -m
  tests.golden.regen --suite``).  The mission names its DEM as ``maps/<folder>/<file>``, looked up
  under the maps' folders (``--data DIR``, then the checkout's ``data/maps`` and
  ``../shared/maps``); a case whose map is not found is *skipped*, and says so.
- ``bench``: a paper's campaign (``replay/campaign/benches/NAME.yaml``), ``runs`` per line.
- ``spec``: a campaign spec written inline (the own-scenario generator at a fixed seed).

Every case is flown with the suite's avoiders, or those named (``--avoid``: built-in or plugin),
and grouped by (case, mission, row, avoider): the runs, the successes, the errors; for a single
run also its end, each threat's minimum separation and the PLR.  A group is compared with the
baseline's group of the same key (:func:`compare`):

- one run (every run is a function of its seed; tolerances are for the drift of a fresh
  install's library versions, as the golden replays' of ``tests/golden/replays.py``): a lost
  success, a threat entered that the baseline kept clear of, a separation that fell by more than
  ``max(25 m, 10 %)``, a PLR that grew by more than 2 % -- each a regression;
- several runs (random scenarios): a regression when the baseline's success rate lies above the
  upper end of the 95 % Wilson interval of the new rate (a drop the runs show, not noise);
- an error in any run is a regression; a group the baseline does not hold is *new* (a plugin's
  first run), printed beside the built-ins' baseline figures.

Outputs (``-o DIR``): the table (``regress.md``), JUnit XML (``junit.xml``: a test case per group,
a ``failure`` per regression, ``skipped`` per case whose map is missing), a picture of each
regressed single run (re-flown with its recording), the runs' store.  ``--update-baseline``
writes the figures as a new baseline beside the one compared with (a dated name, never over it).
"""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np
import yaml

from replay.campaign.own import BUNDLED, ROOT, SHARED
from terrain.docfile import parse_yaml
from terrain.errors import InputError

SUITES_DIR = Path(__file__).resolve().parent / "suites"
BENCHES_DIR = Path(__file__).resolve().parent / "benches"
# the checkout's data/, then the copy a wheel bundles (setup.py: the suite's maps and files)
DATA_DIRS = (ROOT / "data", BUNDLED)
# where a suite's maps are looked for after --data: those, then the shared ones beside the checkout
MAP_DIRS = (*(d / "maps" for d in DATA_DIRS), SHARED)

TOL_SEPARATION = (25.0, 0.10)  # metres or relative, whichever is larger
TOL_PLR = 0.02  # relative
BASELINE_FORMAT = 1


@dataclass(frozen=True)
class Case:
    """One campaign of a suite: its name, the spec file written for it (None: skipped) and why it
    was skipped."""

    name: str
    spec: Path | None
    skipped: str | None = None
    # avoiders not flown here and why: the case's sensor is not one they work with, or the case
    # names its own avoiders and not them
    unfit: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Suite:
    name: str
    title: str
    path: Path
    avoiders: tuple[str, ...]
    cases: tuple[dict[str, Any], ...]
    optimizers: tuple[str, ...] = ()
    plans: tuple[str, ...] = ()  # reference maps (planner.reference) planned by each optimiser

    @property
    def baseline(self) -> Path:
        """The baseline shipped beside the suite: ``NAME-baseline.json``."""
        return self.path.with_name(f"{self.name}-baseline.json")


def suite_names() -> list[str]:
    return sorted(p.stem for p in SUITES_DIR.glob("*.yaml"))


def load_suite(name: str) -> Suite:
    """The suite ``name`` (``suites/NAME.yaml``) or the suite file at the path ``name``."""
    path = Path(name)
    if not (path.suffix in (".yaml", ".yml") and path.is_file()):
        path = SUITES_DIR / f"{name}.yaml"
        if not path.is_file():
            raise InputError(
                f"no regression suite {name!r}; the suites: {', '.join(suite_names())} "
                "(or a suite file's path)"
            )
    doc = parse_yaml(path.read_text(encoding="utf-8"), str(path))
    if not isinstance(doc, dict) or doc.get("terrapath") != 1:
        raise InputError(f"{path}: expected a regression suite (terrapath: 1, name, cases)")
    cases = doc.get("cases")
    if not isinstance(cases, list) or not cases or not all(isinstance(c, dict) for c in cases):
        raise InputError(f"{path}: cases: expected a list of cases (mission, bench or spec)")
    for c in cases:
        kinds = [k for k in ("mission", "bench", "spec") if k in c]
        if not isinstance(c.get("name"), str) or len(kinds) != 1:
            raise InputError(
                f"{path}: case {c.get('name')!r}: expected a name and one of mission (with "
                "threats), bench or spec"
            )
    names = {}
    for key, default in (("avoiders", ["none", "pso-ca", "ctga", "fga"]), ("optimizers", [])):
        names[key] = doc.get(key, default)
        if not isinstance(names[key], list) or not all(isinstance(a, str) for a in names[key]):
            raise InputError(f"{path}: {key}: expected a list of names")
    from planner.reference import REFERENCE_MAPS

    plans = doc.get("plans", [])
    known = [m.name for m in REFERENCE_MAPS]
    if not isinstance(plans, list) or any(p not in known for p in plans):
        raise InputError(f"{path}: plans: expected reference maps among {', '.join(known)}")
    return Suite(
        name=str(doc.get("name") or path.stem),
        title=str(doc.get("title", "")),
        path=path,
        avoiders=tuple(names["avoiders"]),
        cases=tuple(cases),
        optimizers=tuple(names["optimizers"]),
        plans=tuple(plans),
    )


def only_cases(suite: Suite, names: Sequence[str]) -> Suite:
    """The suite with only the cases named (each one of its cases or of the maps it plans)."""
    known = [c["name"] for c in suite.cases]
    unknown = [n for n in names if n not in known and n not in suite.plans]
    if unknown:
        raise InputError(
            f"--case: no case {', '.join(map(repr, unknown))} in the suite {suite.name!r}; "
            f"its cases: {', '.join(known)}; its plans: {', '.join(suite.plans)}"
        )
    return replace(
        suite,
        cases=tuple(c for c in suite.cases if c["name"] in names),
        plans=tuple(p for p in suite.plans if p in names),
    )


def find_map(relative: str, data: Sequence[Path]) -> Path | None:
    """``maps/<folder>/<file>`` under each of ``data`` (as ``DIR/<folder>/<file>`` or
    ``DIR/maps/<folder>/<file>``), then under :data:`MAP_DIRS`; None when nowhere."""
    rel = Path(relative)
    inner = Path(*rel.parts[1:]) if rel.parts and rel.parts[0] == "maps" else rel
    for d in [*data, *MAP_DIRS]:
        for candidate in (d / inner, d / "maps" / inner):
            if candidate.is_file():
                return candidate.resolve()
    return None


def prepare(
    suite: Suite,
    avoiders: Sequence[str],
    work: Path,
    data: Sequence[Path],
    *,
    named: bool = True,
) -> list[Case]:
    """Write each case's campaign spec into ``work`` (its mission's DEM resolved) and return the
    cases, those whose maps are missing marked skipped; an avoider that does not work with a
    case's sensor, or that the case does not name (its ``avoiders``, when it has them: seed
    003's rooms are the priority loop's), is not flown there (the case says why); with
    ``named`` false (no --avoid) such a case flies its own avoiders."""
    work.mkdir(parents=True, exist_ok=True)
    here = suite.path.parent
    out: list[Case] = []
    for c in suite.cases:
        name = c["name"]
        spec_path = work / f"{name}.yaml"
        if "bench" in c:
            bench = BENCHES_DIR / f"{c['bench']}.yaml"
            if not bench.is_file():
                raise InputError(f"{suite.path}: case {name!r}: no bench {c['bench']!r}")
            doc = parse_yaml(bench.read_text(encoding="utf-8"), str(bench))
            doc = _absolute(doc, bench.parent)
            doc["name"] = f"{suite.name}-{name}"
            if "runs" in c:
                doc["runs"] = int(c["runs"])
        elif "spec" in c:
            doc = {"terrapath": 1, **_absolute(dict(c["spec"]), here)}
            doc["name"] = f"{suite.name}-{name}"
            doc.setdefault("seed", 0)
        else:
            mission_src = here / c["mission"]
            mission = parse_yaml(mission_src.read_text(encoding="utf-8"), str(mission_src))
            tiles = (mission.get("terrain") or {}).get("dem") or []
            found = [find_map(t, data) for t in tiles]
            if any(f is None for f in found):
                missing = ", ".join(t for t, f in zip(tiles, found, strict=True) if f is None)
                out.append(Case(name, None, f"map not found: {missing} (give --data DIR)"))
                continue
            mission["terrain"]["dem"] = [str(f) for f in found]
            (work / f"{name}-mission.yaml").write_text(
                yaml.safe_dump(mission, sort_keys=False, default_flow_style=None),
                encoding="utf-8",
            )
            shutil.copyfile(here / c["threats"], work / f"{name}-threats.yaml")
            doc = {
                "terrapath": 1,
                "name": f"{suite.name}-{name}",
                "mission": f"{name}-mission.yaml",
                "threats": {"files": [f"{name}-threats.yaml"]},
                "sensor": c.get("sensor", "radar"),
                "runs": 1,
                "seed": int(c.get("seed", 0)),
            }
        sensor = str(doc.get("sensor", "radar"))
        meant = c.get("avoiders")  # the avoiders a case is made for (the others not flown)
        asked = list(meant) if meant is not None and not named else list(avoiders)
        reasons = {a: _why_not(a, meant, sensor) for a in asked}
        unfit = tuple((a, why) for a, why in reasons.items() if why is not None)
        doc["avoiders"] = [{"name": a} for a, why in reasons.items() if why is None]
        if not doc["avoiders"]:
            out.append(Case(name, None, "no avoider asked for is one it flies", unfit))
            continue
        spec_path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
        out.append(Case(name, spec_path, None, unfit))
    return out


def _why_not(avoider: str, meant: Sequence[str] | None, sensor: str) -> str | None:
    """Why ``avoider`` is not flown in a case made for ``meant`` (None: any) with ``sensor``;
    None when it is."""
    from replay.avoidance.registry import avoider_entry

    if meant is not None and avoider not in meant:
        return f"the case is for {', '.join(meant)}"
    works = avoider_entry(avoider).sensors
    if sensor not in works:
        return f"it works with {', '.join(works)}; the case's sensor is {sensor}"
    return None


def _absolute(doc: dict[str, Any], base: Path) -> dict[str, Any]:
    """The spec's mission and threat files as absolute paths (it is written elsewhere); a file
    of the checkout's ``data/`` that is not there (an installed terrapath) from the bundled
    copy (:data:`DATA_DIRS`)."""
    out = dict(doc)
    if isinstance(out.get("mission"), str):
        out["mission"] = _data_file(base, out["mission"])
    if isinstance(out.get("missions"), list):
        out["missions"] = [_data_file(base, m) for m in out["missions"]]
    threats = out.get("threats")
    if isinstance(threats, dict) and isinstance(threats.get("files"), list):
        out["threats"] = {**threats, "files": [_data_file(base, f) for f in threats["files"]]}
    return out


def _data_file(base: Path, rel: str) -> str:
    path = (base / rel).resolve()
    parts = Path(rel).parts
    if not path.exists() and "data" in parts:
        inner = Path(*parts[parts.index("data") + 1 :])
        for d in DATA_DIRS:
            if (d / inner).exists():
                return str(d / inner)
    return str(path)


# -- figures and comparison ---------------------------------------------------------------------


@dataclass
class Group:
    """The runs of one (case, mission, row, avoider)."""

    key: str
    case: str
    avoider: str
    runs: int = 0
    successes: int = 0
    errors: list[str] = field(default_factory=list)
    end_reason: str | None = None
    min_separation: dict[str, float] | None = None
    plr: float | None = None
    run_keys: list[str] = field(default_factory=list)

    def figures(self) -> dict[str, Any]:
        out: dict[str, Any] = {"runs": self.runs, "successes": self.successes}
        if self.runs == 1 and not self.errors:
            out.update(end_reason=self.end_reason, min_separation=self.min_separation, plr=self.plr)
        return out


def groups(case: str, rows: Iterable[dict[str, Any]]) -> dict[str, Group]:
    """The rows of a case's campaign by (case, mission, row, avoider)."""
    out: dict[str, Group] = {}
    for r in rows:
        key = f"{case}/{r['mission']}/{r['row']}/{r['avoider']}"
        g = out.setdefault(key, Group(key, case, r["avoider"]))
        g.runs += 1
        g.run_keys.append(r["key"])
        if r["status"] != "ok":
            g.errors.append(f"{r['key']}: {r.get('error')}")
            continue
        g.successes += bool(r["success"])
        m = r.get("metrics") or {}
        g.end_reason = r.get("end_reason")
        g.min_separation = {
            k: float(v["value"] if isinstance(v, dict) else v)
            for k, v in (m.get("min_separation") or {}).items()
        }
        plr = m.get("plr")
        g.plr = float(plr) if isinstance(plr, int | float) and math.isfinite(plr) else None
    return out


TOL_COST = 0.03  # relative: a plan's cost may grow this much (the golden plans' tolerance)
PLAN_VEHICLE = "aerosonde"


def reference_request(ref: Any, algorithm: str = "ampso", dem: Path | None = None) -> Any:
    """The plan request of the reference map ``ref`` (:class:`planner.reference.ReferenceMap`)
    as ``terrapath plan`` makes it: the aerosonde at its cruise speed, the zones as hard
    constraints, seed 0 and the plan's defaults (the golden plans' and regress's); ``dem``: where
    its DEM is found (default the map's own path)."""
    from planner.pipeline import PlanRequest
    from replay.flight.fixedwing.presets import load_vehicle

    return PlanRequest(
        dem=(str(dem or ref.dem),),
        start=ref.start,
        goal=ref.goal,
        performance=load_vehicle(PLAN_VEHICLE).performance(),
        vehicle=PLAN_VEHICLE,
        zones=[{"lon": a, "lat": b, "diameter": d} for a, b, d in ref.zones],
        algorithm=algorithm,
        seed=0,
        avoid_zones=True,
    )


def _planned(name: str, algorithm: str, data: Sequence[Path]) -> tuple[Any, Any] | str:
    """The reference map ``name`` prepared and planned by ``algorithm``
    (:func:`reference_request`): (the prepared problem, the plan's result), or why it cannot be
    planned here (its map is missing)."""
    from planner.pipeline import build_problem, plan_request
    from planner.reference import REFERENCE_MAPS

    ref = next(m for m in REFERENCE_MAPS if m.name == name)
    dem = find_map(f"maps/{ref.dem.parent.name}/{ref.dem.name}", data)
    if dem is None:
        return f"map not found: maps/{ref.dem.parent.name}/{ref.dem.name} (give --data DIR)"
    request = reference_request(ref, algorithm, dem)
    prepared = build_problem(request)
    return prepared, plan_request(request, prepared.problem)


def plan_group(name: str, algorithm: str, data: Sequence[Path]) -> Group | str:
    """The reference map ``name`` planned by ``algorithm`` (:func:`_planned`): a group of one
    run (success: feasible; ``plr`` holds the cost), or why it cannot be planned here."""
    key = f"plan/{name}/{algorithm}"
    g = Group(key, "plan", algorithm, runs=1, end_reason="planned", run_keys=[key])
    try:
        got = _planned(name, algorithm, data)
    except Exception as exc:  # an optimiser that breaks its contract: the group's error
        g.errors.append(f"{key}: {type(exc).__name__}: {exc}")
        return g
    if isinstance(got, str):
        return got
    r = got[1]
    g.successes = int(bool(r.feasible))
    g.plr = float(r.terms["total"])  # the cost, compared as the PLR is (lower is better)
    g.min_separation = {}
    return g


def plan_picture(name: str, algorithm: str, data: Sequence[Path], out: Path) -> Path | None:
    """The picture of a regressed plan (planned again: a plan is a function of its seed): the
    map with the path and the zones, and its profile (``terrapath plan``'s picture)."""
    from planner.plot import save_plan_picture

    got = _planned(name, algorithm, data)
    if isinstance(got, str):
        return None
    prepared, r = got
    status = r.status if r.feasible else r.status.upper()
    return save_plan_picture(
        prepared.grid,
        np.asarray(r.path),
        out,
        prepared.zones,
        title=f"{name}: {algorithm}, seed {r.seed} — {status}, cost {r.terms['total']:.4f}",
        clearance=prepared.problem.clearance,
        feasible=r.feasible,
    )


@dataclass(frozen=True)
class Verdict:
    status: str  # "ok", "improved", "regressed", "new", "error"
    reasons: tuple[str, ...] = ()

    @property
    def failed(self) -> bool:
        return self.status in ("regressed", "error")


def baseline_key(key: str, against: str | None = None) -> str:
    """The baseline's key of a group: its own, or with its avoider replaced by ``against``."""
    return key if against is None else f"{key.rsplit('/', 1)[0]}/{against}"


def compare(g: Group, base: dict[str, Any] | None) -> Verdict:
    """The group against its baseline figures (module docstring)."""
    from replay.campaign.runner import wilson

    if g.errors:
        return Verdict("error", tuple(g.errors))
    if base is None:
        return Verdict("new")
    reasons: list[str] = []
    better: list[str] = []
    if g.runs == 1 and base.get("runs") == 1:
        was, now = bool(base["successes"]), bool(g.successes)
        if was and not now:
            lost = "feasibility lost" if g.case == "plan" else f"success lost (end: {g.end_reason})"
            reasons.append(lost)
        elif now and not was:
            better.append("succeeds now")
        for ident, sep in (base.get("min_separation") or {}).items():
            got = (g.min_separation or {}).get(ident)
            if got is None:
                reasons.append(f"{ident}: no separation recorded (baseline {sep:.0f} m)")
                continue
            if sep >= 0 > got:
                reasons.append(f"{ident} entered: separation {got:.0f} m (baseline {sep:.0f} m)")
            elif sep >= 0 and got < sep - max(TOL_SEPARATION[0], TOL_SEPARATION[1] * abs(sep)):
                reasons.append(f"{ident} separation {got:.0f} m (baseline {sep:.0f} m)")
        plr0 = base.get("plr")
        tol, what = (TOL_COST, "cost") if g.case == "plan" else (TOL_PLR, "PLR")
        if was and now and plr0 is not None and g.plr is not None and g.plr > plr0 * (1 + tol):
            reasons.append(f"{what} {g.plr:.3f} (baseline {plr0:.3f})")
    else:
        k0, n0 = int(base["successes"]), int(base["runs"])
        rate0 = k0 / n0 if n0 else 0.0
        lo, hi = wilson(g.successes, g.runs)
        if hi < rate0:
            reasons.append(
                f"success {g.successes}/{g.runs} (95 % CI {100 * lo:.0f}-{100 * hi:.0f} %) "
                f"below the baseline's {k0}/{n0}"
            )
        elif lo > rate0:
            better.append(f"success {g.successes}/{g.runs} above the baseline's {k0}/{n0}")
    if reasons:
        return Verdict("regressed", tuple(reasons))
    return Verdict("improved", tuple(better)) if better else Verdict("ok")


# -- baseline -----------------------------------------------------------------------------------


def read_baseline(path: Path) -> dict[str, dict[str, Any]]:
    """The groups' figures of a baseline file ({} when it does not exist)."""
    if not path.is_file():
        return {}
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a regression baseline ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != BASELINE_FORMAT:
        raise InputError(f"{path}: format: expected {BASELINE_FORMAT} (a regress baseline)")
    groups_doc = doc.get("groups")
    if not isinstance(groups_doc, dict):
        raise InputError(f"{path}: groups: expected the figures of each group")
    return groups_doc


def new_baseline_path(old: Path, now: datetime | None = None) -> Path:
    """A dated name beside ``old`` that exists nowhere yet (never ``old`` itself)."""
    stamp = (now or datetime.now(UTC)).strftime("%Y%m%d-%H%M%S")
    stem = old.stem
    path = old.with_name(f"{stem}-{stamp}.json")
    n = 1
    while path.exists():
        path = old.with_name(f"{stem}-{stamp}-{n}.json")
        n += 1
    return path


def baseline_doc(
    suite: Suite, found: dict[str, Group], old: dict[str, dict[str, Any]], meta: dict[str, Any]
) -> dict[str, Any]:
    """The new baseline: the old groups, with the groups flown now in their place."""
    merged = dict(old)
    merged.update({k: g.figures() for k, g in found.items() if not g.errors})
    return {"format": BASELINE_FORMAT, "suite": suite.name, **meta, "groups": merged}


# -- outputs ------------------------------------------------------------------------------------


def table(
    found: dict[str, Group],
    verdicts: dict[str, Verdict],
    base: dict[str, dict[str, Any]],
    beside: dict[str, dict[str, Any]] | None = None,
) -> list[list[str]]:
    """The rows of the printed table: group, runs, success, worst separation, PLR, the
    baseline's success (``base``: by the flown group's key), the verdict; after each case's row
    of the study, the groups of ``beside`` (the whole baseline) of the avoiders not flown there,
    marked ``(baseline)``: a new avoider's figures beside the built-ins'."""
    rows = [
        [
            "case / mission / row",
            "avoider",
            "success",
            "worst sep",
            "PLR/cost",
            "baseline",
            "verdict",
        ]
    ]

    def figures(runs: int, seps: dict[str, float] | None, plr: float | None) -> list[str]:
        threats = [v for k, v in (seps or {}).items() if not k.startswith("zone:")]
        worst = f"{min(threats):.0f} m" if runs == 1 and threats else "-"
        return [worst, f"{plr:.3f}" if runs == 1 and plr is not None else "-"]

    wheres: dict[str, list[str]] = {}
    for key in found:
        wheres.setdefault(key.rsplit("/", 1)[0], []).append(key)
    for where, keys in wheres.items():
        for key in keys:
            g = found[key]
            b = base.get(key)
            fig = figures(g.runs, g.min_separation, g.plr) if not g.errors else ["-", "-"]
            was = f"{b['successes']}/{b['runs']}" if b else "-"
            rows.append(
                [where, g.avoider, f"{g.successes}/{g.runs}", *fig, was, verdicts[key].status]
            )
        flown = {found[k].avoider for k in keys}
        for key, b in (beside or {}).items():
            where_b, avoider = key.rsplit("/", 1)
            if where_b == where and avoider not in flown:
                fig = figures(int(b["runs"]), b.get("min_separation"), b.get("plr"))
                done = f"{b['successes']}/{b['runs']}"
                rows.append([where, avoider, done, *fig, done, "(baseline)"])
    return rows


def format_table(rows: list[list[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join(
        "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows
    )


def markdown(rows: list[list[str]]) -> str:
    head, *body = rows
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(r) + " |" for r in body]
    return "\n".join(lines) + "\n"


def junit_xml(
    suite: Suite,
    found: dict[str, Group],
    verdicts: dict[str, Verdict],
    skipped: Sequence[Case],
    seconds: float,
    unfit: Sequence[Case] = (),
) -> bytes:
    """JUnit XML: a ``testsuite`` for the suite, a ``testcase`` per group (``failure`` when it
    regressed, ``error`` when a run failed to fly) and per skipped case."""
    failures = sum(v.status == "regressed" for v in verdicts.values())
    errors = sum(v.status == "error" for v in verdicts.values())
    unfit = [c for c in unfit if c.spec is not None]  # a skipped case is one skip
    n_skipped = len(skipped) + sum(len(c.unfit) for c in unfit)
    root = ET.Element("testsuites")
    ts = ET.SubElement(
        root,
        "testsuite",
        name=f"terrapath regress {suite.name}",
        tests=str(len(found) + n_skipped),
        failures=str(failures),
        errors=str(errors),
        skipped=str(n_skipped),
        time=f"{seconds:.1f}",
    )
    for key, g in found.items():
        tc = ET.SubElement(ts, "testcase", classname=f"{suite.name}.{g.case}", name=key)
        v = verdicts[key]
        if v.status == "regressed":
            el = ET.SubElement(tc, "failure", message="; ".join(v.reasons), type="regression")
            el.text = "\n".join(v.reasons)
        elif v.status == "error":
            el = ET.SubElement(tc, "error", message=v.reasons[0][:200], type="error")
            el.text = "\n".join(v.reasons)
        else:
            out = ET.SubElement(tc, "system-out")
            out.text = f"{v.status}: {g.successes}/{g.runs} succeeded"
    for c in skipped:
        tc = ET.SubElement(ts, "testcase", classname=f"{suite.name}.{c.name}", name=c.name)
        ET.SubElement(tc, "skipped", message=c.skipped or "skipped")
    for c in unfit:
        for avoider, why in c.unfit:
            tc = ET.SubElement(
                ts, "testcase", classname=f"{suite.name}.{c.name}", name=f"{c.name}/{avoider}"
            )
            ET.SubElement(tc, "skipped", message=f"{avoider} not flown: {why}")
    ET.indent(root)
    return b'<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="utf-8")


__all__ = [
    "BASELINE_FORMAT",
    "SUITES_DIR",
    "Case",
    "Group",
    "Suite",
    "Verdict",
    "baseline_doc",
    "baseline_key",
    "compare",
    "find_map",
    "format_table",
    "groups",
    "junit_xml",
    "load_suite",
    "markdown",
    "new_baseline_path",
    "only_cases",
    "plan_group",
    "plan_picture",
    "prepare",
    "read_baseline",
    "reference_request",
    "suite_names",
    "table",
]
