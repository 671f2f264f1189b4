"""Settings: dataclass fields that carry their documentation, range and choices, checked once.

A configuration (:class:`~aamcore.operators.options.PipelineOptions` and its parts) is a
frozen dataclass of :class:`Settings` whose fields are made with :func:`setting` (a
value) or :func:`group` (another such dataclass, whose settings are named with a
prefix). From that one declaration

- the dataclass checks every value on construction and raises :class:`ConfigError`
  naming the setting at fault (and its stage: :attr:`Settings.STAGE` of the part that
  holds it);
- :meth:`Settings.settings` lists every value as a flat :class:`Setting` (name, type,
  default, help, choices, range, command-line flag, stage), from which the command line
  and the stack file are made (:mod:`services.bus.options`: the services' options are
  such dataclasses too, holding the parts of their stages);
- :meth:`Settings.values` and :meth:`Settings.with_values` read and set them by their
  flat names (``refit_every`` for ``refit.every``).

This module imports nothing beyond the standard library: option parsers load it in a
blink.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Self

_NO_VALUE = object()
NO_VALUE = _NO_VALUE
"""The value of an error about a setting given no value (an unknown name)."""


class ConfigError(ValueError):
    """A setting's value is not acceptable; the message names the setting and its stage.

    Attributes
    ----------
    field : str or None
        The flat name of the setting at fault (``refit_every``).
    problem : str
        What is wrong, without the name (the same whichever way the value was given).
    value : object
    stage : str
        The pipeline stage the setting belongs to (``fit``; empty when none or unknown).
    """

    def __init__(self, field: str | None, value: Any, problem: str, stage: str = "",
                 shown: str | None = None) -> None:
        name = shown or field
        said = "" if value is _NO_VALUE else f" {value!r}"
        where = f" ({stage} stage)" if stage else ""
        super().__init__(f"{name}{said}: {problem}{where}" if name else problem + where)
        self.field, self.value, self.problem, self.stage = field, value, problem, stage

    def renamed(self, field: str, stage: str = "") -> ConfigError:
        """The same error naming the setting ``field`` (its flat name in a larger one) and
        its ``stage`` (this one's if not given)."""
        return ConfigError(field, self.value, self.problem, stage or self.stage)

    def shown_as(self, flag: str) -> ConfigError:
        """The same error naming the setting by ``flag`` (``--refit-every``)."""
        return type(self)(self.field, self.value, self.problem, self.stage, flag)


@dataclass(frozen=True)
class _Spec:
    help: str
    choices: tuple[Any, ...] | None = None
    low: float | None = None
    high: float | None = None
    above: float | None = None
    metavar: str | None = None
    flag: str | None = None
    env: str | None = None
    check: Callable[[Any], str] | None = None
    const: Any = None
    aliases: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Group:
    prefix: str
    help: str


@dataclass(frozen=True)
class Setting:
    """One value of a configuration, flattened.

    Attributes
    ----------
    name : str
        Flat name: the group's prefix and the field's (``refit_every``).
    path : tuple of str
        Attribute path in the configuration (``("refit", "every")``).
    kind : type
        ``bool``, ``int``, ``float`` or ``str``.
    optional : bool
        None is a value (meaning "chosen for you": see the help).
    default : object
    help : str
    choices : tuple or None
    metavar : str or None
    flag : str
        The command-line flag (``--refit-every``).
    stage : str
        The stage whose part holds it (``fit``), empty for a value of no stage (a
        service's own).
    """

    name: str
    path: tuple[str, ...]
    kind: type
    optional: bool
    default: Any
    help: str
    choices: tuple[Any, ...] | None
    metavar: str | None
    flag: str
    spec: _Spec
    stage: str = ""

    def problem(self, value: Any) -> str:
        """What is wrong with ``value`` for this setting (``""`` when nothing)."""
        return _problem(self.spec, self.kind, self.optional, value)


def setting(default: Any, help: str, *, choices: typing.Sequence[Any] | None = None,
            low: float | None = None, high: float | None = None, above: float | None = None,
            metavar: str | None = None, flag: str | None = None, env: str | None = None,
            check: Callable[[Any], str] | None = None, const: Any = None,
            aliases: typing.Sequence[str] = ()) -> Any:
    """A field of a :class:`Settings` dataclass: its default, its help, what it accepts.

    Parameters
    ----------
    default : object
    help : str
        One line for ``--help`` and the API's documentation.
    choices : sequence, optional
    low, high : float, optional
        Inclusive bounds of a number.
    above : float, optional
        Exclusive lower bound of a number.
    metavar : str, optional
    flag : str, optional
        The command-line flag, when not ``--`` and the flat name with dashes.
    env : str, optional
        Environment variable read when the command line does not give the value.
    check : callable, optional
        ``check(value) -> problem`` (``""`` when fine), beyond the range and choices.
    const : object, optional
        The value of the flag given without one (the value is then optional).
    aliases : sequence of str
        Other flags that give the same value.
    """
    spec = _Spec(help, tuple(choices) if choices is not None else None, low, high, above,
                 metavar, flag, env, check, const, tuple(aliases))
    return dataclasses.field(default=default, metadata={"setting": spec})


def group(default: Settings, help: str, prefix: str = "") -> Any:
    """A field of a :class:`Settings` dataclass that is itself one, its settings named
    ``<prefix>_<name>`` (``prefix`` empty: by their own names)."""
    return dataclasses.field(default=default, metadata={"group": _Group(prefix, help)})


def _problem(spec: _Spec, kind: type, optional: bool, value: Any) -> str:
    problem = _kind_problem(spec, kind, optional, value)
    if not problem and spec.check is not None:
        problem = spec.check(value)
    return problem


def _kind_problem(spec: _Spec, kind: type, optional: bool, value: Any) -> str:
    if value is None:
        return "" if optional else "must be given"
    if kind is bool:
        return "" if isinstance(value, bool) else "must be true or false"
    if kind in (int, float):
        if isinstance(value, bool) or not isinstance(value, int | float) or (
                kind is int and not isinstance(value, int)) or math.isnan(value):
            return f"must be {'a whole number' if kind is int else 'a number'}{_bounds(spec)}"
        if ((spec.low is not None and value < spec.low)
                or (spec.above is not None and value <= spec.above)
                or (spec.high is not None and value > spec.high)):
            return f"must be {'a whole number' if kind is int else 'a number'}{_bounds(spec)}"
        return ""
    if not isinstance(value, kind):
        return f"must be a {'list' if kind is tuple else kind.__name__}"
    if spec.choices is not None and any(v not in spec.choices for v in (
            value if kind is tuple else (value,))):
        return f"choose one of {', '.join(map(str, spec.choices))}"
    return ""


def _bounds(spec: _Spec) -> str:
    if spec.above is not None:
        high = f" and at most {spec.high:g}" if spec.high is not None else ""
        return f" above {spec.above:g}{high}"
    low = f" from {spec.low:g}" if spec.low is not None else ""
    return low + (f" to {spec.high:g}" if spec.high is not None else "")


def _kind(hint: Any) -> tuple[type, bool]:
    """``(int, True)`` for ``int | None``, ``(tuple, False)`` for ``tuple[str, ...]``."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return _kind(args[0])[0], len(args) < len(typing.get_args(hint))
    if typing.get_origin(hint) is tuple:
        return tuple, False
    return hint, False


@dataclass(frozen=True)
class Settings:
    """Base of a configuration dataclass: each :func:`setting` checked on construction.

    A stage's part of the options tree names its stage in :attr:`STAGE`: its values, and
    those of the groups inside it, are that stage's (errors name it)."""

    STAGE: ClassVar[str] = ""

    def __post_init__(self) -> None:
        hints = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):
            spec = f.metadata.get("setting")
            if spec is not None:
                value = getattr(self, f.name)
                if value is f.default:
                    continue  # as declared (tests check every default): nothing to load
                kind, optional = _kind(hints[f.name])
                if isinstance(value, int) and not isinstance(value, bool) and kind is float:
                    value = float(value)  # an int given for a float: kept as one, then checked
                    object.__setattr__(self, f.name, value)
                if problem := _problem(spec, kind, optional, value):
                    raise ConfigError(f.name, value, problem)
            elif "group" in f.metadata and not isinstance(getattr(self, f.name),
                                                          type(f.default)):
                raise ConfigError(f.name, getattr(self, f.name),
                                  f"must be a {type(f.default).__name__}")

    @classmethod
    def settings(cls) -> list[Setting]:
        """Every value, flattened, in declaration order, with its default (the value in
        ``cls()``: a group's default instance may differ from its class's defaults)."""
        return _flatten(cls(), (), "", cls.STAGE)

    @classmethod
    def setting(cls, name: str) -> Setting:
        """The setting of flat name ``name``."""
        return next(s for s in cls.settings() if s.name == name)

    def values(self) -> dict[str, Any]:
        """Every value by its flat name."""
        return {s.name: self.get(s.path) for s in self.settings()}

    def get(self, path: tuple[str, ...]) -> Any:
        value: Any = self
        for part in path:
            value = getattr(value, part)
        return value

    def with_values(self, **values: Any) -> Self:
        """A copy with the settings named (flat names) changed, checked; a group may be
        given whole by its field's name (``refit=NEVER``).

        Raises
        ------
        ConfigError
            For an unknown name or a value it does not accept, naming it by its flat name.
        """
        groups = {f.name for f in dataclasses.fields(self) if "group" in f.metadata}
        if whole := {k: values.pop(k) for k in list(values) if k in groups}:
            return self.replace(**whole).with_values(**values)
        known = {s.name: s for s in self.settings()}
        for name in values:
            if name not in known:
                close = difflib.get_close_matches(name, known, 1)
                hint = (f"; did you mean {close[0]} ({known[close[0]].stage} stage)?"
                        if close and known[close[0]].stage else
                        f"; did you mean {close[0]}?" if close else "")
                raise ConfigError(name, _NO_VALUE, f"unknown setting{hint}")
        return _rebuilt(self, {known[n].path: v for n, v in values.items()}, known)

    def replace(self, **changes: Any) -> Self:
        """A copy with fields of this dataclass (not flat names) changed, checked."""
        return dataclasses.replace(self, **changes)


