"""Running a campaign: each run a 6-DOF replay (:func:`execute`, a plain function of a picklable
:class:`~replay.campaign.spec.Run`), on one of three executors, every finished run written to the
store at once by the calling process (the only writer):

- ``pool`` (default): a process pool on this machine (``jobs`` processes; 1: in this process);
- ``dask-local``: a local Dask distributed cluster of ``jobs`` single-threaded worker processes;
- ``scheduler``: a running Dask scheduler (``tcp://HOST:PORT``), whose workers must have this
  terrapath installed.

A run's result depends only on its :class:`Run` (its seeds are in it), so every executor gives
the same rows; only ``wall_s`` and ``finished_utc`` differ.  A run that raises is stored as an
error with its message, and the campaign goes on.

MCAPs: ``keep="all"`` records every run; ``"failures"`` (the default) flies each run unrecorded
and re-flies a failed one with the recorder (a replay is deterministic: the same result, now
recorded); ``"none"`` records nothing.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from planner.imports import is_foreign
from replay.campaign.spec import Run, Spec
from replay.campaign.store import Store
from replay.campaign.workers import bind_to_parent, end_workers
from terrain.atomic import make_folder, remove_stale_parts
from terrain.errors import InputError, NoRoomError

KEEP = ("none", "failures", "all")
EXECUTORS = ("pool", "dask-local", "scheduler")
CLUSTER_EXTRA = "pip install 'terrapath[cluster]'"
SCHEDULER_TIMEOUT_S = 8.0  # the issue: a clear error within 10 s
_MISSIONS: dict[str, Any] = {}  # per process: the missions read so far


def scenario(run: Run) -> Any:
    """The run's threats: its row's file (a path: the replay reads it over the mission's map),
    or its generator's draw from the scenario seed."""
    import numpy as np

    from planner.mission import load_mission
    from replay.campaign.generators import file_records, threat_generator
    from replay.threats.file import threats_from_records

    if run.row.file is not None:
        return str(run.row.file)  # read by the replay, with the mission's map
    mission = _MISSIONS.get(str(run.mission))
    if mission is None:
        if run.dem and is_foreign(run.mission):
            from replay.source import mission_on_terrain

            mission = mission_on_terrain(str(run.mission), run.dem, None, None)[0]
        else:
            mission = load_mission(run.mission)
        _MISSIONS[str(run.mission)] = mission
    assert run.generator is not None and run.row.count is not None
    rng = np.random.default_rng(run.scenario_seed)
    make = threat_generator(run.generator)
    assert make is not None  # the spec checked the name
    records = make(mission, run.row.count, rng, run.params)
    return threats_from_records(file_records(records), name=f"{run.key} ({run.generator})")


def case(run: Run) -> tuple[Any, Any, dict[str, Any]]:
    """A case generator's run: (its mission, its threats, its notes), drawn from the scenario
    seed."""
    import numpy as np

    from planner.mission import mission_from_dict
    from replay.campaign.generators import case_generator, file_records
    from replay.threats.file import threats_from_records

    assert run.generator is not None
    rng = np.random.default_rng(run.scenario_seed)
    g = case_generator(run.generator)
    assert g is not None  # the spec checked the name
    doc, records, notes = g.make(rng, run.row)
    mission = mission_from_dict(doc, f"{run.key} ({run.generator})")
    threats = threats_from_records(file_records(records), name=f"{run.key} ({run.generator})")
    return mission, threats, notes


def _sensor_range(run: Run, option: str) -> float:
    """The replay's ``radar_range`` (also the cooperative sensor's) or ``rangefinder_range``: the
    spec's ``sensor_range`` for the run's sensor, the replay's default otherwise."""
    from replay.sim import ReplayConfig

    default = float(getattr(ReplayConfig, option))
    if run.sensor_range is None:
        return default
    mine = "rangefinder_range" if run.sensor == "rangefinder" else "radar_range"
    return run.sensor_range if option == mine else default


def mcap_name(run: Run) -> str:
    return run.key.replace("/", "__").replace("[", "(").replace("]", ")") + ".mcap"


def execute(
    run: Run,
    spec_name: str,
    spec_hash: str,
    version: str,
    command: str,
    keep: str,
    mcap_dir: str | None,
) -> dict[str, Any]:
    """Fly one run and return its store row (never raises: an error becomes the row)."""
    import numpy as np

    from replay.run import ReplayRequest, run_replay

    t0 = time.perf_counter()
    row: dict[str, Any] = {
        "run_hash": run.run_hash,
        "spec_name": spec_name,
        "spec_hash": spec_hash,
        "key": run.key,
        "mission": run.mission.stem,
        "row": run.row.label,
        "count": run.row.count,
        "avoider": run.avoider.label,
        "run": run.index,
        "seed": run.seed,
        "scenario_seed": run.scenario_seed,
        "version": version,
        "mcap": None,
    }
    try:
        notes: dict[str, Any] | None = None
        if run.makes_cases:
            source, threats, notes = case(run)
        else:
            source, threats = str(run.mission), scenario(run)
        request = ReplayRequest.of(
            source,
            threats=threats,
            avoid=run.avoider.name,
            avoid_options=dict(run.avoider.options),
            seed=run.seed,
            sensor=run.sensor,
            margin=run.margin,
            duration=run.duration,
            command=f"{command} --only '{run.key}'",
            software_version=version,
            radar_range=_sensor_range(run, "radar_range"),
            rangefinder_range=_sensor_range(run, "rangefinder_range"),
            wind=run.row.wind,
            # the spec's DEM carries the missions of other tools (lon/lat, no terrain named)
            dem=run.dem if not run.makes_cases and is_foreign(run.mission) else (),
        )
        out = None if keep != "all" or mcap_dir is None else str(Path(mcap_dir) / mcap_name(run))
        result = run_replay(request, out)
        if keep == "failures" and mcap_dir is not None and not result.metrics.success:
            out = str(Path(mcap_dir) / mcap_name(run))
            result = run_replay(request, out)
        m = result.metrics
        metrics = m.as_dict()
        # the length of the final waypoint list: the "optimised path length" of seed 000's tables
        wps = np.asarray(result.waypoints, dtype=np.float64)
        metrics["waypoint_list_length_m"] = float(
            np.linalg.norm(np.diff(wps, axis=0), axis=1).sum()
        )
        if notes is not None:
            metrics["case"] = notes
        # every decision's compute time (ms): a suite's pooled percentiles (mean and max above)
        metrics["decision_times_ms"] = [
            round(1000.0 * float(d.get("compute_s", 0.0)), 3) for d in result.decisions
        ]
        row.update(
            status="ok",
            success=bool(m.success),
            end_reason=m.end_reason,
            metrics=metrics,
            mcap=out,
            error=None,
        )
    except NoRoomError:  # no room for the recording: every later run would fail the same way
        raise
    except Exception as exc:  # the campaign goes on; the row says what happened
        row.update(
            status="error",
            success=None,
            end_reason=None,
            metrics=None,
            error=f"{type(exc).__name__}: {exc}",
        )
    row["wall_s"] = time.perf_counter() - t0
    row["finished_utc"] = datetime.now(UTC).isoformat(timespec="seconds")
    return row


def warm_up(run: Run) -> None:
    """Fly the first 10 s of ``run`` in this worker process and forget it: the imports and the
    compiled kernels (from numba's cache) are then paid once per worker, not by its first run
    (whose decision times would carry them)."""
    execute(replace(run, duration=10.0), "warm-up", "", "", "", "none", None)


def start_worker(run: Run, parent: int) -> None:
    """A pool worker's first work: end with the campaign (:mod:`replay.campaign.workers`), then
    :func:`warm_up`."""
    bind_to_parent(parent)
    warm_up(run)


def _pool(tasks: list[tuple[Run, tuple[Any, ...]]], jobs: int) -> Iterator[dict[str, Any]]:
    """Each (run, :func:`execute`'s other arguments) flown in a process pool of ``jobs``
    workers (in this process with one), the rows as they finish."""
    if jobs <= 1:
        for r, args in tasks:
            yield execute(r, *args)
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed

    before = {p.pid for p in multiprocessing.active_children()}
    pool = ProcessPoolExecutor(
        max_workers=jobs, initializer=start_worker, initargs=(tasks[0][0], os.getpid())
    )
    try:
        futures = [pool.submit(execute, r, *args) for r, args in tasks]
        for f in as_completed(futures):
            yield f.result()
    except BaseException:  # SIGTERM, Ctrl-C, a full disk: the workers' runs are not waited for
        end_workers(p for p in multiprocessing.active_children() if p.pid not in before)
        for folder in {args[-1] for _, args in tasks if args[-1] is not None}:
            remove_stale_parts(folder)  # the recordings the workers were writing
        raise
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def require_dask() -> None:
    """A one-line error naming the extra when Dask is not installed."""
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise InputError(f"a Dask executor needs the optional extra: {CLUSTER_EXTRA}") from None


def _dask_client(scheduler: str | None, jobs: int) -> Any:
    require_dask()
    import logging

    from dask.distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)  # its INFO lines are not ours
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=max(1, jobs),
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        return Client(cluster)
    _refused(scheduler)
    try:
        return Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT_S:g}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(
            f"the Dask scheduler {scheduler} does not answer within {SCHEDULER_TIMEOUT_S:g} s ({exc})"
        ) from None


