"""Convert matplotlib's Jacksboro Fault sample DEM (npz with lon/lat bounds) to a GeoTIFF.

Run from the project root:  .venv/bin/python data/maps/make_jacksboro_geotiff.py

The npz keys ``ymin`` and ``ymax`` are swapped in the original (``ymin`` = 36.733 is the NORTH
edge; matplotlib's own examples draw row 0 at ``ymin``), so row 0 is north and the GeoTIFF's
origin is (xmin, max(ymin, ymax)). The bounds are cell edges: 403 columns x 0.000833 deg span
xmin..xmax exactly. The CRS is taken as WGS84 lon/lat (EPSG:4326; the datum is not stated).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin

HERE = Path(__file__).resolve().parent / "mpl_jacksboro_fault"


def main() -> None:
    src = np.load(HERE / "jacksboro_fault_dem.npz")
    elev = np.asarray(src["elevation"])
    dx, dy = float(src["dx"]), float(src["dy"])
    west = float(src["xmin"])
    north = max(float(src["ymin"]), float(src["ymax"]))
    south = min(float(src["ymin"]), float(src["ymax"]))
    rows, cols = elev.shape
    assert abs((float(src["xmax"]) - west) - cols * dx) < 1e-6 * cols, "x extent != cols * dx"
    assert abs((north - south) - rows * dy) < 1e-6 * rows, "y extent != rows * dy"
    out = HERE / "jacksboro_fault_dem.tif"
    tmp = out.with_suffix(".tif.part")
    with rasterio.open(
        tmp,
        "w",
        driver="GTiff",
        height=rows,
        width=cols,
        count=1,
        dtype="int16",
        crs="EPSG:4326",
        transform=from_origin(west, north, dx, dy),
        compress="deflate",
    ) as dst:
        dst.write(elev.astype(np.int16), 1)
        dst.update_tags(SOURCE="matplotlib sample_data/jacksboro_fault_dem.npz", UNITS="m")
    tmp.replace(out)
    print(f"wrote {out} ({rows} x {cols})")


if __name__ == "__main__":
    main()
