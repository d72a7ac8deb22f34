"""Old names kept for one release: each use warns (``DeprecationWarning``) and names the new one."""

from __future__ import annotations

import warnings
from typing import Any

__all__: list[str] = []

#: The release after which the aliases are removed.
REMOVED_IN = "0.3"


def warn_renamed(old: str, new: str) -> None:
    """Warn that `old` is now `new` (both written as the user would: ``'Margin.kind'``, ``'Margin.bound'``)."""
    warnings.warn(f"{old} is renamed {new}; {old} goes in {REMOVED_IN}", DeprecationWarning, stacklevel=3)


def renamed_field(old: str, new: str) -> property:
    """A read-only property `old` that returns the attribute `new` and warns.

    Parameters
    ----------
    old, new : str
        The attribute names.

    Returns
    -------
    property
    """

    def get(self: Any) -> Any:
        warn_renamed(f"{type(self).__name__}.{old}", f"{type(self).__name__}.{new}")
        return getattr(self, new)

    return property(get, doc=f"Deprecated alias of :attr:`{new}`.")


def renamed_argument(function: str, old: str, new: str, old_value: Any, new_value: Any, default: Any) -> Any:
    """The value of a renamed keyword: `new_value`, or `old_value` (with a warning) when only the old one was given.

    Parameters
    ----------
    function : str
        The function's name, for the warning.
    old, new : str
        The keyword names.
    old_value, new_value : object
        What the caller passed (`old_value` is None when not given).
    default : object
        `new`'s default: giving both the old keyword and a non-default new one is an error.

    Returns
    -------
    object

    Raises
    ------
    TypeError
        If both keywords were given.
    """
    if old_value is None:
        return new_value
    if new_value != default:
        raise TypeError(f"{function}() got both `{new}` and its deprecated name `{old}`; pass `{new}` only")
    warn_renamed(f"{function}({old}=...)", f"{function}({new}=...)")
    return old_value
