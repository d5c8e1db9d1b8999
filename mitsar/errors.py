"""Error types shared by every mitsar module.

Every error raised for bad user input names where it happened, the parameter, what was
expected and what was found, so that a user can fix the input without reading the code.
"""

from __future__ import annotations

import functools
import inspect
import os
import types
import typing
import warnings
from collections.abc import Callable
from typing import Any


class MitsarError(Exception):
    """Base class of all mitsar errors."""


class ParameterError(MitsarError, ValueError):
    """A parameter has a value that is invalid or physically impossible.

    Parameters
    ----------
    where : str
        The object or file the parameter belongs to, e.g. ``"Radar"`` or ``"exp.toml"``.
    name : str
        Name of the parameter, e.g. ``"prf"`` or ``"radar.prf"``.
    expected : str
        What a valid value looks like.
    found : Any
        The value that was given.
    """

    def __init__(self, where: str, name: str, expected: str, found: Any) -> None:
        self.where = where
        self.name = name
        self.expected = expected
        self.found = found
        super().__init__(f"{where}: parameter '{name}': expected {expected}, found {found!r}")


class MitsarWarning(UserWarning):
    """A valid but suspicious input or an empty result (e.g. raw data of exact zeros)."""


class SceneError(MitsarError):
    """A Mitsuba scene cannot be loaded or used; the message names the file and element."""


class MissingFileError(SceneError, FileNotFoundError):
    """A scene file, or a file it references (e.g. a PLY mesh), does not exist."""


class MemoryBudgetError(ParameterError):
    """A request would need more memory than the machine (or ``--memory-limit``) has.

    Raised before any work by :func:`mitsar.budget.require_memory`; a
    :class:`ParameterError` naming the parameter that drives the size, the need and what is
    available, and what to change (docs/reliability.md §2).
    """

    def __init__(self, where: str, name: str, needed: int, available: int, limit_source: str,
                 hint: str = "") -> None:
        self.needed = int(needed)
        self.available = int(available)
        found = f"a request of about {format_bytes(needed)}"
        expected = (f"a request that fits in the {format_bytes(available)} available "
                    f"({limit_source})")
        ParameterError.__init__(self, where, name, expected, found)
        tail = f"; {hint}" if hint else ""
        self.args = (f"{where}: parameter '{name}': needs about {format_bytes(needed)} of "
                     f"memory, {format_bytes(available)} available ({limit_source}){tail}",)

    def __str__(self) -> str:
        return str(self.args[0])


def format_bytes(count: float) -> str:
    """A byte count in binary units, e.g. ``format_bytes(2**40) == "1.00 TiB"``."""
    value = float(count)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(value) < 1024.0 or unit == "EiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.2f} {unit}"
        value /= 1024.0
    return f"{value:.2f} EiB"  # pragma: no cover (the loop returns)


def _checked_classes(annotation: Any, namespace: dict[str, Any]) -> tuple[type, ...] | None:
    """The classes an argument annotated ``annotation`` must be an instance of, or ``None`` when
    the annotation is not checked: built-in types (NumPy scalars pass as numbers, and a string
    option may take None; values are checked where they are used) except ``str`` beside
    ``os.PathLike`` (a path), generics (``Sequence[...]``, ``ArrayLike``), ``Any`` and names that
    cannot be resolved at run time."""
    if isinstance(annotation, str):
        parts = {part.strip() for part in annotation.split("|")}
        if "ArrayLike" in parts and parts <= {"ArrayLike", "None"}:
            return (ARRAY_LIKE, type(None)) if "None" in parts else (ARRAY_LIKE,)
        try:
            annotation = eval(annotation, namespace)  # noqa: S307 - the module's own annotation
        except Exception:  # noqa: BLE001 - a name imported only for type checking
            return None
    members = typing.get_args(annotation) if isinstance(
        annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union \
        else (annotation,)
    path = os.PathLike in members  # str | os.PathLike: a path (str and Path pass)
    classes: list[type] = []
    for member in members:
        if member is type(None) or member is os.PathLike or (member is str and path):
            classes.append(member)
        elif not isinstance(member, type) or member.__module__ in ("builtins", "typing"):
            return None  # generics, Any, numbers, str, dict ...: the function's own checks
        else:
            classes.append(member)
    return tuple(classes)


class _NumericArrayMeta(type):
    def __instancecheck__(cls, value: Any) -> bool:
        import numpy as np  # noqa: PLC0415 - errors.py imports nothing heavy at load

        if isinstance(value, np.ndarray):
            return value.dtype.kind in "biufc"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return np.asarray(value).dtype.kind in "biufc"
        except (TypeError, ValueError):  # ragged lists
            return False


class ARRAY_LIKE(metaclass=_NumericArrayMeta):  # noqa: N801 - read as a marker
    """Marker class of an ``ArrayLike`` argument of :func:`public`: an instance is a number or
    a (nested, rectangular) sequence or array of numbers (not text, objects or ragged lists)."""


def _type_name(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def public(func: Callable[..., Any], module: str | None = None) -> Callable[..., Any]:
    """Wrap a public function so that a call that does not match its signature (a missing or
    unknown argument) or an argument of the wrong class (a string for a dataset, a list for a
    path ...) raises :class:`ParameterError` naming the parameter, the class expected and the
    value found, instead of Python's ``TypeError`` (or an ``AttributeError``) from deep inside
    (issue 27; docs/reliability.md §1). Only annotations that name classes are checked (module
    :func:`_checked_classes`); values are left to the function's own checks.

    ``module``: the module that exports the wrapper (``"mitsar"``), recorded as its
    ``__module__`` so that pickle finds the wrapper itself by name."""
    signature = inspect.signature(func)
    where = func.__name__
    namespace = getattr(func, "__globals__", {})
    expected: dict[str, tuple[type, ...] | None] = {}

    @functools.wraps(func)
    def checked(*args: Any, **kwargs: Any) -> Any:
        try:
            bound = signature.bind(*args, **kwargs)
        except TypeError as error:
            text = str(error)
            quoted = text.split("'")
            name = quoted[1] if len(quoted) > 2 else "arguments"
            raise ParameterError(where, name, f"arguments as in {where}{signature}",
                                 text) from None
        for name, value in bound.arguments.items():
            parameter = signature.parameters[name]
            if parameter.kind in (parameter.VAR_POSITIONAL, parameter.VAR_KEYWORD):
                continue
            if name not in expected:
                expected[name] = _checked_classes(parameter.annotation, namespace)
            classes = expected[name]
            if classes and not isinstance(value, classes):
                wanted = " or ".join("None" if c is type(None) else "a path" if c is os.PathLike
                                     else "numbers (an array_like)" if c is ARRAY_LIKE
                                     else f"a {c.__module__.split('.')[0]}.{c.__qualname__}"
                                     if c.__module__ not in ("builtins",) else f"a {c.__name__}"
                                     for c in classes)
                raise ParameterError(where, name, wanted, _type_name(value))
        return func(*args, **kwargs)

    if module is not None:
        checked.__module__ = module
        checked.__qualname__ = func.__name__
    return checked
