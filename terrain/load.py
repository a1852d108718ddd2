"""Load DEM tiles (anything GDAL reads) into one metric :class:`~terrain.grid.HeightGrid`.

What happens, in order:

1. every tile is opened with rasterio and checked (exists, is a raster, has one band or a chosen
   band, is not entirely nodata);
2. the target CRS is chosen: the one the user names; else the tiles' own CRS when it is projected
   in metres and shared by all tiles; else the UTM zone of the area's centre (WGS84, EPSG:326zz /
   327zz; the Norway/Svalbard zone exceptions are not applied). Tiles without CRS are "local"
   metres and stay local; mixing local and georeferenced tiles is refused;
3. the cell size is the user's, or the native one in metres: for tiles already in the target CRS
   their own pixel size; for reprojected tiles the *finer* of the east-west and north-south pixel
   sizes measured in metres (so no detail is thrown away; rmnp-dem.tif's 0.00275 x 0.00211 degree
   pixels become ~233 m cells);
4. tiles in the target CRS on the same pixel lattice are copied exactly; others are reprojected
   with ``rasterio.warp.reproject`` into one grid, three times: the display heights (bilinear;
   ``average`` when the new cells are much coarser), the safety heights (``max``: the highest
   source cell in each grid cell) and the tile's footprint (a coverage array, nearest). Where
   tiles overlap, the first one given wins for the display heights and the highest one for the
   safety heights;
5. what was not measured is recorded: a cell is *known* when its centre lies over a valid
   (not nodata) cell of a tile. Unknown cells (nodata holes, counted in
   ``HeightGrid.nodata_filled``; cells outside every footprint such as the empty corners a
   reprojection adds, counted in ``HeightGrid.outside_source``) are filled by interpolation
   (GDAL's inverse-distance ``fillnodata``, then nearest neighbour for anything left) and flagged
   in ``HeightGrid.known``; the safety heights there are the nearest measured safety height, and
   never below the filled display height.

GDAL's ``max`` resampling, measured on the bundled maps (rmnp, srtm3, jacksboro at native and
other cell sizes): every source cell's value is at most the safety height of the grid cell that
contains the source cell's centre, so the safety grid keeps every summit (rmnp: 4261 m raw and
safety, 4192 m bilinear). It also takes most source cells that overlap a grid cell only partly,
but not all: on rmnp 19 of 300 sampled source cells had up to 9 % of their area in a grid cell
that did not take their value.

The memory a grid needs is checked against the memory available *before* anything is allocated.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt
import rasterio
from affine import Affine
from rasterio.crs import CRS
from rasterio.enums import MaskFlags, Resampling
from rasterio.errors import CRSError, RasterioIOError
from rasterio.windows import Window

from terrain.errors import DataFileError, InputError, ResourceError
from terrain.grid import HeightGrid
from terrain.memo import DiskMemo

WGS84 = CRS.from_epsg(4326)
# Working copies per cell while building a grid: the float32 display and safety results, one
# float32 tile buffer of each, the coverage and validity masks, the fill's scratch arrays and the
# nearest-neighbour indices, and the grid's own frozen copies.
_BYTES_PER_CELL = 48

PathLike = str | os.PathLike[str]
READ_CACHE = 16 * 2**20  # bytes of GDAL's block cache while a grid is read


@dataclass(frozen=True)
class SourceInfo:
    """What one DEM tile is, as stored (before any reprojection)."""

    path: str
    driver: str
    crs: str | None
    rows: int
    cols: int
    res: tuple[float, float]
    bounds: tuple[float, float, float, float]
    nodata: float | None
    dtype: str
    bands: int


def inspect_dem(path: PathLike) -> SourceInfo:
    """Describe one tile without loading its heights."""
    with _open(path) as src:
        return SourceInfo(
            path=str(path),
            driver=src.driver,
            crs=src.crs.to_string() if src.crs else None,
            rows=src.height,
            cols=src.width,
            res=(float(src.res[0]), float(src.res[1])),
            bounds=_own_bounds(src),
            nodata=None if src.nodata is None else float(src.nodata),
            dtype=src.dtypes[0],
            bands=src.count,
        )


def _open(path: PathLike) -> rasterio.DatasetReader:
    p = Path(path)
    if not p.exists():
        raise DataFileError(f"{str(p)!r}: no such file")
    if p.is_dir():
        raise DataFileError(f"{str(p)!r}: is a folder, expected a DEM file")
    if p.stat().st_size == 0:
        raise DataFileError(
            f"{str(p)!r}: empty file (0 bytes), expected a DEM such as GeoTIFF, SRTM .hgt or "
            "ESRI ASCII grid"
        )
    try:
        src = rasterio.open(p)
    except RasterioIOError as exc:
        reason = str(exc).split("\n")[0]
        if len(reason) > 160 or not reason:
            reason = "format not recognised"
        raise DataFileError(
            f"{str(p)!r}: not a raster GDAL can read (expected a DEM such as GeoTIFF, SRTM .hgt "
            f"or ESRI ASCII grid; {reason})"
        ) from None
    t = src.transform
    if not (math.isfinite(t.determinant) and t.determinant != 0 and all(map(math.isfinite, t))):
        src.close()  # an ESRI ASCII grid with 'cellsize 0', a GeoTIFF with a degenerate transform
        raise DataFileError(
            f"{str(p)!r}: cell size {abs(t.a):g} x {abs(t.e):g} (its georeference); expected positive, "
            "finite cell sizes"
        )
    return src


def utm_crs_for(lon: float, lat: float) -> CRS:
    """The WGS84 UTM zone CRS containing (lon, lat)."""
    zone = int(math.floor(((lon + 180.0) % 360.0) / 6.0)) + 1
    zone = min(max(zone, 1), 60)
    return CRS.from_epsg((32600 if lat >= 0 else 32700) + zone)


def _is_metric(crs: CRS) -> bool:
    if crs.is_geographic:
        return False
    try:
        units = (crs.linear_units or "").lower()
    except CRSError:  # pragma: no cover - exotic CRS
        return False
    return units in {"metre", "meter", "metres", "meters", "m"}


def _parse_crs(value: str | CRS | None) -> CRS | None:
    if value is None or isinstance(value, CRS):
        return value
    try:
        # Inside a GDAL environment, PROJ's own complaint goes to rasterio's logger instead of
        # a stray "ERROR 1: PROJ: ..." line on stderr; the message below says it once.
        with rasterio.Env():
            crs = CRS.from_user_input(value)
    except CRSError:
        raise InputError(
            f"CRS {value!r} is not one PROJ knows (expected e.g. 'EPSG:32611')"
        ) from None
    if not _is_metric(crs):
        raise InputError(
            f"CRS {value!r} is not a projected CRS in metres; terrapath maps are metric"
        )
    return crs


def _available_memory() -> int:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 * 2**30


def check_grid_memory(rows: int, cols: int, cell_size: float) -> None:
    """Refuse, before allocating, a grid that would not fit in the memory available."""
    need = rows * cols * _BYTES_PER_CELL
    avail = _available_memory()
    if rows * cols > 2**31 - 1 or need > 0.8 * avail:
        raise ResourceError(
            f"cell size {cell_size:g} m would make a {rows:,} x {cols:,} grid needing about "
            f"{need / 2**30:.1f} GiB, more than the {avail / 2**30:.1f} GiB of memory available; "
            "choose a larger cell size or a smaller crop box"
        )


def _read_band(
    src: rasterio.DatasetReader,
    band: int,
    path: str,
    window: Window | None = None,
    out: npt.NDArray[np.float32] | None = None,
) -> npt.NDArray[np.float32]:
    """The tile's heights (float32, NaN where nodata, masked or not finite) of ``window`` (the
    whole band when None), read straight into ``out`` when given (a C-contiguous float32 array
    of the window's shape): no masked array, no copy of the band."""
    if window is None:
        window = Window(0, 0, src.width, src.height)
    shape = (int(window.height), int(window.width))
    arr = np.empty(shape, dtype=np.float32) if out is None else out
    try:
        src.read(band, window=window, out=arr, out_dtype=np.float32)
        masked = MaskFlags.all_valid not in src.mask_flag_enums[band - 1]
        if masked:  # a nodata value, an internal mask or an alpha band
            arr[src.read_masks(band, window=window) == 0] = np.nan
    except RasterioIOError:  # GDAL's "Read failed": a truncated or damaged file
        raise DataFileError(
            f"{path!r}: its heights cannot be read (band {band}): the file is truncated or damaged"
        ) from None
    if np.dtype(src.dtypes[band - 1]).kind == "f":
        arr[~np.isfinite(arr)] = np.nan
    whole = shape == (src.height, src.width)
    if whole and _finite_max(arr) is None:
        raise DataFileError(f"{path!r}: every cell is nodata; there are no heights in it")
    return arr


def _source_window(
    src: rasterio.DatasetReader, target: CRS | None, transform: Affine, rows: int, cols: int
) -> Window:
    """The part of a tile that a grid (``transform``, ``rows`` x ``cols``, in ``target``) needs
    to be resampled from: the grid's box in the tile's frame, widened by two source cells for the
    resampling's kernel, on the tile (a windowed read: a crop of a large DEM reads its part)."""
    from rasterio.warp import transform_bounds

    everything = Window(0, 0, src.width, src.height)
    st = src.transform
    if st.b != 0 or st.d != 0:  # a rotated tile: read it all
        return everything
    x0, y0 = transform.c, transform.f + rows * transform.e
    x1, y1 = transform.c + cols * transform.a, transform.f
    if target is not None and src.crs != target:
        x0, y0, x1, y1 = transform_bounds(target, src.crs, x0, y0, x1, y1, densify_pts=21)
    cols_ = sorted(((x0 - st.c) / st.a, (x1 - st.c) / st.a))
    rows_ = sorted(((y0 - st.f) / st.e, (y1 - st.f) / st.e))
    if not all(map(math.isfinite, cols_ + rows_)):
        return everything
    c0, c1 = max(0, math.floor(cols_[0]) - 2), min(src.width, math.ceil(cols_[1]) + 2)
    r0, r1 = max(0, math.floor(rows_[0]) - 2), min(src.height, math.ceil(rows_[1]) + 2)
    if c1 <= c0 or r1 <= r0:
        return everything
    return Window(c0, r0, c1 - c0, r1 - r0)


def _choose_band(src: rasterio.DatasetReader, band: int | None, path: str) -> int:
    if band is None:
        if src.count != 1:
            raise InputError(
                f"{path!r}: has {src.count} bands, so which one is elevation is ambiguous "
                "(a DEM has one band); choose one with --band N"
            )
        return 1
    if not 1 <= band <= src.count:
        raise InputError(f"{path!r}: band {band} does not exist (it has {src.count} bands)")
    return band


def load_dem(
    paths: PathLike | Sequence[PathLike],
    *,
    crs: str | CRS | None = None,
    cell_size: float | None = None,
    crop: Sequence[float] | None = None,
    crop_lonlat: bool = False,
    band: int | None = None,
    local_cell_size: float | None = None,
) -> HeightGrid:
    """Load one or more DEM tiles into a metric height grid (see the module docstring).

    ``crop`` is (xmin, ymin, xmax, ymax) in map metres of the *result*, or (west, south, east,
    north) in degrees with ``crop_lonlat=True``.  ``local_cell_size``: the size in metres of one
    cell of a DEM *without a CRS* whose cells are not metres (a picture's pixels, a simulation's
    units): the grid is scaled so that each cell measures that much (its origin too), so every
    length is in metres; refused for a georeferenced DEM (its cells already have a size) and
    with ``cell_size`` (resample a scaled grid in a second step).
    """
    plist = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if not plist:
        raise InputError("no DEM file given")
    names = [str(p) for p in plist]
    if cell_size is not None and not (math.isfinite(cell_size) and cell_size > 0):
        raise InputError(f"cell size must be a positive number of metres; got {cell_size!r}")
    user_crs = _parse_crs(crs)
    if local_cell_size is not None:
        if not (isinstance(local_cell_size, int | float) and math.isfinite(local_cell_size)
                and local_cell_size > 0):  # fmt: skip
            raise InputError(
                f"--local-cell-size must be a positive number of metres; got {local_cell_size!r}"
            )
        if cell_size is not None:
            raise InputError("give --local-cell-size or --cell-size, not both")

    srcs = [_open(p) for p in plist]
    try:
        bands = [_choose_band(s, band, n) for s, n in zip(srcs, names, strict=True)]
        local = [s.crs is None for s in srcs]
        if any(local) and not all(local):
            bad = names[local.index(True)]
            raise InputError(
                f"{bad!r}: has no CRS while other tiles are georeferenced; tiles must all be "
                "georeferenced or all local"
            )
        if local_cell_size is not None and not all(local):
            bad = names[local.index(False)]
            raise InputError(
                f"{bad!r}: is georeferenced ({srcs[local.index(False)].crs.to_string()}): its "
                "cells already have a size; --local-cell-size is for a DEM without a CRS"
            )
        if all(local):
            if user_crs is not None:
                raise InputError(
                    f"{names[0]!r}: has no CRS (local metres), so it cannot be reprojected to "
                    f"{user_crs.to_string()}"
                )
            target = None
        else:
            target = user_crs or _default_crs(srcs)
        # every block is read once, straight into the grid: GDAL's block cache (5 % of the
        # memory by default) would only keep a second copy of the file's cells
        with rasterio.Env(GDAL_CACHEMAX=READ_CACHE):
            grid = _build(srcs, names, bands, target, cell_size, crop, crop_lonlat)
    finally:
        for s in srcs:
            s.close()
    if local_cell_size is not None:
        t = grid.transform
        k = float(local_cell_size) / abs(float(t.a))
        scaled = Affine(t.a * k, t.b, t.c * k, t.d, t.e * k, t.f * k)
        grid = replace(grid, transform=scaled)
    return grid


def _default_crs(srcs: list[rasterio.DatasetReader]) -> CRS:
    first = srcs[0].crs
    if _is_metric(first) and all(s.crs == first for s in srcs):
        return first
    west, south, east, north = _union([_bounds_in(s, WGS84) for s in srcs])
    return utm_crs_for((west + east) / 2.0, (south + north) / 2.0)


def _own_bounds(src: rasterio.DatasetReader) -> tuple[float, float, float, float]:
    b = src.bounds
    return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))


