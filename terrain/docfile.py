"""Reading the YAML/JSON files people write (danger zones, threats, ...): one place for reading
the text, parsing it safely and checking the ``terrapath: 1`` document header, so every file
type reports problems the same way (file, line, field, what was expected, what was found)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

import yaml

from terrain.errors import DataFileError, InputError, where

FORMAT_VERSION = 1
MAX_DEPTH = 100  # nesting levels of lists and mappings a YAML document may have


class _DepthLimitedLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing documents nested deeper than :data:`MAX_DEPTH` (a
    thousand nested lists made the composer recurse out of the stack: a RecursionError)."""

    _depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None,
                    None,
                    f"nested deeper than {MAX_DEPTH} levels",
                    self.peek_event().start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def parse_yaml(text: str | bytes, label: str) -> Any:
    """``text`` parsed with the safe loader, nesting limited to :data:`MAX_DEPTH` levels.

    A document that is not YAML raises a one-line DataFileError naming ``label`` (the file, or
    ``'run.mcap', attachment 'mission.yaml'``), the line and the column, and PyYAML's words for
    the problem with only its grammar tokens quoted (:func:`_grammar_only`): never the content of
    a file that may not be ours.

    Parsed by libyaml where PyYAML has it (:func:`_parse_fast`: a 100-threat file in 10 ms
    instead of 100, issue 38); a document libyaml refuses, or one nested too deep, is parsed
    again by the pure-Python loader, whose words the message quotes."""
    if _CLoader is not None:
        try:
            return _parse_fast(text)
        except (yaml.YAMLError, _TooDeep, RecursionError):
            pass
    loader = None
    try:
        loader = _DepthLimitedLoader(text)  # (its reader refuses a special character here)
        return loader.get_single_data()
    except yaml.reader.ReaderError as exc:
        code = exc.character if isinstance(exc.character, int) else ord(exc.character)
        raise DataFileError(
            f"{label}: not valid YAML at character {exc.position + 1}: {exc.reason} (#x{code:02x})"
        ) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = re.sub(r"'([^']*)'", _grammar_only, getattr(exc, "problem", None) or "")
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        raise DataFileError(
            f"{label}: not valid YAML{at}{': ' + problem if problem else ''}"
        ) from None
    except RecursionError:  # pragma: no cover - the depth limit comes first
        raise DataFileError(f"{label}: nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()


class _TooDeep(Exception):
    """A document nested deeper than :data:`MAX_DEPTH` (:func:`_parse_fast`)."""


_CLoader: Any = getattr(yaml, "CSafeLoader", None)  # PyYAML built without libyaml: None


def _parse_fast(text: str | bytes) -> Any:
    """``text`` composed by libyaml's parser (PyYAML's ``CSafeLoader``: the same resolver and
    safe constructor as :class:`_DepthLimitedLoader`, so the same values), its node tree's depth
    checked (walked without recursion, each node once), then constructed; YAMLError or
    :class:`_TooDeep` for the caller to parse it again with the pure-Python loader (its messages
    are the ones terrapath quotes)."""
    loader = _CLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        stack = [(node, 1)]
        seen: set[int] = set()  # an anchored node is walked once (aliases: no blow-up)
        while stack:
            n, depth = stack.pop()
            if depth > MAX_DEPTH:
                raise _TooDeep
            if id(n) in seen:
                continue
            seen.add(id(n))
            if isinstance(n, yaml.SequenceNode):
                stack += [(c, depth + 1) for c in n.value]
            elif isinstance(n, yaml.MappingNode):
                stack += [(v, depth + 1) for kv in n.value for v in kv]
        return loader.construct_document(node)
    finally:
        loader.dispose()


def _grammar_only(quoted: re.Match[str]) -> str:
    """A quoted bit of PyYAML's problem kept when it names the grammar (``','``, ``'<stream
    end>'``), dropped when it may be the file's content (an alias, a tag, a character)."""
    text = quoted.group(1)
    return (
        quoted.group(0)
        if text in (",", "[", "]", "{", "}", ":", "-", "?")
        or (text.startswith("<") and text.endswith(">"))
        else "(...)"
    )


def kind_of(value: Any) -> str:
    """What a parsed document is, without its content (for a file that may not be ours)."""
    if value is None:
        return "an empty file"
    kinds: dict[type, str] = {str: "text", list: "a list", dict: "a mapping", bool: "a boolean"}
    return kinds.get(type(value), "a number" if isinstance(value, int | float) else "a value")


def finite_number(value: Any, what: str) -> float:
    """``value`` as a finite float (bools, text, NaN and infinities refused: ``what`` names it)."""
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError):
        out = math.nan
    if isinstance(value, bool) or not math.isfinite(out):
        raise InputError(f"{what} must be a finite number; got {value!r}")
    return out


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


