"""``terrapath bench NAME``: one paper table each, as campaign specs shipped beside this module
(``benches/*.yaml``, missions and threats from the source checkout's ``data/``) and the paper's
figures (:mod:`replay.campaign.papers`); our figures beside the paper's, row by row, with the
ratio.

- ``seed000-table4``: the Table 4 obstacles, PSO-CA with PSO / MAFOA / GA / SA: the optimised
  path length (the final waypoint list's) and the algorithm time per run (the decisions' compute
  time), over the successful runs.
- ``seed000-table6``: obstacles N(waypoint, 3 km) round the 8-hour mission, 1-100 of them, plus
  "40 + 1 hill" and "40 + 2 intruders": Table 3 for PSO (flight time, algorithm time per run,
  optimised path length, success) and Table 6 at 40-100 obstacles per optimiser (PLR, TC, SR).
  Our PLR is the flight's (flown length over the straight distance); the paper's is larger
  (1.28 at 40 obstacles) and not defined in the text -- the ratio is shown, not judged.
  ``--optimizers`` chooses the optimisers (default PSO: Table 3).
- ``seed002-table2``: the planners (AMPSO, APSO, PSO, GA) 10 times each on our reference maps:
  cost mean +- sd and the rank of each algorithm's mean, beside its ranks on the paper's three
  terrains (which we do not have: the costs themselves are not comparable, the order is), and
  how many of its runs end within 2 % of the lowest cost any run reached on the map (issue 20).
- ``seed001-scenarios``: CTGA beside PSO-CA in seed 001's three scenarios (cooperative sensor):
  success and the smallest separation from an obstacle's surface (paper: about R_safe, 100 m).
- ``seed004-table3`` / ``seed004-table4``: FGA in 5000 seed 004 cases each (static cylinders /
  moving aircraft, :mod:`replay.campaign.seed004`): the success rate per number of true hazards
  beside the paper's rows, overall, and FGA's time per case and per decision.
- ``seed003-uncharted``: seed 003's four uncharted scenarios (convex, U trap, corridor, box:
  ``data/scenarios/priority-*.yaml``), the priority loop beside PSO-CA, CTGA and FGA given the
  same rangefinder picture: per scenario and avoider the outcome beside the right one (the
  target for three, "target unreachable" for the box, where a success rate means nothing), the
  path-length ratio (flown / straight start-target), the flight time and the end reason; a run
  that fails to fly is shown with its error.  No paper figures: its columns are the right
  outcome and whether the run's is it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from replay.campaign import papers as P
from replay.campaign.report import mean_sd, row_order

HERE = Path(__file__).resolve().parent / "benches"
Line = tuple[str, str, str, str, str, str]  # row, avoider, figure, ours, paper, ratio


@dataclass(frozen=True)
class Bench:
    """A paper table: campaign specs and the lines of their rows (``lines``), or -- a planning
    table -- ``plans(runs)`` computing its lines directly (no replays, no store)."""

    name: str
    title: str
    specs: tuple[str, ...]  # files in benches/
    lines: Callable[[list[dict[str, Any]]], list[Line]]
    optimizers: tuple[str, ...] | None = None  # default choice (None: every avoider)
    plans: Callable[[int], list[Line]] | None = None
    columns: tuple[str, str] = ("paper", "ours / paper")  # the 5th and 6th columns' heads

    def spec_paths(self) -> list[Path]:
        return [HERE / s for s in self.specs]


def _mean(values: Sequence[float | None]) -> float | None:
    ms = mean_sd(values)
    return None if ms is None else ms[0]


def _ratio(ours: float | None, paper: float | None) -> str:
    if ours is None or paper is None or paper == 0:
        return "-"
    r = ours / paper
    return f"{r:.3f}" if 0.01 <= abs(r) < 100 else f"{r:.3g}"  # 0.999, not 1; 0.000179, not 0.000


def _num(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def optimizer_of(avoider_label: str) -> str:
    """``pso-ca[optimizer=ga]`` -> ``ga``; any other label by its avoider's name
    (``fga[d_m=3]`` -> ``fga``)."""
    if "optimizer=" in avoider_label:
        return avoider_label.split("optimizer=", 1)[1].split(",")[0].rstrip("]")
    return avoider_label.split("[", 1)[0]


def _groups(rows: list[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    out: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        label = r["row"]
        if r["spec_name"].endswith("-hill"):
            label = f"{label} + 1 hill"
        elif r["spec_name"].endswith("-intruders"):
            label = f"{label} + 2 intruders"
        out.setdefault((label, r["avoider"]), []).append(r)
    return out


def _figures(runs: list[dict[str, Any]]) -> dict[str, Any]:
    ok = [r for r in runs if r["status"] == "ok"]
    wins = [r for r in ok if r["success"]]
    m = [r["metrics"] for r in wins]
    return {
        "sr": f"{len(wins)}/{len(ok)}",
        "wins": len(wins),
        "n": len(ok),
        "length": _mean([x.get("waypoint_list_length_m") for x in m]),
        "algo_s": _mean(
            [(x.get("decisions") or 0) * (x.get("decision_time_mean_s") or 0.0) for x in m]
        ),
        "flight_min": _mean([x["flight_time_s"] / 60.0 for x in m]),
        "plr": _mean([x["plr"] for x in m]),
        "min_sep": _mean(
            [
                min(
                    (
                        v["value"]
                        for v in x["min_separation"].values()
                        if v.get("value") is not None
                    ),
                    default=math.inf,
                )
                for x in (r["metrics"] for r in ok)
            ]
        ),
    }


def _vs(row: str, av: str, figure: str, ours: float | None, paper: float | None, fmt: str) -> Line:
    """One figure of ours beside the paper's, with the ratio."""
    return (row, av, figure, _num(ours, fmt), _num(paper, fmt), _ratio(ours, paper))