def _bounds_in(src: rasterio.DatasetReader, crs: CRS) -> tuple[float, float, float, float]:
    from rasterio.warp import transform_bounds

    if src.crs == crs:
        return _own_bounds(src)
    b = transform_bounds(src.crs, crs, *src.bounds, densify_pts=21)
    return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))


def _union(boxes: list[tuple[float, float, float, float]]) -> tuple[float, float, float, float]:
    a = np.array(boxes)
    return (float(a[:, 0].min()), float(a[:, 1].min()), float(a[:, 2].max()), float(a[:, 3].max()))


def _native_res(src: rasterio.DatasetReader, target: CRS | None) -> tuple[float, float]:
    if target is None or src.crs == target:
        return (float(src.res[0]), float(src.res[1]))
    from rasterio.warp import transform

    # Measure one pixel step east and one south at the tile's centre, in the target CRS.
    r, c = src.height / 2.0, src.width / 2.0
    t = src.transform
    cols, rows = [c, c + 1.0, c], [r, r, r + 1.0]
    xs = [t.c + ci * t.a + ri * t.b for ci, ri in zip(cols, rows, strict=True)]
    ys = [t.f + ci * t.d + ri * t.e for ci, ri in zip(cols, rows, strict=True)]
    tx, ty = transform(src.crs, target, xs, ys)
    east = math.hypot(tx[1] - tx[0], ty[1] - ty[0])
    south = math.hypot(tx[2] - tx[0], ty[2] - ty[0])
    fine = min(east, south)
    return (fine, fine)


