"""One registry of analysis methods: every certificate, margin and search is registered here by name.

A method is an :class:`AnalysisMethod`: its name, the family of questions it answers, what
it bounds, what it needs, and its ``run`` callable. The front ends and the tables iterate
the registry: :func:`~scara_robust.certificate_table` runs the ``'certificate'`` family,
:func:`~scara_robust.robustness_margin` and :func:`~scara_robust.margin_table` the
``'margin'`` family, :func:`~scara_robust.parameter_margin` the ``'parameter'`` family and
:func:`~scara_robust.payload_margin` the ``'payload'`` family. Adding a method is one module
that calls :func:`register_method` (and its test); nothing else names it.

=============  ===============================================  ==========================================
family         ``run`` signature                                returns
=============  ===============================================  ==========================================
certificate    ``run(context: CertificateContext)``             an :class:`~scara_robust.AnalysisResult`
margin         ``run(model, design, *, elements, anchor,        a :class:`~scara_robust.Margin`
               lower, upper, tol, falsifier_tries, seed)``
parameter      ``run(plant, design, K)``                        a test ``ok(scale) -> bool`` for the
                                                                bisection (monotone in the scale)
payload        ``run(context: PayloadContext)``                 a test ``ok(mass) -> bool``
=============  ===============================================  ==========================================

``bound`` says what the answer is: ``'certificate'`` (a verdict on the set as given),
``'lower'`` (certified up to the number) or ``'upper'`` (unstable from the number).
``needs`` names what the method uses, so a caller can tell beforehand whether it applies:
``'P'`` (the design's Lyapunov matrix), the system's capabilities it uses
(:data:`~scara_robust.CAPABILITIES`: ``'intervals'``, ``'vertices'``, ``'parameters'``,
``'rates'``; a method runs on a system that has them), ``'lmi'`` (cvxpy, extra ``lmi``),
``'lower'`` (a certified value to start from) and ``'upper'`` (an upper bound to search below).
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .._validation import check_choice
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..model.base import CAPABILITIES
from ..results import AnalysisResult

__all__ = [
    "AnalysisMethod",
    "METHOD_FAMILIES",
    "METHOD_BOUNDS",
    "METHOD_NEEDS",
    "register_method",
    "unregister_method",
    "analysis_methods",
    "get_method",
    "checked_result",
]

#: The families of questions, and what each answers.
METHOD_FAMILIES: Mapping[str, str] = {
    "certificate": "a verdict on one design over the set as given (a row of certificate_table)",
    "margin": "the largest scaling θ of the uncertainty set a method certifies, or the smallest it disproves",
    "parameter": "the largest scaling of a plant's parameter box, in the parameters' units",
    "payload": "the SCARA's largest peak payload, kg",
}
#: What a method's number bounds.
METHOD_BOUNDS = ("certificate", "lower", "upper")
#: What a method may need (see the module's docstring).
METHOD_NEEDS = ("P", *CAPABILITIES, "lmi", "lower", "upper")


@dataclass(frozen=True)
class AnalysisMethod:
    """One registered analysis method.

    Attributes
    ----------
    name : str
        Its name in its family (``'lmi-physical'``), as the command line and the tables show it.
    family : str
        A key of :data:`METHOD_FAMILIES`.
    bound : str
        One of :data:`METHOD_BOUNDS`.
    run : callable
        See the module's table for the signature of each family.
    description : str
        The question it answers, one line.
    needs : frozenset of str
        Items of :data:`METHOD_NEEDS`.
    default : bool
        Run when the caller names no methods (False for a method asked for by name only,
        e.g. one that needs data the default call does not give).
    column : str or None
        For the ``'certificate'`` family: the table column that shows the result's ``value``
        (with its unit), added when the method runs; None for the built-in columns.
    cheap : bool
        It answers from closed forms and eigenvalues, in milliseconds (no LMI, no search by
        simulation): the design page runs these at every click.
    """

    name: str
    family: str
    bound: str
    run: Callable[..., Any]
    description: str
    needs: frozenset[str] = field(default_factory=frozenset)
    default: bool = True
    column: str | None = None
    cheap: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ArgumentValueError("name", f"must be a non-empty str, found {self.name!r}")
        check_choice("family", self.family, tuple(METHOD_FAMILIES))
        check_choice("bound", self.bound, METHOD_BOUNDS)
        if not callable(self.run):
            raise ArgumentTypeError("run", f"must be callable, found {type(self.run).__name__}")
        object.__setattr__(self, "needs", frozenset(self.needs))
        for need in self.needs:
            check_choice("needs", need, METHOD_NEEDS)

    def applies_to(self, capabilities: frozenset[str]) -> bool:
        """Whether a system with these capabilities has every capability the method needs.

        Parameters
        ----------
        capabilities : frozenset of str
            Keys of :data:`~scara_robust.CAPABILITIES` (``system.capabilities``).

        Returns
        -------
        bool
        """
        return self.needs & CAPABILITIES.keys() <= capabilities


_REGISTRY: dict[str, dict[str, AnalysisMethod]] = {family: {} for family in METHOD_FAMILIES}


def register_method(method: AnalysisMethod, *, replace: bool = False) -> AnalysisMethod:
    """Add a method to its family (it then runs in the tables, the commands and the page).

    Parameters
    ----------
    method : AnalysisMethod
    replace : bool
        Replace a method registered under the same name (default: refuse).

    Returns
    -------
    AnalysisMethod
        `method`, so the call can decorate a module-level name.

    Raises
    ------
    ArgumentTypeError
        If `method` is not an :class:`AnalysisMethod`.
    ArgumentValueError
        If its family already has a method of that name and `replace` is False.

    Examples
    --------
    >>> import scara_robust as sr
    >>> def nominal(context):  # is the design's own loop stable?
    ...     import numpy as np
    ...     A = context.model.A - context.model.B @ context.design.K
    ...     return sr.CertificateRow.of(bool(np.linalg.eigvals(A).real.max() < 0), "nominal loop")
    >>> method = sr.register_method(sr.AnalysisMethod("nominal", "certificate", "certificate", nominal,
    ...                                               "the design's own loop", default=False))
    >>> "nominal" in sr.analysis_methods("certificate")
    True
    >>> sr.unregister_method("certificate", "nominal")
    """
    if not isinstance(method, AnalysisMethod):
        raise ArgumentTypeError("method", f"must be an AnalysisMethod, found {type(method).__name__}")
    family = _REGISTRY[method.family]
    if method.name in family and not replace:
        raise ArgumentValueError("method", f"{method.name!r} is already registered in the {method.family!r} "
                                           "family; pass replace=True to replace it")
    family[method.name] = method
    return method


def unregister_method(family: str, name: str) -> None:
    """Remove a method from its family.

    Parameters
    ----------
    family : str
        A key of :data:`METHOD_FAMILIES`.
    name : str
        A registered name.

    Raises
    ------
    ArgumentValueError
        For an unknown family or name (the registered names are listed).
    """
    del _REGISTRY[family][get_method(family, name).name]


def analysis_methods(family: str, *, defaults: bool = False) -> tuple[str, ...]:
    """The names registered in a family, in the order they were registered.

    Parameters
    ----------
    family : str
        A key of :data:`METHOD_FAMILIES`.
    defaults : bool
        Only those that run when no method is named.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> import scara_robust as sr
    >>> sr.analysis_methods("margin")
    ('theorem1', 'vertex', 'lmi', 'frozen', 'falsifier')
    """
    check_choice("family", family, tuple(METHOD_FAMILIES))
    return tuple(name for name, m in _REGISTRY[family].items() if m.default or not defaults)


def get_method(family: str, name: str, *, argument: str = "method") -> AnalysisMethod:
    """The registered method `name` of `family`.

    Parameters
    ----------
    family : str
        A key of :data:`METHOD_FAMILIES`.
    name : str
    argument : str
        The caller's argument that gave the name, for the error (``'methods'``).

    Returns
    -------
    AnalysisMethod

    Raises
    ------
    ArgumentValueError
        Naming `argument`, listing the registered names and suggesting the closest.
    """
    check_choice("family", family, tuple(METHOD_FAMILIES))
    registered = _REGISTRY[family]
    if name not in registered:
        close = difflib.get_close_matches(str(name), list(registered), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        names = ", ".join(repr(n) for n in registered)
        raise ArgumentValueError(argument, f"must be one of {names} (the registered {family} methods), "
                                           f"found {name!r}{hint}")
    return registered[name]


def checked_result(method: AnalysisMethod, result: object) -> AnalysisResult:
    """`result`, checked to carry the common fields of every result.

    Parameters
    ----------
    method : AnalysisMethod
        The method that returned it, for the error.
    result : object

    Returns
    -------
    AnalysisResult

    Raises
    ------
    ArgumentTypeError
        If `result` is not an :class:`~scara_robust.AnalysisResult` (it lacks
        ``certified``, ``verdict``, ``status`` or ``message``).
    """
    if not isinstance(result, AnalysisResult):
        raise ArgumentTypeError("method", f"{method.name!r} ({method.family}) returned a {type(result).__name__}, "
                                          "not an AnalysisResult with certified, verdict, status and message")
    return result