def _table4(rows: list[dict[str, Any]]) -> list[Line]:
    out: list[Line] = []
    for (row, av), runs in sorted(_groups(rows).items()):
        f = _figures(runs)
        opt = optimizer_of(av)
        out.append((row, opt, "success", f["sr"], "-", "-"))
        out.append(_vs(row, opt, "path length (m)", f["length"], P.PAPER_TABLE4.get(opt), ",.0f"))
        t = P.PAPER_TABLE4_S.get(opt)
        out.append(_vs(row, opt, "algorithm time (s/run)", f["algo_s"], t, ".3g"))
    return out


def _table6(rows: list[dict[str, Any]]) -> list[Line]:
    out: list[Line] = []

    def order(item: tuple[tuple[str, str], Any]) -> tuple[bool, str, tuple[int, str]]:
        (row, av), _ = item
        return (optimizer_of(av) != "pso", optimizer_of(av), row_order(row))

    for (row, av), runs in sorted(_groups(rows).items(), key=order):
        f = _figures(runs)
        opt = optimizer_of(av)
        paper_sr = P.paper_sr_pso(int(row.split()[0])) if opt == "pso" else "-"
        out.append((row, opt, "success", f["sr"], paper_sr, "-"))
        if opt == "pso" and row in P.PAPER_TABLE3:
            fl, alg, length = P.PAPER_TABLE3[row]
            out.append(_vs(row, opt, "flight time (min)", f["flight_min"], fl, ".1f"))
            out.append(_vs(row, opt, "algorithm time (s/run)", f["algo_s"], alg, ".3g"))
            out.append(_vs(row, opt, "path length (m)", f["length"], length, ",.0f"))
        t6 = P.PAPER_TABLE6.get((row, opt))
        if t6 is not None:
            plr, tc, _cs, sr = t6
            rate = f["wins"] / f["n"] if f["n"] else None
            out.append(_vs(row, opt, "PLR (ours: the flight's)", f["plr"], plr, ".3f"))
            out.append(_vs(row, opt, "TC (s/run)", f["algo_s"], tc, ".3g"))
            out.append(_vs(row, opt, "SR (Table 6, rate)", rate, sr / 10, ".2f"))
    return out


