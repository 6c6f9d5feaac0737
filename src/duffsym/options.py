"""Options objects: the settings of a public function with many of them, as one frozen dataclass.

A function with many settings takes ``(inputs..., options=None, **settings)``: ``options`` a frozen dataclass
of every setting with its default, ``settings`` any of its fields by keyword (they override ``options``), so
that every keyword call keeps working and a study can keep one options object for many calls::

    opts = DiagnoseOptions(holdout=0.25, screen=None)
    diagnose(record, model, opts)                    # these settings
    diagnose(record, model, opts, sindy=False)       # these, without the SINDy cross-check
    diagnose(record, model, holdout=0.25)            # the defaults but one

:func:`resolve` does the merging and names an unknown setting in a :class:`TypeError`, as Python does for an
unknown keyword argument.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

T = TypeVar("T", bound="DataclassInstance")


def field_names(cls) -> tuple[str, ...]:
    """The settings an options class holds (its dataclass fields), in order."""
    return tuple(f.name for f in dataclasses.fields(cls))


def resolve(cls: type[T], options: T | None, settings: Mapping[str, Any], function: str) -> T:
    """``options`` (default ``cls()``) with ``settings`` replacing its fields; a :class:`TypeError` naming
    the first setting ``cls`` does not have (``function`` is the name the message gives)."""
    if options is not None and not isinstance(options, cls):
        raise TypeError(f"{function}() options must be a {cls.__name__}; got {type(options).__name__}")
    known = set(field_names(cls))
    unknown = [k for k in settings if k not in known]
    if unknown:
        raise TypeError(
            f"{function}() got an unexpected keyword argument {unknown[0]!r} (settings: {', '.join(sorted(known))})"
        )
    base = cls() if options is None else options
    return dataclasses.replace(base, **settings) if settings else base
