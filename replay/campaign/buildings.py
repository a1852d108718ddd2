"""Own building scenarios (issue 34): ``own-buildings``, a *case* generator for the priority loop
(seed 003, ``--avoid priority``) -- a quadrotor among buildings on real terrain, its start and
target drawn in the open with buildings or ground in the way, flown with the rangefinders.  A
spec names the layouts as its rows (``threats: {generator: own-buildings, maps: [...]}``) and no
mission; ``runs`` scenarios are drawn per layout, each from its scenario seed.

The parameters and the exclusion rules below were fixed (and committed) before any success rate
was measured; ``VERSION`` is part of every run's identity and is bumped when a draw changes.

**Layouts** (the rows, :data:`LAYOUTS`):

- ``bubenec``: momepy's Prague neighbourhood, its 1 m DTM (``data/maps/momepy_bubenec``) and its
  143 real building footprints (``data/scenarios/bubenec-buildings.yaml``; their heights from the
  seeded floors rule written there), the same in every scenario;
- ``lidar-blocks``: the 400 m, 1 m LiDAR DEM (``data/maps/lidar_1m_dem``, 31 m of relief) with
  ``U(BLOCKS)`` buildings drawn per scenario, each a rectangle (sides ``U(RECT_M)``), an L or a U
  (arms ``U(RECT_M)`` long, ``WALL_M`` thick; the U's open side towards a random direction, the
  seed 003 trap in any orientation), turned by a uniform angle, at a uniform place at least
  ``GAP_M`` from the others and ``EDGE_M`` inside the map; its bottom the lowest ground under it,
  its top the highest ground under it plus ``U(TALL_M)``.

**Vehicle**: the ``quadrotor`` preset at ``SPEED_MPS`` (5 m/s, seed 003's slow explorer).

**Start and target**: uniform inside the map less ``EDGE_M``, ``U(DIST_M)`` apart; the flight
level ``z`` is the higher of their grounds plus ``U(ABOVE_M)`` (the mission's altitude: the loop
flies it level); both must stand ``CLEAR_M`` from everything *blocked* at ``z`` (below), and
the straight line between them must meet something blocked (a case with nothing in the way tests
nothing); redrawn up to ``TRIES`` times, else the layout gives no case (one line).

**Blocked at the flight level** (a 1 m raster on the map's grid, :func:`blocked`): a cell whose
ground is higher than ``z - BAND_M``, or covered by a building whose top is higher than ``z -
BAND_M`` and whose bottom is lower than ``z + BAND_M``, or off the map.  ``BAND_M`` (3 m) is the
priority loop's default ``tau`` (2 m) plus a metre: what a rangefinder cone sees as a wall.

**Exclusion rules** (geometric, independent of every avoider; a scenario they flag is still
flown, and the report drops it and counts it per rule): ``no way round`` -- no path joins the
start and the target through cells farther than ``PASSAGE_M / 2`` from every blocked cell (no
way at this level 4 m from every wall; the loop may still find a narrower gap, or pass over a
roof or a rise that ``BAND_M`` counts as blocked but its beams do not see, so such a case's
right outcome is not known: the report counts the outcomes there apart, and a test of the
loop's "target unreachable" is seed 003's closed box, ``data/scenarios/priority-box.yaml``);
``none survives`` (the run without an avoider succeeds).

The notes of a case (``metrics["case"]``) carry the layout, the start, target, flight level, the
straight and the shortest free-path lengths (the path on the raster, 8-connected), the buildings'
count and kinds, and ``excluded``.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from terrain.errors import InputError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

VERSION = 1
ROOT = Path(__file__).resolve().parents[2]
# layout: (DEM under data/maps, fixed buildings file under data/ or None: drawn per scenario)
LAYOUTS: dict[str, tuple[str, str | None]] = {
    "bubenec": ("momepy_bubenec/bubenec_dtm.tif", "scenarios/bubenec-buildings.yaml"),
    "lidar-blocks": ("lidar_1m_dem/dem.tif", None),
}
VEHICLE = "quadrotor"
SPEED_MPS = 5.0
EDGE_M = 10.0
DIST_M = (60.0, 250.0)
ABOVE_M = (6.0, 15.0)
CLEAR_M = 5.0
BAND_M = 3.0
PASSAGE_M = 8.0
TRIES = 400
BLOCKS = (8, 14)
RECT_M = (10.0, 40.0)
WALL_M = 2.0
GAP_M = 8.0
TALL_M = (12.0, 30.0)
SHAPES = ("rectangle", "L", "U")
EXCLUSIONS = ("no way round", "none survives")


def _path(rel: str, under: str) -> Path:
    return ROOT / "data" / under / rel


def check_layout(name: str) -> None:
    """One line naming what is missing for layout ``name`` (nothing when it can be drawn)."""
    if name not in LAYOUTS:
        raise InputError(f"own-buildings: unknown layout {name!r}; valid: {', '.join(LAYOUTS)}")
    dem, fixed = LAYOUTS[name]
    for path in (_path(dem, "maps"), *([_path(fixed, "")] if fixed else [])):
        if not path.is_file():
            raise InputError(f"own-buildings: layout {name!r} needs {path}")


@cache
def _grid(name: str) -> Any:
    from terrain.load import load_dem

    return load_dem([str(_path(LAYOUTS[name][0], "maps"))])


@cache
def _fixed(name: str) -> tuple[dict[str, Any], ...]:
    import yaml

    fixed = LAYOUTS[name][1]
    if fixed is None:
        return ()
    with open(_path(fixed, ""), encoding="utf-8") as f:
        return tuple(yaml.safe_load(f)["threats"])


def _shape(kind: str, a: float, b: float) -> list[tuple[float, float]]:
    """A footprint centred on the origin, before turning: a rectangle ``a x b``, an L or a U
    with arms ``a`` and ``b`` long and ``WALL_M`` thick (the U open towards +y)."""
    w = WALL_M
    if kind == "rectangle":
        return [(-a / 2, -b / 2), (a / 2, -b / 2), (a / 2, b / 2), (-a / 2, b / 2)]
    if kind == "L":
        return [(0, 0), (a, 0), (a, w), (w, w), (w, b), (0, b)]
    return [(0, 0), (a, 0), (a, b), (a - w, b), (a - w, w), (w, w), (w, b), (0, b)]


def _blocks(grid: Any, rng: np.random.Generator) -> list[dict[str, Any]]:
    """``lidar-blocks``' buildings (module docstring) as prism records."""
    from shapely.affinity import rotate, translate
    from shapely.geometry import Polygon

    xmin, ymin, xmax, ymax = grid.bounds
    count = int(rng.integers(BLOCKS[0], BLOCKS[1] + 1))
    placed: list[Any] = []
    out: list[dict[str, Any]] = []
    for _ in range(TRIES):
        if len(out) == count:
            break
        kind = SHAPES[int(rng.integers(len(SHAPES)))]
        a, b = (float(v) for v in rng.uniform(*RECT_M, size=2))
        poly = Polygon(_shape(kind, a, b))
        poly = translate(poly, -poly.centroid.x, -poly.centroid.y)
        poly = rotate(poly, float(rng.uniform(0.0, 360.0)), origin=(0, 0))
        at = rng.uniform([xmin + EDGE_M, ymin + EDGE_M], [xmax - EDGE_M, ymax - EDGE_M])
        poly = translate(poly, float(at[0]), float(at[1]))
        x0, y0, x1, y1 = poly.bounds
        if x0 < xmin + EDGE_M or y0 < ymin + EDGE_M or x1 > xmax - EDGE_M or y1 > ymax - EDGE_M:
            continue
        if any(poly.distance(p) < GAP_M for p in placed):
            continue
        placed.append(poly)
        ring = [(round(x, 2), round(y, 2)) for x, y in poly.exterior.coords]
        top = grid.highest_under(ring) + float(rng.uniform(*TALL_M))
        out.append(
            {
                "id": f"{kind}{len(out) + 1}",
                "kind": "prism",
                "bottom": math.floor(grid.lowest_under(ring) * 100.0) / 100.0,
                "top": math.ceil(top * 100.0) / 100.0,
                "footprint": [list(p) for p in ring],
            }
        )
    return out


