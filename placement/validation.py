"""Validation of parsed YAML/JSON documents: one error line naming the file and the key path.

A :class:`Checker` is bound to the file it checks (``where``, usually its path)
and to the error class to raise (a :class:`~placement.errors.PlacementError`
subclass), so that every message reads ``where: key.path[i]: what is wrong``.
Each method returns the validated, converted value, so a parser reads as a
list of checks::

    c = Checker("my.yaml", PresetError)
    doc = c.mapping(data, "", {"name": "robot name", "v_max": "[m/s] base speed"}, required=("name",))
    speed = c.positive(doc["v_max"], "v_max")

YAML is read with :func:`read_yaml`, which refuses duplicate keys and reports
syntax errors with their line and column.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
from collections.abc import Hashable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np
import yaml

#: Integers with more bits than this are shown by their size, never in full: Python refuses to turn
#: an int of more than 4300 decimal digits into a string (and a long one makes no message).
SHOW_BITS = 128


def show(value: Any) -> str:
    """``str(value)`` that is safe and short for any parsed value: a huge integer (a YAML ``0x...``
    of 5,000 digits) becomes "an integer of N digits", a long string is cut."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > SHOW_BITS:
        digits = int(value.bit_length() * math.log10(2)) + 1
        return f"{'-' if value < 0 else ''}an integer of about {digits} digits"
    if isinstance(value, str):
        return value if len(value) <= 60 else value[:57] + "..."
    if isinstance(value, (int, float, bool)) or value is None:
        return str(value)
    return describe(value)


def join(path: str, key: Any) -> str:
    """Key path of ``key`` inside ``path``: ``"arms"`` + ``"right"`` -> ``"arms.right"``."""
    return f"{path}.{show(key)}" if path else show(key)


