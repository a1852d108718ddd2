"""Convert momepy's Bubeneč buildings (Prague) to a terrapath threat file of ``prism`` threats.

Run from the project root (the GeoPackage is read where the shared maps keep it; it is not
copied into the project)::

    .venv/bin/python data/tools/bubenec_buildings.py [GPKG] [-o data/scenarios/bubenec-buildings.yaml]

Source: ``momepy_bubenec/bubenec.gpkg`` of the shared maps (PyPI momepy 0.11.0, its example data
set "bubenec": open data of the City of Prague, Bubeneč; the momepy package is BSD-3-Clause, see
``bubenec-buildings.SOURCE_LICENSE.txt`` beside the output).  It holds 144 building footprints
(layer ``buildings``, EPSG:3857 polygons, no heights) and a 1 m terrain model (raster ``dtm``, in
S-JTSK / Krovak East North, EPSG:5514, declared in the file as a LOCAL_CS of that name).

Steps:

1. the footprints are read with sqlite3: a GeoPackage geometry is a header (``GP``, version,
   flags, SRS id, an envelope whose size the flags give) followed by standard WKB, which
   shapely reads;
2. every vertex is reprojected from EPSG:3857 to EPSG:5514, the DTM's CRS, with
   ``rasterio.warp.transform`` (PROJ; pyproj is not installed), and rounded to the centimetre;
   the project has no converted copy of this DTM in ``data/maps/`` yet, so the threat file is
   in EPSG:5514 metres: fly it over a grid in that CRS (the DTM itself);
3. a feature that cannot be a prism is skipped and reported (printed, and listed in the output's
   header): a footprint with holes (interior rings), or one that is not a valid polygon after
   reprojection and rounding;
4. heights, by a documented, seeded rule (``SEED``, one ``numpy.random.default_rng``; one draw
   per written building, in the order of the features' ``fid``):

   - ``bottom`` = the lowest ground under the footprint: :meth:`HeightGrid.lowest_under` over the
     DTM (the lowest 1 m cell centre of the interpolation cells the footprint overlaps, so never
     above the ground under any part of it; the threat file's own default bottom with this grid),
     rounded down to the centimetre;
   - ``floors`` drawn uniformly from a range that grows with the footprint's area (EPSG:5514 m²),
     ``FLOORS_BY_AREA``: under 50 m² (garages, sheds) 1; under 150 m² 1-2; under 400 m² (the
     neighbourhood's villas and small blocks) 2-5; larger 3-6;
   - ``top`` = the highest ground under the footprint (:meth:`HeightGrid.highest_under`, up to
     4.8 m above its lowest on this slope) + ``FLOOR_HEIGHT_M`` (3 m) x floors, rounded up to the
     centimetre: every floor stands above the ground over the whole footprint.

Ids are ``b<uID>`` (the layer's ``uID`` column).  The output is written only when every building
kept is a valid ``prism`` (:class:`replay.threats.kinds.PrismThreat` and the threat-file loader).
"""

from __future__ import annotations

import argparse
import math
import sqlite3
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
import shapely
import shapely.wkb
from rasterio.crs import CRS
from rasterio.warp import transform

from replay.threats.file import load_threats
from replay.threats.kinds import PrismThreat
from terrain.grid import HeightGrid

ROOT = Path(__file__).resolve().parents[2]
GPKG = ROOT.parent / "shared" / "maps" / "momepy_bubenec" / "bubenec.gpkg"
OUT = ROOT / "data" / "scenarios" / "bubenec-buildings.yaml"
SOURCE_CRS = "EPSG:3857"
MAP_CRS = "EPSG:5514"  # the DTM's (S-JTSK / Krovak East North)
SEED = 3  # the seed (003)
FLOOR_HEIGHT_M = 3.0
# (area below which, m²; fewest floors; most floors), the first that fits
FLOORS_BY_AREA = ((50.0, 1, 1), (150.0, 1, 2), (400.0, 2, 5), (math.inf, 3, 6))
_ENVELOPE_BYTES = {0: 0, 1: 32, 2: 48, 3: 48, 4: 64}


@dataclass(frozen=True)
class Building:
    fid: int
    uid: int
    ring: list[tuple[float, float]]  # open, EPSG:5514 metres, rounded to the centimetre
    area: float
    floors: int
    bottom: float
    top: float

    @property
    def id(self) -> str:
        return f"b{self.uid}"


def geometry(blob: bytes) -> shapely.Geometry:
    """A GeoPackage geometry blob (header + WKB) as a shapely geometry."""
    if blob[:2] != b"GP":
        raise ValueError(f"not a GeoPackage geometry (magic {blob[:2]!r})")
    envelope = (blob[3] >> 1) & 0b111
    return shapely.wkb.loads(bytes(blob[8 + _ENVELOPE_BYTES[envelope] :]))


def read_footprints(gpkg: Path) -> list[tuple[int, int, shapely.Geometry]]:
    """(fid, uID, polygon in EPSG:3857) of every building, by fid."""
    with sqlite3.connect(f"file:{gpkg}?mode=ro", uri=True) as con:
        rows = con.execute("SELECT fid, uID, geom FROM buildings ORDER BY fid").fetchall()
    return [(int(fid), int(uid), geometry(blob)) for fid, uid, blob in rows]