def _seed001(rows: list[dict[str, Any]]) -> list[Line]:
    out: list[Line] = []
    for (row, av), runs in sorted(_groups(rows).items()):
        f = _figures(runs)
        paper = P.PAPER_SEED001_SEPARATION_M if av == "ctga" else None
        name = row.removeprefix("seed001-").removesuffix("-threats")
        out.append((name, av, "success", f["sr"], "-", "-"))
        out.append(_vs(name, av, "smallest separation (m)", f["min_sep"], paper, ".1f"))
    return out


def _seed004(paper: dict[str, tuple[int, int]]) -> Callable[[list[dict[str, Any]]], list[Line]]:
    """Seed 004 Table III / IV: the success rate by the number of true hazards per case, ours
    beside the paper's rows, then overall; FGA's compute time per case and per decision."""
    from replay.campaign.seed004 import hazard_bin

    def lines(rows: list[dict[str, Any]]) -> list[Line]:
        ok = [r for r in rows if r["status"] == "ok"]
        out: list[Line] = []
        for label, (cases, wins) in paper.items():
            mine = [r for r in ok if hazard_bin(r["metrics"]["case"]["hazards"]) == label]
            n, k = len(mine), sum(bool(r["success"]) for r in mine)
            rate = 100.0 * k / n if n else None
            out.append((label, "fga", "cases", str(n), str(cases), "-"))
            out.append(_vs(label, "fga", "success (%)", rate, 100.0 * wins / cases, ".1f"))
        n, k = len(ok), sum(bool(r["success"]) for r in ok)
        total = sum(c for c, _ in paper.values())
        won = sum(w for _, w in paper.values())
        out.append(("all", "fga", "cases", str(n), str(total), "-"))
        out.append(
            _vs(
                "all",
                "fga",
                "success (%)",
                100.0 * k / n if n else None,
                100.0 * won / total,
                ".2f",
            )
        )
        m = [r["metrics"] for r in ok]
        per_case = _mean([x.get("avoider_time_s", 0.0) for x in m])
        out.append(
            _vs("all", "fga", "FGA time (s/case)", per_case, P.PAPER_SEED004_S_PER_CASE, ".3g")
        )
        calls = sum(x.get("avoider_calls", 0) for x in m)
        mean_ms = 1000.0 * sum(x.get("avoider_time_s", 0.0) for x in m) / calls if calls else None
        out.append(("all", "fga", "time per decision (ms, mean)", _num(mean_ms, ".3f"), "-", "-"))
        worst = max((x.get("avoider_time_max_s", 0.0) for x in m), default=None)
        out.append(
            (
                "all",
                "fga",
                "time per decision (ms, max)",
                _num(None if worst is None else 1000 * worst, ".2f"),
                "-",
                "-",
            )
        )
        return out

    return lines


# seed 003's scenarios in the table's order; the right outcome of each is the target, but the
# box round it is closed
# the option that sets how far each avoider keeps from what it sees (seed003-uncharted flies two)
SAFETY_OPTION = {"pso-ca": "rs", "ctga": "r_safe", "fga": "d_m"}


def _safety_label(avoider_label: str) -> str:
    """``ctga[piece_m=2,r_safe=10,...]`` -> ``ctga r_safe=10``; the priority loop by its name."""
    name = optimizer_of(avoider_label)
    key = SAFETY_OPTION.get(name)
    if key is None or "[" not in avoider_label:
        return name
    options = dict(
        kv.split("=", 1) for kv in avoider_label.split("[", 1)[1].rstrip("]").split(",") if kv
    )
    return f"{name} {key}={options[key]}" if key in options else name


SEED003_SCENARIOS = ("priority-convex", "priority-u-trap", "priority-corridor", "priority-box")
SEED003_UNREACHABLE = ("priority-box",)