def blocked(grid: Any, buildings: list[dict[str, Any]], z: float) -> BoolArray:
    """The cells of ``grid`` blocked at the flight level ``z`` (module docstring); the raster's
    rows and columns are the grid's."""
    from rasterio.features import rasterize

    ground = np.asarray(grid.heights if grid.upper is None else grid.upper, dtype=np.float64)
    out = ground > z - BAND_M
    shapes = [
        ({"type": "Polygon", "coordinates": [b["footprint"]]}, 1)
        for b in buildings
        if float(b["top"]) > z - BAND_M and float(b["bottom"]) < z + BAND_M
    ]
    if shapes:
        out |= rasterize(
            shapes,
            out_shape=grid.shape,
            transform=grid.transform,
            fill=0,
            all_touched=True,
            dtype="uint8",
        ).astype(bool)
    if grid.known is not None:
        out |= ~np.asarray(grid.known, dtype=bool)
    out[0, :] = out[-1, :] = out[:, 0] = out[:, -1] = True
    return np.asarray(out, dtype=bool)


def _cell(grid: Any, p: FloatArray) -> tuple[int, int]:
    r, c = grid.cell_of(p[0:1], p[1:2])
    return int(r[0]), int(c[0])


def _crosses(grid: Any, blk: BoolArray, a: FloatArray, b: FloatArray) -> bool:
    """Whether the straight line ``a``-``b`` meets a blocked cell (sampled every half cell)."""
    n = max(2, int(np.linalg.norm(b - a) / (0.5 * min(grid.cell_size))) + 1)
    s = np.linspace(0.0, 1.0, n)[:, None]
    p = a + s * (b - a)
    r, c = grid.cell_of(p[:, 0], p[:, 1])
    return bool(blk[r, c].any())


