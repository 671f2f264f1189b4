"""Options as dataclasses: one declaration gives the parser, the checked values and the argv.

A service declares its options once, as fields of an :class:`Options`
dataclass made with :func:`option` (default, help, choices, range check,
environment variable). From that one declaration

- :func:`add_options` adds them to an ``argparse`` parser,
- :func:`options_from` builds the checked dataclass from parsed arguments
  (the environment fills what the command line leaves out), and
- :func:`options_argv` turns a dataclass back into the command line that
  gives it, which is how the launcher starts a service with its options.

A value out of range raises :class:`OptionError` naming the option, before
any process starts.

A field made with :func:`settings_option` holds a whole configuration (a
:class:`aamcore.settings.Settings` dataclass, such as the tracker's): each of its
values is an option of its own (its flag, help, default and check come from the
configuration's declaration), and the field is rebuilt from them, so that the
configuration's own checks (two values that contradict each other) run too. This
module reads such a configuration through its methods only (``settings()``,
``values()``, ``with_values()``): the bus layer imports no algorithm.
"""

from __future__ import annotations

import argparse
import dataclasses
import difflib
import math
import os
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Self

Check = Callable[[Any], str]
"""Returns what is wrong with a value, or ``""``."""


class OptionError(ValueError):
    """An option's value is not acceptable; the message names the option.

    Attributes
    ----------
    option : str or None
        The field name of the option, when one option is at fault.
    """

    def __init__(self, message: str, option: str | None = None) -> None:
        super().__init__(message)
        self.option = option


@dataclass(frozen=True)
class _Meta:
    help: str
    choices: tuple[Any, ...] | None
    metavar: str | None
    env: str | None
    check: Check | None
    flag: str | None
    const: Any = None
    aliases: tuple[str, ...] = ()


def option(
    default: Any,
    help: str,
    *,
    choices: Sequence[Any] | None = None,
    metavar: str | None = None,
    env: str | None = None,
    check: Check | None = None,
    flag: str | None = None,
    const: Any = None,
    aliases: Sequence[str] = (),
) -> Any:
    """A dataclass field that is also a command-line option ``--name-with-dashes``.

    Parameters
    ----------
    default : object
        Immutable default (tuples for lists).
    help : str
    choices : sequence, optional
    metavar : str, optional
    env : str, optional
        Environment variable read when the command line does not give the option.
    check : callable, optional
        ``check(value) -> problem`` (``""`` when fine).
    flag : str, optional
        The flag, when not ``--`` and the field name with dashes.
    const : object, optional
        The value of the flag given without one (the value is then optional);
        for options that take a value (not booleans or lists).
    aliases : sequence of str
        Other flags that give the same option (e.g. ``--save`` for ``--rrd``).
    """
    meta = _Meta(help, tuple(choices) if choices is not None else None, metavar, env, check, flag,
                 const, tuple(aliases))
    return dataclasses.field(default=default, metadata={"option": meta})


def in_range(low: float, high: float = math.inf) -> Check:
    """A check that a number lies in ``[low, high]``."""

    def check(value: Any) -> str:
        if value is None:
            return ""
        if not (isinstance(value, int | float) and math.isfinite(value) and low <= value <= high):
            upper = "" if high == math.inf else f" to {high:g}"
            return f"must be a number from {low:g}{upper}"
        return ""

    return check


def setting_option(setting: Any, **changes: Any) -> Any:
    """An option field made of one value of a configuration (an
    :class:`aamcore.settings.Setting`: its default, help, choices and check), for a service
    that takes that one value under its own name; ``changes`` (``metavar``, ``flag``) go
    over it."""
    made = {"help": setting.help, "choices": setting.choices, "metavar": setting.metavar,
            "check": setting.problem, **changes}
    return option(setting.default, **made)


@dataclass(frozen=True)
class _Group:
    without: tuple[str, ...]


def settings_option(default: Any, without: Sequence[str] = ()) -> Any:
    """A dataclass field holding a whole configuration (``default``, a
    :class:`aamcore.settings.Settings`), each of its values (but those named in
    ``without``, by flat name) an option of its own."""
    return dataclasses.field(default=default, metadata={"settings": _Group(tuple(without))})


@dataclass(frozen=True)
class _Entry:
    """One option: a field of its own, or a value of a configuration field (``group``)."""

    name: str
    kind: type
    meta: _Meta
    default: Any
    group: str | None = None