def describe(value: Any) -> str:
    """Short type description of a parsed value for error messages ("string 'abc'", "list", ...)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return f"string {value[:30]!r}"
    if isinstance(value, int) and value.bit_length() > SHOW_BITS:
        return show(value)
    if isinstance(value, (int, float)):
        return f"{value!r}"
    return type(value).__name__


def strict_json(data: Any, error: type[Exception], indent: int | None = 2) -> str:
    """``data`` as strict JSON text (``indent`` None: one line), as every command writes it; ``error``
    if it holds NaN or inf (JSON has no such numbers, and they would mean a silent wrong answer)."""
    try:
        return json.dumps(data, indent=indent, sort_keys=False, allow_nan=False)
    except ValueError:
        raise error("the result holds a non-finite number (NaN or inf); refusing to print invalid JSON") from None


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"duplicate key '{k[:60]}'" + (f" ({len(k):,} characters)" if len(k) > 60 else ""))
        out[k] = v
    return out


def parse_json(text: str) -> Any:
    """``text`` as JSON, a key given twice in one object refused (ValueError naming it; ``json.loads``
    would keep the last silently), as YAML documents are read (:func:`parse_yaml`)."""
    return json.loads(text, object_pairs_hook=_unique_pairs)


def one_line(text: str) -> str:
    """``text`` with every non-printable character (newline, tab, NUL, ...) escaped: an error stays one line."""
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ascii(ch)[1:-1] for ch in text)


class Checker:
    """Checks of one document; every failure raises ``error("where: path: message")``.

    Args:
        where: what is checked, first in every message (a file path or a name).
        error: exception class to raise (one-argument constructor).
    """

    def __init__(self, where: str, error: type[Exception]):
        self.where = where
        self.error = error

    def fail(self, path: str, message: str) -> NoReturn:
        """Raise the error for ``path`` (may be empty for the whole document)."""
        raise self.error(one_line(f"{self.where}: {path}: {message}" if path else f"{self.where}: {message}"))

    # -- containers ----------------------------------------------------
    def mapping(
        self, value: Any, path: str, allowed: Mapping[str, str] | Iterable[str], required: Iterable[str] = ()
    ) -> dict[str, Any]:
        """A mapping with string keys among ``allowed`` and every key of ``required``.

        ``allowed`` may map each key to a short description (with its unit), which
        the message for a missing required key repeats.
        """
        if not isinstance(value, dict):
            self.fail(path, f"expected a mapping, got {describe(value)}")
        names = dict(allowed) if isinstance(allowed, Mapping) else dict.fromkeys(allowed, "")
        for key in value:
            if not isinstance(key, str) or key not in names:
                self.fail(join(path, key), f"unknown key; allowed keys: {', '.join(sorted(names))}")
        for key in required:
            if key not in value:
                hint = f" ({names[key]})" if names.get(key) else ""
                self.fail(join(path, key), f"missing required key{hint}")
        return value

    def keyed(self, value: Any, path: str, minimum: int = 0) -> dict[str, Any]:
        """A mapping with non-empty string keys (names chosen by the user) and >= ``minimum`` entries."""
        if not isinstance(value, dict):
            self.fail(path, f"expected a mapping, got {describe(value)}")
        for key in value:
            if not isinstance(key, str) or not key.strip():
                self.fail(join(path, key), f"expected a non-empty string as name, got {describe(key)}")
        if len(value) < minimum:
            self.fail(path, f"expected at least {minimum} entr{'y' if minimum == 1 else 'ies'}, got {len(value)}")
        return value

    def sequence(
        self, value: Any, path: str, length: int | None = None, minimum: int = 0, what: str = "values"
    ) -> list[Any]:
        """A list of exactly ``length`` (if given) or at least ``minimum`` items."""
        if not isinstance(value, list):
            self.fail(path, f"expected a list of {what}, got {describe(value)}")
        if length is not None and len(value) != length:
            self.fail(path, f"expected {length} {what}, got {len(value)}")
        if len(value) < minimum:
            self.fail(path, f"expected at least {minimum} {what}, got {len(value)}")
        return value

    # -- scalars -------------------------------------------------------
    def number(self, value: Any, path: str, minimum: float | None = None, strict: bool = False) -> float:
        """A finite int or float (booleans refused), >= ``minimum`` (> if ``strict``)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {describe(value)}")
        try:
            v = float(value)
        except OverflowError:  # an int beyond the float range
            self.fail(path, "expected a finite number, got a number too large for a float")
        if not math.isfinite(v):
            self.fail(path, f"expected a finite number, got {value}")
        if minimum is not None and (v <= minimum if strict else v < minimum):
            self.fail(path, f"must be {'>' if strict else '>='} {minimum:g}, got {show(value)}")
        return v

    def positive(self, value: Any, path: str) -> float:
        """A finite number > 0."""
        return self.number(value, path, 0.0, strict=True)

    def integer(self, value: Any, path: str, minimum: int | None = None) -> int:
        """An int (booleans and floats such as 1.5 refused), >= ``minimum``."""
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {describe(value)}")
        if minimum is not None and value < minimum:
            self.fail(path, f"must be >= {minimum}, got {show(value)}")
        return value

    def string(self, value: Any, path: str) -> str:
        """A non-empty string."""
        if not isinstance(value, str) or not value.strip():
            self.fail(path, f"expected a non-empty string, got {describe(value)}")
        return value

    def boolean(self, value: Any, path: str) -> bool:
        """``true`` or ``false``."""
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {describe(value)}")
        return value

    # -- compounds -----------------------------------------------------
    def vector(self, value: Any, path: str, length: int | None = None, what: str = "numbers") -> tuple[float, ...]:
        """A list of finite numbers, of exactly ``length`` items if given."""
        items = self.sequence(value, path, length, what=what)
        return tuple(self.number(v, f"{path}[{i}]") for i, v in enumerate(items))

    def names(self, value: Any, path: str, minimum: int = 0, what: str = "names") -> list[str]:
        """A list of distinct non-empty strings (at least ``minimum``)."""
        items = self.sequence(value, path, minimum=minimum, what=what)
        seen: dict[str, int] = {}
        for i, v in enumerate(items):
            self.string(v, f"{path}[{i}]")
            if v in seen:
                self.fail(f"{path}[{i}]", f"'{v}' is listed twice (also at [{seen[v]}])")
            seen[v] = i
        return list(items)