def _crop_box(
    crop: Sequence[float] | None, lonlat: bool, target: CRS | None
) -> tuple[float, float, float, float] | None:
    if crop is None:
        return None
    vals = [float(v) for v in crop]
    if len(vals) != 4 or not all(math.isfinite(v) for v in vals):
        raise InputError(
            f"crop box must be 4 finite numbers (xmin, ymin, xmax, ymax); got {crop!r}"
        )
    if vals[0] >= vals[2] or vals[1] >= vals[3]:
        raise InputError(f"crop box must have xmin < xmax and ymin < ymax; got {tuple(vals)}")
    if not lonlat:
        return (vals[0], vals[1], vals[2], vals[3])
    if target is None:
        raise InputError(
            "a crop box in lon/lat needs a georeferenced DEM; this one is local metres"
        )
    if not (-90 <= vals[1] <= 90 and -90 <= vals[3] <= 90):
        raise InputError(f"crop box latitudes must lie in [-90, 90]; got {tuple(vals)}")
    from rasterio.warp import transform_bounds

    b = transform_bounds(WGS84, target, *vals, densify_pts=21)
    return (float(b[0]), float(b[1]), float(b[2]), float(b[3]))


def _build(
    srcs: list[rasterio.DatasetReader],
    names: list[str],
    bands: list[int],
    target: CRS | None,
    cell_size: float | None,
    crop: Sequence[float] | None,
    crop_lonlat: bool,
) -> HeightGrid:
    native = [_native_res(s, target) for s in srcs]
    if cell_size is not None:
        res = (float(cell_size), float(cell_size))
    elif target is None or all(s.crs == target for s in srcs):
        res = native[0]
    else:
        fine = min(min(r) for r in native)
        res = (fine, fine)
    full = _union([_bounds_in(s, target) if target else _own_bounds(s) for s in srcs])
    box = _crop_box(crop, crop_lonlat, target)
    if box is not None:
        inter = (
            max(box[0], full[0]),
            max(box[1], full[1]),
            min(box[2], full[2]),
            min(box[3], full[3]),
        )
        if inter[2] - inter[0] < res[0] or inter[3] - inter[1] < res[1]:
            raise InputError(
                f"crop box {tuple(round(v, 6) for v in (crop or ()))} lies outside the map "
                f"(map bounds {tuple(round(v, 3) for v in full)}"
                f"{' in map metres' if not crop_lonlat else ' in map metres; box given in lon/lat'})"
            )
        full = inter
    same_frame = target is None or all(s.crs == target for s in srcs)
    if same_frame:
        # Snap to the first tile's pixel lattice when keeping its resolution, so reads are exact.
        t0 = srcs[0].transform
        if res == native[0]:
            xmin = t0.c + math.floor((full[0] - t0.c) / res[0] + 1e-9) * res[0]
            ymax = t0.f - math.floor((t0.f - full[3]) / res[1] + 1e-9) * res[1]
        else:
            xmin, ymax = full[0], full[3]
    else:
        xmin, ymax = full[0], full[3]
    cols = max(2, math.ceil((full[2] - xmin) / res[0] - 1e-9))
    rows = max(2, math.ceil((ymax - full[1]) / res[1] - 1e-9))
    check_grid_memory(rows, cols, min(res))
    transform = Affine(res[0], 0.0, xmin, 0.0, -res[1], ymax)

    coarse = min(res) > 1.5 * max(max(r) for r in native)
    resampling = Resampling.average if coarse else Resampling.bilinear
    heights: npt.NDArray[np.float32] | None = None
    # None while the safety heights are the display heights (one tile copied exactly)
    upper: npt.NDArray[np.float32] | None = None
    covered: npt.NDArray[np.bool_] | None = None
    exact = True
    source_max: float | None = None
    for src, name, band in zip(srcs, names, bands, strict=True):
        part = _warp_tile(
            src, name, band, target, transform, rows, cols, resampling, same_frame, box is None
        )
        if heights is None or covered is None:
            # the first tile's arrays become the grid's (no copy); a display height counts
            # only over a measured cell
            heights, covered, upper = part.heights, part.covered, part.upper
            if part.measured is not None:
                heights[~part.measured] = np.nan
        else:
            if upper is None:
                upper = heights.copy()  # an exact copy is its own maximum
            measured = np.isfinite(part.heights) if part.measured is None else part.measured
            hole = np.isnan(heights) & measured
            heights[hole] = part.heights[hole]
            del hole
            covered |= part.covered
            np.fmax(upper, part.heights if part.upper is None else part.upper, out=upper)
        exact = exact and part.upper is None
        if part.source_max is not None:
            source_max = part.source_max if source_max is None else max(source_max, part.source_max)
        del part
    assert heights is not None and covered is not None
    known = ~np.isnan(heights)
    if not known.any():
        raise DataFileError(
            f"{', '.join(repr(n) for n in names)}: no heights inside the requested area (all nodata)"
        )
    outside = np.logical_not(covered, out=covered)
    n_outside = int(np.count_nonzero(outside))
    n_holes = int(known.size - np.count_nonzero(known)) - n_outside
    if n_holes or n_outside:
        heights[~known] = np.nan
        heights = fill_nodata(heights)
        if not exact and upper is not None:
            # Unknown cells: the nearest measured safety height (below, never under the fill).
            upper = _fill_nearest(upper)
    safety: npt.NDArray[np.float32] | None = None
    if upper is not None:
        np.fmax(upper, heights, out=upper)  # NaN (an exact copy's holes) takes the filled height
        if not (exact and np.array_equal(upper, heights)):
            safety = upper
            safety.flags.writeable = False  # handed to the grid as it is
    del upper
    heights.flags.writeable = False
    known.flags.writeable = False
    outside.flags.writeable = False
    return HeightGrid(
        heights,
        transform,
        target,
        tuple(names),
        n_holes,
        known=None if n_holes + n_outside == 0 else known,
        upper=safety,
        outside_source=n_outside,
        source_max=source_max,
        outside=outside if n_outside else None,
    )