def _refused(scheduler: str) -> None:
    """The one-line error at once when a ``tcp://`` scheduler's port refuses the connection
    (nothing listens there: Dask's client would retry for :data:`SCHEDULER_TIMEOUT_S`)."""
    import socket
    from urllib.parse import urlsplit

    try:
        where = urlsplit(scheduler)
        host, port = where.hostname, where.port
    except ValueError:
        return  # Dask's own error names it
    if where.scheme != "tcp" or host is None or port is None:
        return
    try:
        socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT_S).close()
    except ConnectionRefusedError as exc:
        raise InputError(
            f"the Dask scheduler {scheduler} does not answer: nothing listens there ({exc})"
        ) from None
    except OSError:
        return  # unreachable or slow: Dask's client tries, within its timeout


def check_scheduler(address: str) -> None:
    """Connect to the scheduler once (a clear error within :data:`SCHEDULER_TIMEOUT_S` when it
    does not answer), before anything is written."""
    _dask_client(address, 1).close()


def _dask(
    runs: list[Run], args: tuple[Any, ...], jobs: int, scheduler: str | None
) -> Iterator[dict[str, Any]]:
    client = _dask_client(scheduler, jobs)
    try:
        from dask.distributed import as_completed

        client.run(warm_up, runs[0])  # every worker there now (later ones warm on their first run)

        futures = [client.submit(execute, r, *args, pure=False) for r in runs]
        for f in as_completed(futures):
            yield f.result()
    finally:
        cluster = getattr(client, "cluster", None)
        client.close()
        if cluster is not None and scheduler is None:
            cluster.close()


