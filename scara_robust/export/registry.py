"""The export targets by name: one :class:`ExportTarget` per format, a new format is one module.

A target module builds its :class:`ExportTarget` and registers it at import with
:func:`register_target`; :func:`~scara_robust.export_controller` and the ``export``
command's ``--format`` offer every registered name (:func:`export_targets`, in the order
registered) and dispatch through :func:`get_target`. The built-in targets are ``'c'``
(C99 header and source) and ``'json'`` (the controller's record).

ExportTarget       -- one format: name, file suffix, description, write function
register_target    -- add a target (``replace=True`` replaces one of the same name)
unregister_target  -- remove a target by name
export_targets     -- the registered names, in order
get_target         -- a registered target by name
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .._validation import check_callable, check_instance, describe
from ..controller.discrete import DiscretePID
from ..controller.scheduled import SampledScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..model.plant import Signal
from ._common import DEFAULT_PREFIX, check_prefix

__all__ = ["ExportTarget", "register_target", "unregister_target", "export_targets", "get_target"]

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")
_SUFFIX = re.compile(r"(\.[A-Za-z0-9_+-]+)+")


@dataclass(frozen=True)
class ExportTarget:
    """One export format: its name, the suffix of its file and the function that writes it.

    Attributes
    ----------
    name : str
        The format's name, as :func:`~scara_robust.export_controller` (``format``) and the
        ``export`` command (``--format``) take it: a letter or digit, then letters, digits,
        ``_`` or ``-`` (``'c'``, ``'json'``).
    suffix : str
        Suffix of the file written, ``<prefix><suffix>`` (``'.json'``). A target that
        writes several files names its main one here (the C target: ``'.c'``, with its
        ``'.h'``).
    description : str
        One line saying what is written, e.g. ``'<prefix>.json: every gain and limit'``.
    write : callable
        ``write(controller, *, prefix, notes, metadata, outputs, inputs, precision)``,
        with the arguments of :func:`~scara_robust.export_controller` (the controller is a
        :class:`~scara_robust.DiscretePID`, a :class:`~scara_robust.SampledStateFeedback` or a
        :class:`~scara_robust.SampledScheduledGain`;
        Ts and the gains in SI units, the signals' units as the plant gives them).
        Returns the text of ``<prefix><suffix>`` (str), or, for several files, a mapping
        of suffix to text in the order the files are written (the C target:
        ``{'.h': header, '.c': source}``).

    Examples
    --------
    >>> import scara_robust as sr
    >>> csv = sr.ExportTarget("csv", ".csv", "<prefix>.csv: Ts, s",
    ...                       lambda controller, **options: f"Ts\\n{controller.Ts}\\n")
    >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3)
    >>> csv.files(pid, prefix="arm")
    {'arm.csv': 'Ts\\n0.001\\n'}
    """

    name: str
    suffix: str
    description: str
    write: Callable[..., str | Mapping[str, str]]

    def __post_init__(self) -> None:
        for field, value in (("name", self.name), ("suffix", self.suffix), ("description", self.description)):
            if not isinstance(value, str):
                raise ArgumentTypeError(field, f"must be a str, found {type(value).__name__} {describe(value)}")
        if not _NAME.fullmatch(self.name):
            raise ArgumentValueError(
                "name", f"must be a letter or digit, then letters, digits, _ or -, found {describe(self.name)}"
            )
        if not _SUFFIX.fullmatch(self.suffix):
            raise ArgumentValueError(
                "suffix", f"must be a file suffix such as '.json' (a dot, then letters or digits), "
                f"found {describe(self.suffix)}"
            )
        check_callable("write", self.write)

    def files(
        self,
        controller: DiscretePID | SampledStateFeedback | SampledScheduledGain,
        *,
        prefix: str = DEFAULT_PREFIX,
        notes: Sequence[str] = (),
        metadata: Mapping[str, Any] | None = None,
        outputs: Sequence[Signal] | None = None,
        inputs: Sequence[Signal] | None = None,
        precision: str = "double",
    ) -> dict[str, str]:
        """The files of `controller` in this format, by name; nothing is written.

        Parameters
        ----------
        controller : DiscretePID, SampledStateFeedback or SampledScheduledGain
            The controller (Ts in s).
        prefix : str
            C identifier; the files are ``<prefix><suffix>``.
        notes : sequence of str
            Lines for the files' opening comment (or the record's ``notes``).
        metadata : mapping, optional
            Extra keys for a record (JSON).
        outputs, inputs : sequence of Signal, optional
            Names and units of the signals (see :func:`~scara_robust.export_controller`).
        precision : {'double', 'single'}
            The C floating-point type.

        Returns
        -------
        dict of str to str
            File name (``<prefix><suffix>``) to its text, in the order to write them.

        Raises
        ------
        ArgumentTypeError
            If `write` returns something other than a str or a mapping of suffix to str.
        """
        prefix = check_prefix(prefix)
        written = self.write(controller, prefix=prefix, notes=notes, metadata=metadata, outputs=outputs,
                             inputs=inputs, precision=precision)
        if isinstance(written, str):
            return {f"{prefix}{self.suffix}": written}
        if (isinstance(written, Mapping) and written
                and all(isinstance(k, str) and _SUFFIX.fullmatch(k) and isinstance(v, str)
                        for k, v in written.items())):
            return {f"{prefix}{suffix}": text for suffix, text in written.items()}
        raise ArgumentTypeError(
            "write", f"of the export target {self.name!r} must return the file's text (a str) or a mapping of "
            f"suffix to text, found {describe(written)}"
        )


#: The registered targets by name, in the order registered.
_TARGETS: dict[str, ExportTarget] = {}


def register_target(target: ExportTarget, *, replace: bool = False) -> ExportTarget:
    """Add an export target, offered from then on by name.

    Parameters
    ----------
    target : ExportTarget
        The target; its ``name`` must not be registered yet, unless `replace`.
    replace : bool
        Replace the target registered under the same name (it keeps its place in
        :func:`export_targets`).

    Returns
    -------
    ExportTarget
        `target`, so a module can write ``TARGET = register_target(ExportTarget(...))``.

    Raises
    ------
    ArgumentTypeError
        If `target` is not an :class:`ExportTarget`, or `replace` not a bool.
    ArgumentValueError
        If a target named ``target.name`` is registered and `replace` is False.
    """
    check_instance("target", target, ExportTarget, "an ExportTarget(name, suffix, description, write)")
    if not isinstance(replace, bool):
        raise ArgumentTypeError("replace", f"must be True or False, found {type(replace).__name__} {describe(replace)}")
    if target.name in _TARGETS and not replace:
        raise ArgumentValueError(
            "target", f"is named {target.name!r}, and an export target of that name is registered already "
            "(replace=True replaces it)"
        )
    _TARGETS[target.name] = target
    return target


def _registered(name: str) -> str:
    """`name` if a target of that name is registered, else raise listing them and suggesting the closest."""
    if not isinstance(name, str):
        raise ArgumentTypeError("name", f"must be the name of an export target (a str), found {type(name).__name__} "
                                f"{describe(name)}")
    if name not in _TARGETS:
        known = ", ".join(repr(n) for n in _TARGETS) or "none"
        close = difflib.get_close_matches(name, list(_TARGETS), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ArgumentValueError("name", f"must be a registered export target ({known}), found {describe(name)}{hint}")
    return name


def unregister_target(name: str) -> ExportTarget:
    """Remove the export target registered as `name`.

    Parameters
    ----------
    name : str

    Returns
    -------
    ExportTarget
        The target removed (:func:`register_target` puts it back, last).

    Raises
    ------
    ArgumentValueError
        If no target is registered as `name`: the message lists the registered names
        and suggests the closest.
    """
    return _TARGETS.pop(_registered(name))


def export_targets() -> tuple[str, ...]:
    """The names of the registered export targets, in the order registered.

    Returns
    -------
    tuple of str
        ``('c', 'json')`` unless targets were registered or removed.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.export_targets()
    ('c', 'json', 'ros2')
    """
    return tuple(_TARGETS)


def get_target(name: str) -> ExportTarget:
    """The export target registered as `name`.

    Parameters
    ----------
    name : str
        One of :func:`export_targets`.

    Returns
    -------
    ExportTarget

    Raises
    ------
    ArgumentValueError
        If no target is registered as `name`: the message lists the registered names
        and suggests the closest.

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.get_target("json").suffix
    '.json'
    >>> sr.get_target("jsn")
    Traceback (most recent call last):
    ...
    scara_robust.exceptions.ArgumentValueError: `name` must be a registered export target (...; did you mean 'json'?
    """
    return _TARGETS[_registered(name)]