@dataclass(frozen=True)
class _TilePart:
    """One tile on the grid: display heights (NaN where it has no value), safety heights (``max``
    resampling; None when the tile is copied exactly), the cells whose centre lies inside its
    footprint (``covered``) and over one of its valid cells (``measured``: a display height
    that bilinear resampling spreads from valid neighbours over a hole's edge does not count),
    and its highest valid value over the grid's area."""

    heights: npt.NDArray[np.float32]
    upper: npt.NDArray[np.float32] | None
    covered: npt.NDArray[np.bool_]
    measured: npt.NDArray[np.bool_] | None  # None: where ``heights`` is not NaN
    source_max: float | None


def _finite_max(values: npt.NDArray[np.float32]) -> float | None:
    """The highest value that is not NaN (None when every one is; heights hold no infinities
    by then), with no copy of ``values``."""
    if values.size == 0:
        return None
    top = float(np.fmax.reduce(values, axis=None))
    return None if math.isnan(top) else top


def _warp_tile(
    src: rasterio.DatasetReader,
    name: str,
    band: int,
    target: CRS | None,
    transform: Affine,
    rows: int,
    cols: int,
    resampling: Resampling,
    same_frame: bool,
    whole: bool,
) -> _TilePart:
    out = np.full((rows, cols), np.nan, dtype=np.float32)
    st = src.transform
    aligned = (
        same_frame
        and st.b == 0
        and st.d == 0
        and math.isclose(st.a, transform.a, rel_tol=1e-9)
        and math.isclose(st.e, transform.e, rel_tol=1e-9)
    )
    if aligned:
        # Same lattice: an exact copy of the overlapping window (no resampling at all), read
        # from the file straight into the grid (a windowed read: a crop reads only its cells).
        c_off = (st.c - transform.c) / transform.a
        r_off = (st.f - transform.f) / transform.e
        ci, ri = round(c_off), round(r_off)
        if abs(c_off - ci) < 1e-6 and abs(r_off - ri) < 1e-6:
            covered = np.zeros((rows, cols), dtype=bool)
            r0, c0 = max(ri, 0), max(ci, 0)
            r1, c1 = min(ri + src.height, rows), min(ci + src.width, cols)
            top = None
            if r1 > r0 and c1 > c0:
                window = Window(c0 - ci, r0 - ri, c1 - c0, r1 - r0)
                if c0 == 0 and c1 == cols:  # whole rows of the grid: a contiguous block
                    _read_band(src, band, name, window, out[r0:r1])
                else:
                    out[r0:r1, c0:c1] = _read_band(src, band, name, window)
                covered[r0:r1, c0:c1] = True
                top = _finite_max(out[r0:r1, c0:c1])
            elif whole:
                _read_band(src, band, name)  # refuses a tile that is all nodata
            return _TilePart(out, None, covered, None, top)
    win = _source_window(src, target, transform, rows, cols)
    data = _read_band(src, band, name, win)
    if (win.width, win.height) != (src.width, src.height):
        whole = False  # the source maximum over the grid's area is taken as for a crop
        st = st @ Affine.translation(win.col_off, win.row_off)
    from rasterio.warp import reproject

    if target is None:
        # Local metres: resample in the shared frame (GDAL wants a CRS; any metric one will do
        # since source and destination share it).
        frame = CRS.from_epsg(3857)
        src_crs, dst_crs = frame, frame
    else:
        src_crs, dst_crs = src.crs, target
    frames = {
        "src_transform": st,
        "src_crs": src_crs,
        "dst_transform": transform,
        "dst_crs": dst_crs,
    }
    reproject(
        source=data,
        destination=out,
        src_nodata=np.nan,
        dst_nodata=np.nan,
        resampling=resampling,
        **frames,
    )
    upper = np.full((rows, cols), np.nan, dtype=np.float32)
    reproject(
        source=data,
        destination=upper,
        src_nodata=np.nan,
        dst_nodata=np.nan,
        resampling=Resampling.max,
        **frames,
    )
    # The source cell under each grid cell's centre: 0 none (outside the footprint), 1 a nodata
    # cell, 2 a valid one.
    coverage = np.zeros((rows, cols), dtype=np.uint8)
    reproject(
        source=np.where(np.isfinite(data), 2, 1).astype(np.uint8),
        destination=coverage,
        dst_nodata=0,
        resampling=Resampling.nearest,
        **frames,
    )
    if whole:
        top = _finite_max(data)
    else:
        # Which source cells have their centre on the (cropped) grid: the grid's own coverage
        # warped back onto the tile's lattice.
        inside = np.zeros(data.shape, dtype=np.uint8)
        reproject(
            source=np.ones((rows, cols), dtype=np.uint8),
            destination=inside,
            src_transform=transform,
            src_crs=dst_crs,
            dst_transform=st,
            dst_crs=src_crs,
            dst_nodata=0,
            resampling=Resampling.nearest,
        )
        top = _finite_max(data[inside == 1])
    return _TilePart(out, upper, coverage > 0, (coverage == 2) & np.isfinite(out), top)