def read_dtm(gpkg: Path) -> HeightGrid:
    """The DTM as a height grid in EPSG:5514 (the file's LOCAL_CS of that name)."""
    with rasterio.open(f"GPKG:{gpkg}:dtm") as ds:
        heights = ds.read(1)
        if ds.nodata is not None and np.any(heights == ds.nodata):
            raise ValueError("the DTM has nodata cells; this conversion expects none")
        return HeightGrid(heights, ds.transform, CRS.from_string(MAP_CRS), sources=(str(gpkg),))


def floors_for(area: float, rng: np.random.Generator) -> int:
    lo, hi = next((lo, hi) for below, lo, hi in FLOORS_BY_AREA if area < below)
    return int(rng.integers(lo, hi + 1))


def convert(gpkg: Path, seed: int = SEED) -> tuple[list[Building], list[str]]:
    """The buildings (by fid) and one line per feature skipped, saying why."""
    grid = read_dtm(gpkg)
    rng = np.random.default_rng(seed)
    kept: list[Building] = []
    skipped: list[str] = []
    for fid, uid, poly in read_footprints(gpkg):
        if poly.geom_type != "Polygon":
            skipped.append(f"fid {fid} (uID {uid}): a {poly.geom_type}, not a Polygon")
            continue
        if len(poly.interiors):
            skipped.append(
                f"fid {fid} (uID {uid}): a footprint with {len(poly.interiors)} hole(s) "
                "(a prism has none)"
            )
            continue
        x, y = np.asarray(poly.exterior.coords).T
        mx, my = transform(SOURCE_CRS, MAP_CRS, x.tolist(), y.tolist())
        ring = np.round(np.column_stack([mx, my]), 2)[:-1]
        keep = np.r_[True, np.any(ring[1:] != ring[:-1], axis=1)]
        ring = ring[keep]
        area = float(shapely.Polygon(ring).area)
        problem = shapely.is_valid_reason(shapely.Polygon(ring)) if len(ring) >= 3 else "< 3"
        if problem != "Valid Geometry":
            skipped.append(f"fid {fid} (uID {uid}): not a valid polygon ({problem})")
            continue
        floors = floors_for(area, rng)
        bottom = math.floor(grid.lowest_under(ring) * 100.0) / 100.0
        top = math.ceil((grid.highest_under(ring) + FLOOR_HEIGHT_M * floors) * 100.0) / 100.0
        pts = [(float(a), float(b)) for a, b in ring]
        kept.append(Building(fid, uid, pts, area, floors, bottom, top))
    return kept, skipped


def _number(v: float) -> str:
    return f"{v:.2f}".rstrip("0").rstrip(".")


def render(buildings: list[Building], skipped: list[str], gpkg_name: str, seed: int) -> str:
    lines = [
        "# Bubenec (Prague): real building footprints as prism threats, written by",
        "#   .venv/bin/python data/tools/bubenec_buildings.py   (do not edit by hand)",
        f"# Source: {gpkg_name}, layer 'buildings' (momepy 0.11.0 example data 'bubenec', open data",
        "# of the City of Prague; momepy is BSD-3-Clause: bubenec-buildings.SOURCE_LICENSE.txt).",
        "# Coordinates: EPSG:5514 (S-JTSK / Krovak East North) metres, the CRS of the source's 1 m",
        "# DTM (raster 'dtm'); fly these over a grid in that CRS.  Footprints reprojected from",
        "# EPSG:3857 with PROJ (rasterio.warp.transform) and rounded to the centimetre.",
        f"# Heights: no heights in the source; a seeded rule (numpy default_rng({seed}), one draw per",
        "# building in fid order): floors 1 below 50 m2 of footprint, else uniform in 1-2 below",
        "# 150 m2, 2-5 below 400 m2, 3-6 above; bottom = the lowest DTM ground under the footprint",
        "# (HeightGrid.lowest_under, rounded down to the cm); top = the highest DTM ground under it",
        "# (HeightGrid.highest_under) + 3 m per floor, rounded up to the cm.",
        f"# {len(buildings)} buildings; {len(skipped)} feature(s) skipped:",
        *(f"#   {s}" for s in skipped),
        "terrapath: 1",
        "name: bubenec-buildings",
        "threats:",
    ]
    for b in buildings:
        ring = [*b.ring, b.ring[0]]
        coords = ", ".join(f"[{_number(x)}, {_number(y)}]" for x, y in ring)
        lines += [
            f"- id: {b.id}  # fid {b.fid}, {b.area:.0f} m2, {b.floors} floor(s)",
            "  kind: prism",
            f"  bottom: {_number(b.bottom)}",
            f"  top: {_number(b.top)}",
            f"  footprint: [{coords}]",
        ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gpkg", nargs="?", type=Path, default=GPKG, help="bubenec.gpkg")
    parser.add_argument("-o", "--output", type=Path, default=OUT, help="the threat file")
    parser.add_argument("--seed", type=int, default=SEED, help="the heights' seed")
    args = parser.parse_args(argv)
    buildings, skipped = convert(args.gpkg, args.seed)
    for line in skipped:
        print(f"skipped {line}", file=sys.stderr)
    text = render(buildings, skipped, args.gpkg.name, args.seed)
    tmp = args.output.with_suffix(".yaml.part")
    tmp.write_text(text, encoding="utf-8")
    try:
        threats = load_threats(tmp)  # every building must read back as a valid prism
        assert all(isinstance(t, PrismThreat) for t in threats) and len(threats) == len(buildings)
    except Exception:
        tmp.unlink()
        raise
    tmp.replace(args.output)
    print(f"wrote {args.output} ({len(buildings)} buildings, {len(skipped)} skipped)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