def _seed003(rows: list[dict[str, Any]]) -> list[Line]:
    """Seed 003's uncharted scenarios: the outcome of each (scenario, avoider) beside the right
    one, its path-length ratio, flight time and end reason (an error's message instead)."""
    groups = _groups(rows)
    scenarios = [*SEED003_SCENARIOS, *sorted({row for row, _ in groups} - set(SEED003_SCENARIOS))]

    def key(item: tuple[tuple[str, str], Any]) -> tuple[int, bool, str, float]:
        (row, av), _ = item
        name, _, value = _safety_label(av).partition("=")
        return (scenarios.index(row), optimizer_of(av) != "priority", name, float(value or 0))

    out: list[Line] = []
    for (row, av), runs in sorted(groups.items(), key=key):
        name = row.removeprefix("priority-")
        short = _safety_label(av)
        closed = row in SEED003_UNREACHABLE
        right = "target unreachable" if closed else "goal"
        for r in runs:
            if r["status"] != "ok":
                out.append((name, short, "outcome", f"error: {r['error']}", right, "wrong"))
                continue
            m = r["metrics"]
            reason = str(r["end_reason"])
            got = reason.startswith("target unreachable") if closed else bool(r["success"])
            hit = bool(m["violations"]) or (reason == "goal" and not r["success"])
            outcome = f"{reason}, through an obstacle" if hit else reason
            out.append((name, short, "outcome", outcome, right, "right" if got else "wrong"))
            if not closed:
                out.append((name, short, "success", "1/1" if r["success"] else "0/1", "-", "-"))
            out.append((name, short, "PLR (flown / straight)", _num(m["plr"], ".3f"), "-", "-"))
            out.append((name, short, "flight time (s)", _num(m["flight_time_s"], ".1f"), "-", "-"))
            sep = min(
                (v["value"] for v in m["min_separation"].values() if v.get("value") is not None),
                default=None,
            )
            out.append((name, short, "smallest separation (m)", _num(sep, ".2f"), "-", "-"))
    return out


PLAN_ALGORITHMS = ("ampso", "apso", "pso", "ga")


def _seed002(runs: int) -> list[Line]:
    """Seed 002 Table 2's protocol on our reference maps (``planner.reference``): each algorithm
    ``runs`` times (seeds 0..runs-1) with the ``terrapath plan`` defaults; the cost's mean and
    standard deviation, and its rank on the map, beside the paper's ranks on its three maps."""
    from planner.pipeline import PlanRequest, build_problem
    from planner.plan import plan
    from planner.reference import REFERENCE_MAPS
    from replay.flight.fixedwing.presets import load_vehicle

    paper_rank = {
        terrain: sorted(PLAN_ALGORITHMS, key=lambda a: costs[a][0]).index
        for terrain, costs in P.PAPER_SEED002_TABLE2.items()
    }
    out: list[Line] = []
    for m in REFERENCE_MAPS:
        if not m.available():
            out.append((m.name, "-", "map not found", str(m.dem), "-", "-"))
            continue
        request = PlanRequest(
            dem=(str(m.dem),),
            start=m.start,
            goal=m.goal,
            performance=load_vehicle("aerosonde").performance(),
            vehicle="aerosonde",
            zones=[{"lon": a, "lat": b, "diameter": d} for a, b, d in m.zones],
            avoid_zones=True,
        )
        problem = build_problem(request).problem
        stats = {}
        all_costs: dict[str, list[float]] = {}
        for alg in PLAN_ALGORITHMS:
            costs = all_costs[alg] = [
                plan(
                    problem,
                    alg,
                    seed=k,
                    population=request.population,
                    iterations=request.iterations,
                ).terms["total"]
                for k in range(runs)
            ]
            mean = sum(costs) / len(costs)
            sd = math.sqrt(sum((c - mean) ** 2 for c in costs) / max(1, len(costs) - 1))
            stats[alg] = (mean, sd)
        ranked = sorted(PLAN_ALGORITHMS, key=lambda a: stats[a][0])
        for alg in PLAN_ALGORITHMS:
            mean, sd = stats[alg]
            ranks = "/".join(str(paper_rank[t](alg) + 1) for t in P.PAPER_SEED002_TABLE2)
            out.append((m.name, alg, "cost mean ± sd", f"{mean:.4f} ± {sd:.4f}", "-", "-"))
            out.append(
                (m.name, alg, "rank of the mean (1 best)", str(ranked.index(alg) + 1), ranks, "-")
            )
        best = min(min(c) for c in all_costs.values())
        for alg in PLAN_ALGORITHMS:
            near = sum(c <= best * 1.02 for c in all_costs[alg])
            out.append(
                (m.name, alg, f"runs within 2 % of the map's best ({best:.4f})",
                 f"{near}/{runs}", "-", "-")
            )  # fmt: skip
    return out


