"""Convert the Bubeneč (Prague) terrain model of momepy's example GeoPackage to a GeoTIFF.

Run from the project root (the GeoPackage is read where the shared maps keep it; only the
converted raster is committed)::

    .venv/bin/python data/maps/make_bubenec_geotiff.py [GPKG]

Source: ``momepy_bubenec/bubenec.gpkg`` of the shared maps (PyPI momepy 0.11.0, example data set
"bubenec", open data of the City of Prague; the momepy package is BSD-3-Clause), raster layer
``dtm``: 592 x 647 cells of 1 m, float32, 188.4-222.1 m.  The GeoPackage declares its CRS as a
LOCAL_CS named ``S-JTSK_Krovak_East_North``; that is S-JTSK / Krovak East North (EPSG:5514),
the CRS momepy documents, so the GeoTIFF is written with EPSG:5514 and the same transform (the
cells are copied unchanged; the nodata value -3.4e38 marks no cell of this raster).  The
building footprints (``data/scenarios/bubenec-buildings.yaml``, ``data/tools/
bubenec_buildings.py``) are in the same CRS.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import rasterio

ROOT = Path(__file__).resolve().parents[2]
GPKG = ROOT.parent / "shared" / "maps" / "momepy_bubenec" / "bubenec.gpkg"
OUT = Path(__file__).resolve().parent / "momepy_bubenec" / "bubenec_dtm.tif"


def main(gpkg: Path = GPKG) -> None:
    with rasterio.open(f"GPKG:{gpkg}:dtm") as src:
        assert src.crs is not None and "Krovak" in src.crs.to_wkt(), src.crs
        elev = src.read(1)
        transform = src.transform
        nodata = src.nodata
    assert nodata is None or not np.any(elev == nodata), "the DTM has nodata cells"
    rows, cols = elev.shape
    tmp = OUT.with_suffix(".tif.part")
    with rasterio.open(
        tmp,
        "w",
        driver="GTiff",
        height=rows,
        width=cols,
        count=1,
        dtype="float32",
        crs="EPSG:5514",
        transform=transform,
        compress="deflate",
        predictor=3,
    ) as dst:
        dst.write(elev.astype(np.float32), 1)
        dst.update_tags(SOURCE="momepy 0.11.0 datasets/bubenec.gpkg, raster layer dtm", UNITS="m")
    tmp.replace(OUT)
    print(f"wrote {OUT} ({rows} x {cols}, {float(elev.min()):.2f}-{float(elev.max()):.2f} m)")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else GPKG)
