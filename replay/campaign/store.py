"""The campaign store: one SQLite file (standard library ``sqlite3``, WAL journal), one row per run,
written as each run finishes.

A row is written in one transaction (``INSERT OR REPLACE`` of the run's identity), so a campaign
killed at any moment (Ctrl-C, SIGKILL, a power cut) loses no finished run and leaves no half row;
WAL mode and a 60 s busy timeout (:data:`BUSY_S`, also over the opening, where SQLite can answer
"locked" at once) let two campaigns write to one store at once.  The table
``meta`` holds the store format (:data:`FORMAT`) and the terrapath version that created it; a
store of another format is refused, naming both versions.

Columns of ``runs``: ``run_hash`` (the run's identity, :mod:`replay.campaign.spec`), the spec's
``spec_name`` and ``spec_hash``, the run ``key`` and its parts (``mission``, ``row``, ``count``,
``avoider``, ``run``), ``seed`` and ``scenario_seed``, the ``version`` of terrapath that flew it,
``status`` (``ok`` / ``error``), ``success``, ``end_reason``, ``metrics`` (the run's metrics as
JSON: ``RunMetrics.as_dict``), ``wall_s``, ``mcap`` (the kept recording, or NULL), ``error``
(the message of a run that raised) and ``finished_utc``.
"""

from __future__ import annotations

import json
import sqlite3
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from terrain.atomic import output_folder
from terrain.errors import DataFileError, InputError

FORMAT = "1"
BUSY_S = 60.0  # how long to wait for another campaign holding the store
COLUMNS = (
    *("run_hash", "spec_name", "spec_hash", "key", "mission", "row", "count", "avoider", "run"),
    *("seed", "scenario_seed", "version", "status", "success", "end_reason", "metrics"),
    *("wall_s", "mcap", "error", "finished_utc"),
)
_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    run_hash TEXT PRIMARY KEY,
    spec_name TEXT NOT NULL,
    spec_hash TEXT NOT NULL,
    key TEXT NOT NULL,
    mission TEXT NOT NULL,
    row TEXT NOT NULL,
    count INTEGER,
    avoider TEXT NOT NULL,
    run INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    scenario_seed INTEGER NOT NULL,
    version TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('ok', 'error')),
    success INTEGER,
    end_reason TEXT,
    metrics TEXT,
    wall_s REAL NOT NULL,
    mcap TEXT,
    error TEXT,
    finished_utc TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_by_spec ON runs (spec_name, mission, row, avoider);
"""

# What SQLite says when the disk (or a size limit) leaves no room
_NO_ROOM = frozenset({"database or disk is full", "disk I/O error"})


class Store:
    """A campaign store (module docstring); ``version`` is the terrapath writing to it."""

    def __init__(self, path: str | Path, version: str) -> None:
        self.path = Path(path)
        if self.path.is_dir():
            raise InputError(f"{self.path}: is a folder; the store is a file (results.sqlite)")
        output_folder(self.path)  # the store's folder, made if missing
        self.version = version
        deadline = time.monotonic() + BUSY_S
        while True:
            try:
                meta = self._open()
                break
            except sqlite3.DatabaseError as exc:
                # SQLite answers "locked" at once, without its busy handler, when two
                # connections open a new file together (one switching it to WAL while the other
                # reads its header): wait and open again, up to the busy timeout.
                locked = isinstance(exc, sqlite3.OperationalError) and "locked" in str(exc)
                if str(exc) in _NO_ROOM:  # a full disk, not a stranger's file
                    raise DataFileError(f"{str(self.path)!r}: cannot be written: {exc}") from None
                if not locked or time.monotonic() > deadline:
                    raise InputError(
                        f"{self.path}: not a terrapath campaign store ({exc})"
                    ) from None
                time.sleep(0.05)
        if meta.get("format") != FORMAT:
            self._db.close()
            raise InputError(
                f"{self.path}: written by terrapath {meta.get('created_by', '?')} (store format "
                f"{meta.get('format')!r}); this is terrapath {version}, which reads format "
                f"{FORMAT!r}: use a new store"
            )

    def _open(self) -> dict[str, str]:
        """Connect, make the file a store if it is empty, and return its ``meta`` table."""
        db = sqlite3.connect(self.path, timeout=BUSY_S, isolation_level=None)
        try:
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("BEGIN IMMEDIATE")
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if tables and "meta" not in tables:
                raise InputError(
                    f"{self.path}: an SQLite database, but not a terrapath campaign store "
                    f"(tables {', '.join(sorted(tables))})"
                )
            for statement in _SCHEMA.strip().split(";"):
                if statement.strip():
                    db.execute(statement)
            meta = dict(db.execute("SELECT key, value FROM meta").fetchall())
            if not meta:
                db.executemany(
                    "INSERT INTO meta (key, value) VALUES (?, ?)",
                    [("format", FORMAT), ("created_by", self.version)],
                )
                meta = {"format": FORMAT, "created_by": self.version}
            db.execute("COMMIT")
        except BaseException:
            db.close()  # closing rolls back an open transaction
            raise
        self._db = db
        return meta

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def done(self, hashes: Iterable[str]) -> set[str]:
        """The identities among ``hashes`` that have a row."""
        wanted = list(hashes)
        have: set[str] = set()
        for i in range(0, len(wanted), 500):
            chunk = wanted[i : i + 500]
            marks = ",".join("?" * len(chunk))
            rows = self._db.execute(f"SELECT run_hash FROM runs WHERE run_hash IN ({marks})", chunk)
            have.update(r[0] for r in rows)
        return have

    def put(self, row: dict[str, Any]) -> None:
        """Write one run's row (one transaction)."""
        values = [
            json.dumps(row[c], sort_keys=True)
            if c == "metrics" and row.get(c) is not None
            else row.get(c)
            for c in COLUMNS
        ]
        marks = ",".join("?" * len(COLUMNS))
        try:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.execute(
                    f"INSERT OR REPLACE INTO runs ({','.join(COLUMNS)}) VALUES ({marks})", values
                )
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")
        except sqlite3.OperationalError as exc:  # "database or disk is full", "disk I/O error"
            if "locked" in str(exc):
                raise
            raise DataFileError(
                f"{str(self.path)!r}: cannot write the row of run {row.get('key')!r}: {exc}"
            ) from None

    def rows(
        self, spec_name: str | None = None, hashes: Iterable[str] | None = None
    ) -> list[dict[str, Any]]:
        """Rows (metrics decoded), in key order; of one spec name, or of the given identities."""
        query = f"SELECT {','.join(COLUMNS)} FROM runs"
        args: list[Any] = []
        if spec_name is not None:
            query += " WHERE spec_name = ?"
            args.append(spec_name)
        out = []
        for values in self._db.execute(query + " ORDER BY key", args):
            row = dict(zip(COLUMNS, values, strict=True))
            if row["metrics"] is not None:
                row["metrics"] = json.loads(row["metrics"])
            out.append(row)
        if hashes is not None:
            keep = set(hashes)
            out = [r for r in out if r["run_hash"] in keep]
        return out


__all__ = ["COLUMNS", "FORMAT", "Store"]