BENCHES: dict[str, Bench] = {
    b.name: b
    for b in (
        Bench(
            "seed000-table4",
            "seed 000 Table 4 (PSO-CA, the Table 4 obstacles)",
            ("seed000-table4.yaml",),
            _table4,
        ),
        Bench(
            "seed000-table6",
            "seed 000 Tables 3 and 6 (PSO-CA, 1-100 random obstacles, hill, intruders)",
            ("seed000-table6.yaml", "seed000-table6-hill.yaml", "seed000-table6-intruders.yaml"),
            _table6,
            optimizers=("pso",),
        ),
        Bench(
            "seed002-table2",
            "seed 002 Table 2 (planners' cost over 10 runs; the paper's ranks on Daklak/Dakrong/LangCo)",
            (),
            lambda rows: [],
            plans=_seed002,
        ),
        Bench(
            "seed001-scenarios",
            "seed 001's three scenarios (CTGA beside PSO-CA)",
            ("seed001-scenarios.yaml",),
            _seed001,
        ),
        Bench(
            "seed004-table3",
            "seed 004 Table III (FGA, static obstacles: 5000 cases by the number of true hazards)",
            ("seed004-table3.yaml",),
            _seed004(P.PAPER_SEED004_STATIC),
        ),
        Bench(
            "seed004-table4",
            "seed 004 Table IV (FGA, moving obstacles: 5000 cases by the number of true hazards)",
            ("seed004-table4.yaml",),
            _seed004(P.PAPER_SEED004_DYNAMIC),
        ),
        Bench(
            "seed003-uncharted",
            "seed 003's uncharted scenarios (priority loop, PSO-CA, CTGA, FGA; rangefinders only)",
            ("seed003-uncharted.yaml",),
            _seed003,
            columns=("right outcome", "ours right?"),
        ),
    )
}
# named by the issues, not built yet: said so when asked for
COMING: dict[str, str] = {}


def markdown(bench: Bench, lines: list[Line], header: str) -> str:
    """The bench's section of SUMMARY.md."""
    out = [
        f"## {bench.name}: {bench.title}",
        "",
        header,
        "",
        f"| row | avoider | figure | ours | {bench.columns[0]} | {bench.columns[1]} |",
        "|---|---|---|---:|---:|---:|",
    ]
    out += [f"| {' | '.join(line)} |" for line in lines]
    return "\n".join(out) + "\n"


def update_summary(path: Path, bench: Bench, section: str) -> None:
    """Replace (or add) the bench's section of SUMMARY.md, through a temporary name."""
    from terrain.atomic import atomic_output

    text = (
        path.read_text(encoding="utf-8")
        if path.exists()
        else (
            "# Paper tables: the current figures\n\nWritten by `terrapath bench NAME` (one section a "
            "table, replaced each time); `benchmarks/RESULTS.md` is the dated log.\n"
        )
    )
    head = f"## {bench.name}:"
    parts = text.split("\n## ")
    kept = [parts[0]] + [p for p in parts[1:] if not ("## " + p).startswith(head)]
    new = "\n## ".join(kept).rstrip("\n") + "\n\n" + section
    with atomic_output(path) as tmp:
        tmp.write_text(new, encoding="utf-8")


__all__ = ["BENCHES", "COMING", "Bench", "markdown", "optimizer_of", "update_summary"]