def _flatten(config: Any, path: tuple[str, ...], prefix: str, stage: str) -> list[Setting]:
    hints = typing.get_type_hints(type(config))
    out = []
    for f in dataclasses.fields(config):
        name = f"{prefix}_{f.name}" if prefix else f.name
        if "group" in f.metadata:
            inner = getattr(config, f.name)
            out += _flatten(inner, (*path, f.name),
                            "_".join(p for p in (prefix, f.metadata["group"].prefix) if p),
                            stage or type(inner).STAGE)
        elif "setting" in f.metadata:
            spec: _Spec = f.metadata["setting"]
            kind, optional = _kind(hints[f.name])
            out.append(Setting(name, (*path, f.name), kind, optional, getattr(config, f.name),
                               spec.help, spec.choices, spec.metavar,
                               spec.flag or "--" + name.replace("_", "-"), spec, stage))
    return out


def _rebuilt(config: Any, changes: dict[tuple[str, ...], Any], known: dict[str, Setting],
             at: tuple[str, ...] = ()) -> Any:
    """``config`` (at ``at`` in the whole) with ``changes`` by path, each group rebuilt once
    so that its own checks see every change together."""
    mine = {p[-1]: v for p, v in changes.items() if p[:-1] == at}
    for f in dataclasses.fields(config):
        if "group" in f.metadata and any(p[:len(at) + 1] == (*at, f.name) for p in changes):
            mine[f.name] = _rebuilt(getattr(config, f.name), changes, known, (*at, f.name))
    try:
        return dataclasses.replace(config, **mine)
    except ConfigError as exc:
        by_path = {s.path: s for s in known.values()}
        found = by_path.get((*at, exc.field))
        if found is None:
            raise
        raise exc.renamed(found.name, found.stage) from None