def _entries(cls: type[Options], only: Sequence[str] | None = None) -> list[_Entry]:
    """Every option of ``cls`` (those named in ``only``: a configuration's values by their
    flat names, or all of them by the field's name)."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        if "option" in f.metadata and (only is None or f.name in only):
            out.append(_Entry(f.name, _base_type(hints[f.name]), f.metadata["option"],
                              f.default))
        elif "settings" in f.metadata:
            skip = f.metadata["settings"].without
            for s in f.default.settings():
                if s.name not in skip and (only is None or f.name in only or s.name in only):
                    meta = _Meta(s.help, s.choices, s.metavar, None, None, s.flag)
                    out.append(_Entry(s.name, s.kind, meta, s.default, f.name))
    return out


@dataclass(frozen=True)
class Options:
    """Base of every options dataclass: checks each field on construction."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            meta: _Meta | None = f.metadata.get("option")
            if meta is None:
                continue
            value = getattr(self, f.name)
            if meta.choices is not None and value is not None and value not in meta.choices:
                raise OptionError(f"{flag_of(f)} {value!r}: choose one of "
                                  f"{', '.join(map(str, meta.choices))}", f.name)
            problem = meta.check(value) if meta.check else ""
            if problem:
                raise OptionError(f"{flag_of(f)} {value!r}: {problem}", f.name)

    def replace(self, **changes: Any) -> Self:
        """A copy with ``changes``, checked again."""
        return dataclasses.replace(self, **changes)


def flag_of(f: dataclasses.Field | _Entry) -> str:
    """The command-line flag of an option field (or entry)."""
    meta: _Meta = f.meta if isinstance(f, _Entry) else f.metadata["option"]
    return meta.flag or "--" + f.name.replace("_", "-")


def _base_type(hint: Any) -> type:
    """``int`` for ``int | None``, ``tuple`` for ``tuple[str, ...]``, else the hint."""
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return _base_type(args[0])
    if origin is tuple:
        return tuple
    return hint


def add_options(
    parser: argparse.ArgumentParser | Any,
    cls: type[Options],
    only: Sequence[str] | None = None,
    flags: Mapping[str, Sequence[str]] | None = None,
) -> None:
    """Add the options of ``cls`` (those named in ``only``) to ``parser`` or an argument group.

    ``flags`` gives some options other flags than their own (and their
    aliases), by field name: ``{"viewer": ("--connect",)}``.
    """
    for f in _entries(cls, only):
        kind, meta = f.kind, f.meta
        text = meta.help
        if f.default not in (None, (), False, ""):
            text += f" (default {f.default})"
        if meta.const is not None:
            text += f" (without a value: {meta.const})"
        if meta.env:
            text += f" [env {meta.env}]"
        kwargs: dict[str, Any] = {"dest": f.name, "default": None, "help": text}
        if kind is bool:
            kwargs["action"] = argparse.BooleanOptionalAction
        elif kind is tuple:
            kwargs.update(action="extend", type=_comma_list, metavar=meta.metavar or "VALUE")
        else:
            kwargs.update(type=kind, metavar=meta.metavar, choices=meta.choices)
            if meta.const is not None:
                kwargs.update(nargs="?", const=meta.const)
        names = (flags or {}).get(f.name) or (flag_of(f), *meta.aliases)
        parser.add_argument(*names, **kwargs)


def _comma_list(text: str) -> list[str]:
    """A repeatable option's value: one item, or several separated by commas."""
    return [item.strip() for item in text.split(",") if item.strip()]


def _from_env(name: str, kind: type) -> Any:
    text = os.environ.get(name, "")
    if not text:
        return None
    if kind is tuple:
        return tuple(_comma_list(text))
    if kind is bool:
        return text.lower() in ("1", "true", "yes", "on")
    try:
        return kind(text)
    except ValueError as exc:
        raise OptionError(f"environment variable {name}={text!r}: {exc}") from None


