"""Reading the YAML/JSON files people write (danger zones, threats, ...): one place for reading
the text, parsing it safely and checking the ``terrapath: 1`` document header, so every file
type reports problems the same way (file, line, field, what was expected, what was found)."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from terrain.errors import DataFileError, InputError, where

FORMAT_VERSION = 1


def found(value: Any) -> str:
    """A short description of a value for an error message: ``'abc' (text)``, ``nothing (null)``."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"{value!r} (a boolean)"
    if isinstance(value, int | float):
        return repr(value)
    text = repr(value)
    text = text if len(text) <= 60 else text[:57] + "..."
    kinds: dict[type, str] = {str: "text", list: "a list", dict: "a mapping"}
    kind = kinds.get(type(value), type(value).__name__)
    return f"{text} ({kind})"


def read_document(path: Path, what: str, json_suffixes: Iterable[str] = ()) -> Any:
    """Parse a file: JSON for ``json_suffixes``, else YAML with the safe loader only.

    ``what`` names the expected file in messages ("a threat file")."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise DataFileError(f"{where(path)}no such file (expected {what})") from None
    except IsADirectoryError:
        raise DataFileError(f"{where(path)}is a folder, expected {what}") from None
    except UnicodeDecodeError as exc:
        raise DataFileError(f"{where(path)}not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise DataFileError(f"{where(path)}cannot be read: {exc.strerror or exc}") from None
    if path.suffix.lower() in tuple(json_suffixes):
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise DataFileError(
                f"{where(path)}not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
            ) from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or " ".join(str(exc).split())
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        raise DataFileError(f"{where(path)}not valid YAML{at}: {problem}") from None


def check_header(
    data: Any, path: Path, list_key: str, allowed: Iterable[str], items: str
) -> dict[str, Any]:
    """The document must be a mapping with ``terrapath: 1``, only ``allowed`` keys, and a
    ``list_key`` entry (``items`` names its contents in messages: "zones", "threats")."""
    keys = tuple(allowed)
    if not isinstance(data, dict):
        what = "an empty file" if data is None else found(data)
        raise DataFileError(
            f"{where(path)}expected a mapping with 'terrapath: 1' and '{list_key}', found {what}"
        )
    if "terrapath" not in data:
        raise DataFileError(
            f"{where(path, 'terrapath')}missing format version key; expected 'terrapath: 1'"
        )
    version = data["terrapath"]
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise DataFileError(
            f"{where(path, 'terrapath')}expected format version {FORMAT_VERSION}, found {found(version)}"
        )
    unknown = [str(k) for k in data if k not in keys]
    if unknown:
        raise InputError(
            f"{where(path)}unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(keys)}"
        )
    if list_key not in data:
        raise DataFileError(f"{where(path, list_key)}missing; expected a list of {items}")
    return data
