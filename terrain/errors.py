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


class PluginError(TerrapathError, ImportError):
    """A plugin (an entry point of an installed package) cannot be used: its module or object
    is missing, it is not what its group expects, or two packages give the same name.  The
    message names the package, so the user knows what to fix or uninstall."""


class ContractError(TerrapathError, RuntimeError):
    """An algorithm broke the contract the loop relies on: an avoider returned something other
    than a decision, an optimiser evaluated a point outside its bounds.  The run ends with this
    one-line error and is never recorded as a success."""


def where(path: str | PathLike[str] | None, field: str | None = None) -> str:
    """Format the location part of a message: ``'file.yaml', field 'zones[2].diameter': ``."""
    parts = []
    if path is not None:
        parts.append(f"{str(path)!r}")
    if field:
        parts.append(f"field {field!r}")
    return (", ".join(parts) + ": ") if parts else ""