def clearance_m(grid: Any, blk: BoolArray) -> FloatArray:
    """Each cell's distance (m) to the nearest blocked cell of ``blk``."""
    from scipy.ndimage import distance_transform_edt

    dx, dy = grid.cell_size
    return np.asarray(distance_transform_edt(~blk, sampling=(dy, dx)), dtype=np.float64)


def free_path_m(
    grid: Any, blk: BoolArray, a: FloatArray, b: FloatArray, clear: FloatArray | None = None
) -> float | None:
    """The shortest 8-connected path (m) from ``a`` to ``b`` through cells farther than
    ``PASSAGE_M / 2`` from every blocked cell; None when there is none (``no way round``).
    ``clear``: :func:`clearance_m` of ``blk`` when the caller has it."""
    from scipy.sparse import csgraph, csr_matrix

    dx, dy = grid.cell_size
    free = (clearance_m(grid, blk) if clear is None else clear) > PASSAGE_M / 2.0
    ra, rb = _cell(grid, a), _cell(grid, b)
    if not (free[ra] and free[rb]):
        return None
    idx = np.full((free.shape[0] + 2, free.shape[1] + 2), -1, dtype=np.int64)
    idx[1:-1, 1:-1][free] = np.arange(int(free.sum()))
    h, w = free.shape
    src = idx[1 : h + 1, 1 : w + 1]
    rows: list[npt.NDArray[np.int64]] = []
    cols: list[npt.NDArray[np.int64]] = []
    wts: list[FloatArray] = []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        dst = idx[1 + di : h + 1 + di, 1 + dj : w + 1 + dj]
        ok = (src >= 0) & (dst >= 0)
        rows.append(src[ok])
        cols.append(dst[ok])
        wts.append(np.full(int(ok.sum()), math.hypot(di * dy, dj * dx)))
    n = int(free.sum())
    graph = csr_matrix((np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), (n, n))
    dist = csgraph.dijkstra(graph, directed=False, indices=int(idx[1 + ra[0], 1 + ra[1]]))
    d = float(dist[int(idx[1 + rb[0], 1 + rb[1]])])
    return None if not math.isfinite(d) else d


def buildings_case(
    rng: np.random.Generator, layout: str
) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any]]:
    """One scenario of ``layout`` (module docstring): (mission document, threat records,
    notes)."""
    check_layout(layout)
    grid = _grid(layout)
    fixed = LAYOUTS[layout][1] is not None
    buildings = list(_fixed(layout)) if fixed else _blocks(grid, rng)
    xmin, ymin, xmax, ymax = grid.bounds
    for _ in range(TRIES):
        a = rng.uniform([xmin + EDGE_M, ymin + EDGE_M], [xmax - EDGE_M, ymax - EDGE_M])
        heading = rng.uniform(0.0, 2.0 * math.pi)
        b = a + float(rng.uniform(*DIST_M)) * np.array([math.sin(heading), math.cos(heading)])
        if not (xmin + EDGE_M <= b[0] <= xmax - EDGE_M and ymin + EDGE_M <= b[1] <= ymax - EDGE_M):
            continue
        ground = grid.height_at(np.array([a[0], b[0]]), np.array([a[1], b[1]]))
        z = float(np.max(ground) + rng.uniform(*ABOVE_M))
        blk = blocked(grid, buildings, z)
        clear = clearance_m(grid, blk)
        if clear[_cell(grid, a)] < CLEAR_M or clear[_cell(grid, b)] < CLEAR_M:
            continue
        if _crosses(grid, blk, a, b):
            break
    else:
        raise InputError(f"own-buildings: no start and target fit layout {layout!r}")
    way = free_path_m(grid, blk, a, b, clear)
    excluded = [EXCLUSIONS[0]] if way is None else []
    z = round(z, 2)
    doc = {
        "terrapath": 1,
        "name": f"own-buildings-{layout}",
        "crs": str(grid.crs) if getattr(grid, "crs", None) else "local",
        "terrain": {"dem": [str(_path(LAYOUTS[layout][0], "maps"))]},
        "vehicle": VEHICLE,
        "cruise": {"speed": SPEED_MPS, "altitude": z},
        "waypoints": [[float(a[0]), float(a[1]), z], [float(b[0]), float(b[1]), z]],
    }
    kinds: dict[str, int] = {}
    for bd in buildings:
        k = str(bd["id"]).rstrip("0123456789") if not fixed else "real"
        kinds[k] = kinds.get(k, 0) + 1
    notes = {
        "generator": f"own-buildings v{VERSION}",
        "map": layout,
        "vehicle": VEHICLE,
        "speed_mps": SPEED_MPS,
        "altitude_m": z,
        "straight_m": round(float(np.linalg.norm(b - a)), 1),
        "free_path_m": None if way is None else round(way, 1),
        "buildings": kinds,
        "excluded": excluded,
    }
    return doc, buildings, notes


__all__ = ["EXCLUSIONS", "LAYOUTS", "VERSION", "blocked", "buildings_case", "check_layout"]