def finite_array(values: Any, what: str, error: type[Exception]) -> np.ndarray:
    """``values`` as a float array of any shape; anything but finite numbers raises ``error`` naming ``what``.

    For the public wrappers of numeric code: a NaN that reaches a numba kernel
    can end in a ZeroDivisionError or a silently wrong answer.
    """
    try:
        out = np.array(values, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise error(one_line(f"{what} must be an array of numbers, got {values!r:.60}")) from None
    if not np.all(np.isfinite(out)):
        raise error(f"{what} must hold finite numbers, got {np.array2string(out, threshold=12)}")
    return out


if TYPE_CHECKING:  # both have the same interface; the stubs cannot say which one loaded
    _SafeLoader = yaml.SafeLoader
else:
    _SafeLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class UniqueKeyLoader(_SafeLoader):
    """Safe loader (libyaml's when installed: ~10x faster) that refuses duplicate mapping keys.

    PyYAML silently keeps the last of two equal keys.
    """


def _construct_mapping(loader: UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False) -> dict[Hashable, Any]:
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            duplicate = key in seen
        except TypeError:  # an unhashable key: SafeLoader reports it itself
            continue
        if duplicate:
            raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return yaml.constructor.SafeConstructor.construct_mapping(loader, node, deep)


UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


#: A number as PyYAML resolves it, in the forms whose conversion is plain ``int()`` or ``float()``
#: (no underscores, octal, hexadecimal, sexagesimal, infinities or NaN: those take the plain path).
_NUMBER = r"[-+]?(?:[0-9]+\.[0-9]*(?:[eE][-+][0-9]+)?|0|[1-9][0-9]*)"
#: A whole line holding one flow sequence of such numbers as a block item or a plain key's value
#: (every part of it is matched one way only: no input makes the search backtrack more than linearly).
_NUMBERS_LINE = re.compile(
    r"^([ \t]*(?:-[ \t]+)*(?:[A-Za-z_][\w.-]*[ \t]*:[ \t]+)?)"
    rf"\[([ \t]*{_NUMBER}(?:[ \t]*,[ \t]*{_NUMBER})*[ \t]*)\]([ \t]*(?:#.*)?)$",
    re.MULTILINE,
)
_NUMBERS_TAG = "!placement-numbers"
#: Documents from this size [bytes] are read with :func:`_numbers_first`.
FAST_FROM = 64 * 2**10


class _NumbersLoader(UniqueKeyLoader):
    """:class:`UniqueKeyLoader` that reads a :data:`_NUMBERS_TAG` scalar as its list of numbers and
    counts them."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.numbers = 0


def _construct_numbers(loader: _NumbersLoader, node: yaml.ScalarNode) -> list[int | float]:
    loader.numbers += 1
    return [float(t) if "." in t else int(t) for t in (t.strip() for t in str(node.value).split(","))]


_NumbersLoader.add_constructor(_NUMBERS_TAG, _construct_numbers)


def _numbers_first(text: str) -> Any:
    """``text`` parsed as :class:`UniqueKeyLoader` parses it, lines of numbers in flow sequences
    (a grasp set's poses: most of a large scene) read as one scalar each and split in Python: a
    fraction of the time (PyYAML builds and resolves every scalar in Python).

    Each such ``[..]`` becomes a tagged scalar on the same line (line numbers stay). The result is
    kept only when every one came back as a list (none was inside a block scalar, a quoted string or
    a comment): then each stands where the flow sequence stood, and its numbers are those PyYAML
    resolves (:data:`_NUMBER`). Otherwise, or on any error, ``text`` is parsed as it is."""
    if _NUMBERS_TAG in text:  # its own tags would be counted as ours
        return yaml.load(text, Loader=UniqueKeyLoader)
    tagged, count = _NUMBERS_LINE.subn(rf"\1{_NUMBERS_TAG} '\2'\3", text)
    if count:
        loader = _NumbersLoader(tagged)
        try:
            data = loader.get_single_data()
            if loader.numbers == count:
                return data
        except (yaml.YAMLError, ValueError, OverflowError, RecursionError):
            pass  # the plain parse says what is wrong, where
        finally:
            loader.dispose()
    return yaml.load(text, Loader=UniqueKeyLoader)


def parse_yaml(text: str, where: str, error: type[Exception]) -> Any:
    """Parse YAML ``text``; a syntax error or duplicate key raises ``error`` with line and column.

    An empty document also raises (there is nothing to check). From :data:`FAST_FROM` bytes, lines
    of numbers are read first (:func:`_numbers_first`): the same result.
    """
    try:
        data = _numbers_first(text) if len(text) >= FAST_FROM else yaml.load(text, Loader=UniqueKeyLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        at = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = " ".join(str(exc.problem or exc.context or "syntax error").split())
        raise error(one_line(f"{where}: invalid YAML at {at}{problem}")) from None
    except RecursionError:
        raise error(one_line(f"{where}: invalid YAML: nested too deeply")) from None
    except (yaml.YAMLError, ValueError, OverflowError) as exc:
        # ValueError: PyYAML converts some scalars with int()/float() (e.g. huge timestamps, or an
        # integer of more than 4300 decimal digits, which Python refuses to convert)
        if "integer string conversion" in str(exc):
            raise error(one_line(f"{where}: invalid YAML: an integer of more than 4300 digits")) from None
        raise error(one_line(f"{where}: invalid YAML: {' '.join(str(exc).split()) or type(exc).__name__}")) from None
    if data is None:
        raise error(one_line(f"{where}: the file is empty"))
    return data


#: Largest YAML document read [bytes] unless a caller says otherwise (a scene of the largest
#: allowed size is a few megabytes; a bigger file is a mistake or an attack, not a scene).
MAX_YAML_BYTES = 16 * 2**20


def size_text(n: int) -> str:
    """A byte count as it reads best: ``16 MiB``, ``512 KiB``, ``300 bytes``."""
    for unit, factor in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n >= factor:
            return f"{n / factor:.3g} {unit}"
    return f"{n} bytes"


def read_regular(
    path: str | Path,
    error: type[Exception],
    where: str | None = None,
    max_bytes: int = MAX_YAML_BYTES,
    what: str = "file",
    prefix: int | None = None,
) -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``max_bytes``; else ``error`` naming it.

    Opened without blocking and checked on the open descriptor, so a FIFO, a device (``/dev/zero``),
    a directory or a symlink loop is refused at once instead of hanging or filling memory, and a file
    that grows while it is read is cut off at ``max_bytes`` + 1 and refused.
    """
    where = str(path) if where is None else where
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(os.fspath(path), flags)
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise error(one_line(f"{where}: cannot read the {what}: {reason}")) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = (
                "a directory"
                if stat.S_ISDIR(st.st_mode)
                else "a FIFO"
                if stat.S_ISFIFO(st.st_mode)
                else "a device"
                if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "a socket"
                if stat.S_ISSOCK(st.st_mode)
                else "not a regular file"
            )
            raise error(one_line(f"{where}: the {what} is {kind}, not a regular file"))
        if st.st_size > max_bytes:
            raise error(
                one_line(
                    f"{where}: the {what} is {size_text(st.st_size)}, more than the {size_text(max_bytes)} allowed"
                )
            )
        chunks, total = [], 0
        stop = max_bytes + 1 if prefix is None else min(prefix, max_bytes + 1)
        while total < stop:
            chunk = os.read(fd, min(1 << 20, stop - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as exc:
        raise error(one_line(f"{where}: cannot read the {what}: {exc.strerror or exc}")) from None
    finally:
        os.close(fd)
    if total > max_bytes:
        raise error(one_line(f"{where}: the {what} grew beyond the {size_text(max_bytes)} allowed while read"))
    return b"".join(chunks)


def read_text(
    path: str | Path,
    error: type[Exception],
    where: str | None = None,
    max_bytes: int = MAX_YAML_BYTES,
    what: str = "file",
) -> str:
    """:func:`read_regular` decoded as UTF-8 (a one-line ``error`` for anything else)."""
    where = str(path) if where is None else where
    data = read_regular(path, error, where, max_bytes, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(one_line(f"{where}: not a UTF-8 text file (byte {exc.start})")) from None


def read_yaml(
    path: str | Path, error: type[Exception], where: str | None = None, max_bytes: int = MAX_YAML_BYTES
) -> Any:
    """Read and parse the YAML file ``path`` (see :func:`parse_yaml`); ``where`` defaults to the path.

    Only a regular file of at most ``max_bytes`` is read (see :func:`read_regular`).
    """
    where = str(path) if where is None else where
    return parse_yaml(read_text(path, error, where, max_bytes), where, error)