def run_campaign(
    spec: Spec,
    store: Store,
    *,
    version: str,
    command: str,
    jobs: int = 1,
    executor: str = "pool",
    scheduler: str | None = None,
    only: str | None = None,
    keep: str = "failures",
    mcap_dir: str | Path | None = None,
    report: Callable[[dict[str, Any], int, int], None] | None = None,
) -> tuple[list[Run], list[dict[str, Any]]]:
    """Fly the campaign's missing runs (or the one ``only`` names, again), writing each row as it
    finishes; returns (the campaign's runs, the rows flown now).  ``report(row, done, total)``
    after each."""
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if keep not in KEEP:
        raise InputError(f"--keep-mcap {keep!r}: expected one of {', '.join(KEEP)}")
    runs = spec.all_runs()
    todo = [spec.find(only)] if only is not None else _missing(runs, store)
    folder = None
    if keep != "none":
        folder = (
            Path(mcap_dir)
            if mcap_dir is not None
            else store.path.parent / f"{store.path.stem}-mcap"
        )
        make_folder(folder)
        remove_stale_parts(folder)  # recordings a killed campaign left half-written
    args = (
        spec.name,
        spec.spec_hash,
        version,
        command,
        keep,
        None if folder is None else str(folder),
    )
    stream: Iterable[dict[str, Any]]
    if not todo:
        stream = ()
    elif executor == "pool":
        stream = _pool([(r, args) for r in todo], jobs)
    else:
        stream = _dask(todo, args, jobs, scheduler if executor == "scheduler" else None)
    return runs, _stored(stream, store, len(todo), report)


def _missing(runs: list[Run], store: Store) -> list[Run]:
    """The runs the store holds no row of."""
    have = store.done(r.run_hash for r in runs)
    return [r for r in runs if r.run_hash not in have]


def _stored(
    stream: Iterable[dict[str, Any]],
    store: Store,
    total: int,
    report: Callable[[dict[str, Any], int, int], None] | None,
) -> list[dict[str, Any]]:
    """Each row of ``stream`` written to the store as it comes (then ``report(row, done,
    total)``); the rows."""
    flown: list[dict[str, Any]] = []
    for row in stream:
        store.put(row)
        flown.append(row)
        if report is not None:
            report(row, len(flown), total)
    return flown


def run_campaigns(
    specs: Sequence[Spec],
    store: Store,
    *,
    version: str,
    commands: Sequence[str],
    jobs: int = 1,
    report: Callable[[dict[str, Any], int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """The missing runs of several campaigns flown in one process pool (no recordings kept:
    ``terrapath regress``), each row written as it finishes; returns the rows flown now.  One
    pool for all balances the cores to the last run and starts its workers once."""
    tasks: list[tuple[Run, tuple[Any, ...]]] = []
    for spec, command in zip(specs, commands, strict=True):
        args = (spec.name, spec.spec_hash, version, command, "none", None)
        tasks += [(r, args) for r in _missing(spec.all_runs(), store)]
    return _stored(_pool(tasks, jobs) if tasks else (), store, len(tasks), report)


def wilson(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval (95 %) of a success rate."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)  # exact ends, not 1 - 1e-16
    return lo, hi


__all__ = [
    "EXECUTORS",
    "KEEP",
    "check_scheduler",
    "execute",
    "mcap_name",
    "run_campaign",
    "run_campaigns",
    "scenario",
    "wilson",
]
