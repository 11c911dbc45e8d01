"""Reading nested settings (JSON or TOML tables) into the pipeline's configuration dataclasses
(:mod:`spark_bench.methods.ours.config`), every value checked against its default's kind."""

from __future__ import annotations

from dataclasses import fields, is_dataclass

from spark_bench.errors import InputError


def build_dataclass(cls, data, source, prefix: str = ""):
    """An instance of dataclass ``cls`` from nested dicts: nested dataclass fields from sub-dicts, each value
    coerced to its default's kind.

    :param data: the settings (unknown keys are an error)
    :param source: the file (or ``"command line"``) named in errors
    :param prefix: the dotted section of ``cls`` in the whole configuration, for error messages
    :raises InputError: naming ``source``, for an unknown setting or a value of the wrong kind
    """
    if not isinstance(data, dict):
        raise InputError(source, f"section {prefix or 'root'} must be a table/object")
    known = {f.name: f for f in fields(cls)}
    unknown = set(data) - set(known)
    if unknown:
        raise InputError(source, f"unknown setting(s) {sorted(prefix + k for k in unknown)}")
    kwargs = {}
    defaults = cls()
    for name, value in data.items():
        default = getattr(defaults, name)
        if is_dataclass(default):
            kwargs[name] = build_dataclass(type(default), value, source, f"{prefix}{name}.")
        else:
            kwargs[name] = _coerce(value, default, source, prefix + name)
    return cls(**kwargs)


def _coerce(value, default, source, key):
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise InputError(source, f"{key} must be true or false")
        return value
    if isinstance(default, int | float):
        try:
            if isinstance(value, bool):  # int(True) is 1: a switch is no number
                raise TypeError
            return type(default)(value)
        except (TypeError, ValueError):
            raise InputError(source, f"{key} must be a number, got {value!r}") from None
    if isinstance(default, str):
        return str(value)
    if isinstance(default, list):
        if not isinstance(value, list):
            raise InputError(source, f"{key} must be a list")
        if not default:
            return list(value)
        # every list setting holds numbers of one kind: check each like a single setting of that kind
        return [_coerce(item, default[0], source, f"{key}[{k}]") for k, item in enumerate(value)]
    return value