def _fill_nearest(values: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """NaN cells take the value of the nearest finite cell (all NaN stays all NaN)."""
    from scipy import ndimage

    missing = np.isnan(values)
    if not missing.any() or missing.all():
        return values
    idx = ndimage.distance_transform_edt(missing, return_distances=False, return_indices=True)
    return np.asarray(values[idx[0], idx[1]], dtype=np.float32)


# grids up to this many cells keep their filled heights on disk (terrain.memo; 16 MB at most,
# 256 MB in all: the maps used longest ago are forgotten first)
FILL_MEMO_CELLS = 4_000_000
_FILL_MEMO = DiskMemo(
    "fill", [__file__], versions=f"gdal {rasterio.__gdal_version__}", max_bytes=256 * 2**20
)


def fill_nodata(heights: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """Fill NaN cells by inverse-distance interpolation from the valid cells around them (GDAL's
    ``fillnodata``, a four-quadrant search as far as the grid is wide), then by nearest neighbour
    for any cell that search could not reach. Valid cells are returned unchanged.

    The search costs seconds on a tile with many holes (SRTM-3 N57E011 in UTM: 238,000 of 2.9 M
    cells, 2.4 s): grids up to :data:`FILL_MEMO_CELLS` remember their filled heights on disk
    (:class:`terrain.memo.DiskMemo`, keyed by the heights' bytes), the next load of the map reads
    them."""
    heights = np.ascontiguousarray(heights, dtype=np.float32)
    if heights.size > FILL_MEMO_CELLS:
        return _fill_now(heights)
    question = np.asarray(heights.shape, dtype=np.int64).tobytes() + heights.tobytes()
    data = _FILL_MEMO.get(question, lambda: _fill_now(heights).tobytes(), heights.nbytes)
    return np.frombuffer(data, dtype=np.float32).reshape(heights.shape).copy()


def _fill_now(heights: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    from rasterio.fill import fillnodata
    from scipy import ndimage

    valid = np.isfinite(heights)
    reach = float(max(heights.shape))
    filled = np.asarray(
        fillnodata(heights.copy(), mask=valid.astype(np.uint8), max_search_distance=reach),
        dtype=np.float32,
    )
    still = ~np.isfinite(filled)
    if still.any():
        idx = ndimage.distance_transform_edt(still, return_distances=False, return_indices=True)
        filled = filled[idx[0], idx[1]]
    filled[valid] = heights[valid]
    return filled