def read_text(path: Path, what: str, encoding: str = "utf-8") -> str:
    """The text of ``path``; a one-line DataFileError naming it and ``what`` was expected
    when it is missing, a folder, not UTF-8 or unreadable."""
    try:
        return path.read_text(encoding=encoding)
    except FileNotFoundError:
        raise DataFileError(f"{where(path)}no such file (expected {what})") from None
    except IsADirectoryError:
        raise DataFileError(f"{where(path)}is a folder, expected {what}") from None
    except UnicodeDecodeError as exc:
        raise DataFileError(f"{where(path)}not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise DataFileError(f"{where(path)}cannot be read: {exc.strerror or exc}") from None


def read_document(path: Path, what: str, json_suffixes: Iterable[str] = ()) -> Any:
    """Parse a file: JSON for ``json_suffixes``, else YAML with the safe loader only.

    ``what`` names the expected file in messages ("a threat file")."""
    text = read_text(path, what)
    if path.suffix.lower() in tuple(json_suffixes):
        return parse_json(text, path)
    return parse_yaml(text, repr(str(path)))


def parse_json(text: str, path: str | PathLike[str]) -> Any:
    """``text`` parsed as JSON; a one-line DataFileError naming ``path``, the line and the
    column when it is not."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFileError(
            f"{where(path)}not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise DataFileError(f"{where(path)}not valid JSON: nested too deeply") from None


def check_header(
    data: Any, path: Path, list_key: str, allowed: Iterable[str], items: str
) -> dict[str, Any]:
    """The document must be a mapping with ``terrapath: 1``, only ``allowed`` keys, and a
    ``list_key`` entry (``items`` names its contents in messages: "zones", "threats")."""
    keys = tuple(allowed)
    if not isinstance(data, dict):
        raise DataFileError(
            f"{where(path)}expected a mapping with 'terrapath: 1' and '{list_key}', "
            f"found {kind_of(data)}"
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


def geojson_features(data: Any, path: Path) -> list[Any]:
    """The ``features`` list of a GeoJSON FeatureCollection, else a one-line error naming the key."""
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        what = found(data.get("type")) if isinstance(data, dict) else found(data)
        raise DataFileError(
            f"{where(path, 'type')}expected a GeoJSON FeatureCollection, found {what}"
        )
    features = data.get("features")
    if not isinstance(features, list):
        raise DataFileError(f"{where(path, 'features')}expected a list, found {found(features)}")
    return features


def feature_id(
    feature: dict[str, Any], props: dict[str, Any], field: str
) -> tuple[Any, str] | None:
    """The identifier a GeoJSON feature ``field`` gives, with the key it stands at: the first
    set of ``properties.id``, ``properties.name`` and the feature's own ``id``; None if none is."""
    pfield = f"{field}.properties"
    for value, at in (
        (props.get("id"), f"{pfield}.id"),
        (props.get("name"), f"{pfield}.name"),
        (feature.get("id"), f"{field}.id"),
    ):
        if value is not None:
            return value, at
    return None


def absolute_as_written(p: str | PathLike[str]) -> Path:
    """``p`` made absolute against the working directory, keeping ``..`` and symlinks as written
    (so that a message shows exactly what was looked for)."""
    q = Path(p).expanduser()
    return q if q.is_absolute() else Path.cwd() / q


def reference_places(written: str, holder: str | PathLike[str] | None) -> tuple[str, ...]:
    """Where a file named inside another file (``holder``) is looked for, in order: relative to
    the holder's folder, then as given (absolute, or relative to the working directory); made
    absolute, without repeats."""
    if holder is None or Path(written).is_absolute():
        places = [written]
    else:
        places = [str(Path(holder).parent.resolve() / written), written]
    return tuple(dict.fromkeys(str(absolute_as_written(q)) for q in places))


def find_reference(
    places: Sequence[str],
    written: str,
    *,
    holder: str | PathLike[str] | None,
    field: str,
    what: str,
    attachment: str | None = None,
    hint: str = "",
) -> str:
    """The first of ``places`` that exists (absolute).  Else a DataFileError naming the file that
    holds the reference (and the ``attachment`` of it that does), the field, what was written and
    every place looked: ``'m.yaml', field 'terrain.dem[0]': DEM 'a.tif' not found (looked for
    '/m/a.tif' and '/cwd/a.tif')`` followed by ``hint``."""
    for q in places:
        if Path(q).exists():
            return str(absolute_as_written(q))
    at = [repr(str(holder))] if holder is not None else []
    if attachment:
        at.append(f"attachment {attachment!r}")
    at.append(f"field {field!r}")
    quoted = [repr(q) for q in places]
    looked = " and ".join(filter(None, [", ".join(quoted[:-1]), quoted[-1]]))
    raise DataFileError(
        f"{', '.join(at)}: {what} {written!r} not found (looked for {looked}){hint}"
    )
