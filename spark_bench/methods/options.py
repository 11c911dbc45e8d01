"""A method's options as data: what a method accepts (:class:`MethodOption`), the ``--method-args
key=value,...`` text, a configuration file's ``[method]`` table, and the one function that checks and types
them (:func:`resolve_options`) before the method's factory sees them.

Standard library only: ``spark-bench eval --help`` and the command line's checks import it before any method.
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from spark_bench.errors import InputError, SparkBenchError

#: The kinds of :class:`MethodOption`.
KINDS = ("str", "path", "int", "float", "bool", "any")
#: The key under which a configuration file holds the method's options.
METHOD_TABLE = "method"


@dataclass(frozen=True)
class MethodOption:
    """One key a method's factory accepts (a method class lists them in its ``accepts`` mapping).

    :param help: what the value is, in a few words (shown by ``--method-args help`` and in errors)
    :param kind: ``str`` (the text as given), ``path`` (a file or folder, made absolute where the command
        runs, since workers may run elsewhere; an empty path is no path), ``int``, ``float``, ``bool``, or
        ``any`` (a JSON scalar where the text parses as one, else the text)
    """

    help: str
    kind: str = "str"

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"option kind {self.kind!r} is not one of {KINDS}")


class Text(str):
    """A value as typed on the command line (``--method-args``): its kind decides what it becomes."""


def split_method_args(text: str) -> list[str]:
    """``key=value`` items of one ``--method-args`` text: split at the commas outside double quotes."""
    items, current, quoted, escaped = [], [], False, False
    for char in text:
        if char == "," and not quoted:
            items.append("".join(current))
            current = []
            continue
        current.append(char)
        if escaped:
            escaped = False
        elif char == "\\" and quoted:
            escaped = True
        elif char == '"':
            quoted = not quoted
    if quoted:
        raise SparkBenchError(f"--method-args {text!r}: a double quote is not closed")
    items.append("".join(current))
    return [item for item in items if item.strip()]


def parse_method_args(texts: Iterable[str]) -> dict[str, Text]:
    """The options of ``--method-args`` texts (``key=value,key2=value2``; the flag may repeat), each value the
    :class:`Text` as given (quoted with double quotes, JSON style, when it holds a comma).

    :raises SparkBenchError: for an item without ``=``, an empty key, or a key given twice
    """
    out: dict[str, Text] = {}
    for text in texts:
        for item in split_method_args(text):
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep or not key:
                raise SparkBenchError(f"--method-args: {item.strip()!r} is not KEY=VALUE")
            if key in out:
                raise SparkBenchError(f"--method-args: {key!r} is given twice")
            out[key] = Text(value.strip())
    return out


def scalar(text: str):
    """A JSON scalar (number, ``true``/``false``, ``null``, a quoted string) where ``text`` parses as one, else
    ``text`` itself."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return str(text)
    return value if value is None or isinstance(value, str | int | float | bool) else str(text)


def _unquoted(text: str) -> str:
    """The text of a value, its JSON double quotes removed where it is quoted."""
    if len(text) >= 2 and text.startswith('"') and text.endswith('"'):
        value = scalar(text)
        if isinstance(value, str):
            return value
    return str(text)


def typed(method: str, key: str, value, option: MethodOption | None, base: Path | None = None):
    """``value`` as option ``key`` of ``method`` takes it (:class:`MethodOption` ``kind``); a :class:`Text` of an
    undeclared option becomes a JSON scalar where it parses, any other value is kept.

    :raises SparkBenchError: naming the method and the key, for a value of the wrong kind
    """
    if value is None:
        return None
    kind = option.kind if option else "any"
    if kind == "any":
        return scalar(value) if isinstance(value, Text) else value
    if isinstance(value, Text):
        value = _unquoted(value) if kind in ("str", "path") else scalar(value)
    try:
        return _convert(kind, value, base)
    except (TypeError, ValueError):
        raise SparkBenchError(f"--method {method}: option {key} must be {_KIND_WORDS[kind]}, got {value!r}") from None


_KIND_WORDS = {"str": "text", "path": "a path", "int": "a whole number", "float": "a number",
               "bool": "true or false"}