def options_from(
    cls: type[Options],
    args: argparse.Namespace | None = None,
    only: Sequence[str] | None = None,
    base: Options | None = None,
    flags: Mapping[str, Sequence[str]] | None = None,
    **given: Any,
) -> Any:
    """Build ``cls`` from parsed arguments, then the environment, then ``base`` or the defaults.

    Only the options named in ``only`` are read from ``args``; keyword
    arguments override everything. ``flags``, as given to :func:`add_options`,
    names an option at fault by the flag it was given with.

    Raises
    ------
    OptionError
    """
    values = _shallow(base) if base is not None else {}
    groups: dict[str, dict[str, Any]] = {}
    for f in _entries(cls, only):
        value = getattr(args, f.name, None) if args is not None else None
        if value is None and f.meta.env:
            value = _from_env(f.meta.env, f.kind)
        if value is not None:
            value = tuple(value) if f.kind is tuple else value
            if f.group is None:
                values[f.name] = value
            else:
                groups.setdefault(f.group, {})[f.name] = value
    values.update(given)
    try:
        values.update(_regrouped(cls, values, groups))
        return cls(**values)
    except OptionError as exc:
        names = (flags or {}).get(exc.option or "")
        if not names:
            raise
        own = flag_of(next(e for e in _entries(cls) if e.name == exc.option))
        raise OptionError(names[0] + str(exc).removeprefix(own), exc.option) from None


def _shallow(opts: Options) -> dict[str, Any]:
    """The fields of ``opts`` by name (a configuration field as it is)."""
    return {f.name: getattr(opts, f.name) for f in dataclasses.fields(opts)}


def _regrouped(cls: type[Options], values: dict[str, Any], groups: dict[str, dict[str, Any]],
               where: str = "") -> dict[str, Any]:
    """Each configuration field of ``cls`` with the values given for it (by flat name).

    Raises
    ------
    OptionError
        Naming the value at fault by its flag (after ``where``: a stack file's table).
    """
    out = {}
    for name, given in groups.items():
        default = next(f.default for f in dataclasses.fields(cls) if f.name == name)
        try:
            out[name] = values.get(name, default).with_values(**given)
        except ValueError as exc:  # the configuration's ConfigError, read by its attributes
            field = getattr(exc, "field", None)
            if field is None:
                raise OptionError(f"{where}{exc}") from None
            flag = next((flag_of(e) for e in _entries(cls) if e.name == field), field)
            raise OptionError(f"{where}{flag} {exc.value!r}: {exc.problem}", field) from None
    return out


def options_argv(opts: Options) -> list[str]:
    """The command-line arguments giving ``opts`` back (only values other than the defaults)."""
    argv: list[str] = []
    for f in _entries(type(opts)):
        kind = f.kind
        value = (getattr(opts, f.group).values()[f.name] if f.group is not None
                 else getattr(opts, f.name))
        if value == f.default or value is None:
            continue
        flag = flag_of(f)
        if kind is bool:
            argv.append(flag if value else "--no-" + flag[2:])
        elif kind is tuple:
            for item in value:
                argv += [flag, str(item)]
        else:
            argv += [flag, str(value)]
    return argv


def options_of_mapping(cls: type[Options], data: dict[str, Any], where: str) -> Any:
    """Build ``cls`` from a mapping of field names (a stack file's table).

    Raises
    ------
    OptionError
        Naming ``where`` for an unknown key or a value of the wrong type.
    """
    entries = {e.name: e for e in _entries(cls)}
    entries |= {flag_of(e)[2:].replace("-", "_"): e for e in entries.values()
                if flag_of(e).startswith("--")}  # a value may be named by its flag too
    values: dict[str, Any] = {}
    groups: dict[str, dict[str, Any]] = {}
    for key, value in data.items():
        name = key.replace("-", "_")
        if name not in entries:
            close = difflib.get_close_matches(name, entries, 1)
            hint = f"did you mean {close[0].replace('_', '-')}? " if close else ""
            raise OptionError(f"{where}: unknown option {key!r}; {hint}options are "
                              f"{', '.join(sorted({e.name for e in entries.values()}))}",
                              name)
        kind = entries[name].kind
        if kind is tuple:
            value = tuple(value) if isinstance(value, list) else (value,)
        elif kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise OptionError(f"{where}: {key} = {value!r} is not a {kind.__name__}", name)
        entry = entries[name]
        if entry.group is None:
            values[entry.name] = value
        else:
            groups.setdefault(entry.group, {})[entry.name] = value
    values.update(_regrouped(cls, values, groups, f"{where}: "))
    try:
        return cls(**values)
    except OptionError as exc:
        raise OptionError(f"{where}: {exc}", exc.option) from None
