"""The one error root of terrapath.

Every error a user can cause derives from :class:`TerrapathError`; the subclasses also derive from
the matching built-in (``ValueError`` for bad values, ``OSError`` for files that cannot be read) so
that callers who do not know terrapath can still catch them.  Messages say what was expected, what
was found and where (file, field).  The command line prints the message and exits non-zero.

This module lives in ``terrain`` because ``terrain`` is the bottom of the import chain
(``terrain <- planner <- replay <- terrapath``); the other packages import it from here.
"""

from __future__ import annotations

from os import PathLike


class TerrapathError(Exception):
    """Root of every error terrapath raises on purpose."""


class InputError(TerrapathError, ValueError):
    """A value given by the user is invalid (a field, an option, a coordinate)."""


class DataFileError(TerrapathError, OSError):
    """A file is missing, unreadable, or not what it should be (not a raster, wrong structure)."""


class NoRoomError(DataFileError):
    """An output could not be written for lack of room (a full disk, a quota, a size limit)."""


class ResourceError(InputError):
    """The request would need more memory (or other resources) than the machine has."""


def where(path: str | PathLike[str] | None, field: str | None = None) -> str:
    """Format the location part of a message: ``'file.yaml', field 'zones[2].diameter': ``."""
    parts = []
    if path is not None:
        parts.append(f"{str(path)!r}")
    if field:
        parts.append(f"field {field!r}")
    return (", ".join(parts) + ": ") if parts else ""