def _convert(kind: str, value, base: Path | None):
    if kind == "bool":
        if not isinstance(value, bool):
            raise TypeError
        return value
    if kind in ("int", "float"):
        if isinstance(value, bool) or not isinstance(value, int | float | str):
            raise TypeError
        number = float(value)
        if kind == "int" and not number.is_integer():
            raise ValueError
        return int(number) if kind == "int" else number
    if not isinstance(value, str | int | float) or isinstance(value, bool):
        raise TypeError
    if kind == "path":
        if not isinstance(value, str):
            raise TypeError
        if not value:
            return None
        path = Path(value).expanduser()
        return str((path if path.is_absolute() or base is None else base / path).resolve())
    return str(value)


def resolve_options(method: str, options: Mapping, accepts: Mapping[str, MethodOption] | None,
                    base: Path | None = None) -> dict:
    """The options ``method``'s factory receives: checked against what it accepts (``None``: it does not say,
    every key passes) and typed by each option's kind; None values (and empty paths) are left out.

    :param base: the folder relative paths are taken from (default: the current folder)
    :raises SparkBenchError: naming the method and the keys it accepts, for a key it does not accept, or a
        value of the wrong kind
    """
    if accepts is not None:
        unknown = sorted(set(options) - set(accepts))
        if unknown:
            takes = ", ".join(sorted(accepts)) if accepts else "none"
            raise SparkBenchError(f"--method {method} takes no option {', '.join(unknown)} "
                                  f"(its options: {takes}; --method {method} --method-args help)")
    out = {}
    for key, value in options.items():
        value = typed(method, key, value, accepts.get(key) if accepts else None, base)
        if value is not None:
            out[key] = value
    return out


def describe_options(method: str, accepts: Mapping[str, MethodOption] | None) -> str:
    """What ``--method METHOD --method-args help`` prints: each option, its kind and what it is."""
    if accepts is None:
        return f"--method {method} does not declare its options: it receives every --method-args key as given\n"
    if not accepts:
        return f"--method {method} takes no options\n"
    width = max(len(key) for key in accepts)
    lines = [f"--method {method} --method-args KEY=VALUE,... (or a config file's [{METHOD_TABLE}] table):"]
    lines += [f"  {key:<{width}}  {option.kind:<5}  {option.help}" for key, option in sorted(accepts.items())]
    return "\n".join(lines) + "\n"


def read_config_file(path: str | Path) -> dict:
    """A configuration file (TOML for a ``.toml`` file, else JSON, as ``ours`` and methods files read theirs)
    as a dict.

    :raises InputError: for a missing, unreadable or malformed file, or one that is not a table
    """
    path = Path(path).expanduser()
    try:
        text = path.read_text()
        data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
    except FileNotFoundError:
        raise InputError(path, "config file not found") from None
    except (OSError, json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"malformed config: {exc}") from None
    if not isinstance(data, dict):
        raise InputError(path, "a config file must be a table (a JSON object)")
    return data


def config_file_options(path: str | Path) -> tuple[dict, list[str]]:
    """The method options of a configuration file: its ``[method]`` table, and the names of its other tables
    (which configure the method itself: :func:`with_config_file`).

    :raises InputError: when the file is malformed or ``[method]`` is not a table
    """
    data = read_config_file(path)
    table = data.get(METHOD_TABLE, {})
    if not isinstance(table, dict):
        raise InputError(path, f"[{METHOD_TABLE}] must be a table of the method's options")
    return dict(table), sorted(k for k in data if k != METHOD_TABLE)


def with_config_file(method: str, path: str | Path, options: dict, others: list[str],
                     accepts: Mapping[str, MethodOption] | None) -> dict:
    """``options`` and ``config = path``: the tables ``others`` of the configuration file ``path`` besides
    ``[method]`` configure the method itself (``ours``' ``[prior]``, ``[optimize]``...), which its factory reads
    from its ``config`` option.

    :raises InputError: when the method takes no ``config`` option, or ``options`` names another config file
    """
    if accepts is not None and "config" not in accepts:
        raise InputError(path, f"its tables {others} would configure --method {method}, which takes no config "
                               f"file: put its options in [{METHOD_TABLE}]")
    if options.get("config") not in (None, str(path)):
        raise InputError(path, f"the method's config file is given twice (config={options['config']!r}, and this "
                               f"file's tables {others}): keep one")
    return {**options, "config": str(path)}
