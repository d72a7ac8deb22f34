"""The one base of every certificate, margin and bound the package returns.

Every analysis answers the same four questions, whatever its method (the way scipy's
``OptimizeResult`` always has ``success``, ``status`` and ``message``):

``certified``
    True when the result proves robust stability (or the bound it states) for the set it
    was asked about, False when it disproves it, None when it neither proves nor
    disproves (a search that found nothing, a solver that did not answer, a skipped row).
``verdict``
    One word or phrase a table can show: ``'certified'``, ``'not certified'``,
    ``'infeasible'``, ``'unknown'``, ...
``status``
    The machine-readable state of the computation (the solver's status for an LMI, the
    verdict otherwise).
``message``
    One sentence saying what the numbers mean.

A result class declares these as dataclass fields or properties; :class:`AnalysisResult`
checks, when the class is defined, that all four are there, and gives every result
:meth:`AnalysisResult.to_pandas`. The front ends build their tables from these fields, so a
table's columns exist because the results have them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pandas as pd

__all__ = ["AnalysisResult", "CertificateRow", "RESULT_FIELDS", "verdict_of"]

#: The fields every result has, as a dataclass field or a property.
RESULT_FIELDS = ("certified", "verdict", "status", "message")


def verdict_of(certified: bool | None) -> str:
    """The verdict of a result that only knows whether it certified.

    Parameters
    ----------
    certified : bool or None

    Returns
    -------
    {'certified', 'not certified', 'unknown'}

    Examples
    --------
    >>> verdict_of(True), verdict_of(False), verdict_of(None)
    ('certified', 'not certified', 'unknown')
    """
    if certified is None:
        return "unknown"
    return "certified" if certified else "not certified"


def _scalar(value: Any) -> bool:
    if isinstance(value, (bool, int, float, str, np.bool_, np.integer, np.floating)) or value is None:
        return True
    return isinstance(value, tuple) and len(value) <= 4 and all(
        isinstance(v, (int, float, np.integer, np.floating)) for v in value)


class VerdictFromCertified:
    """Mixin of a result whose ``status`` is its ``verdict``, by default :func:`verdict_of` its ``certified``.

    For the results that run no solver (nothing to report beyond the verdict); a class
    with a verdict of its own defines ``verdict`` and keeps ``status``. List it before
    :class:`AnalysisResult` among the bases.
    """

    @property
    def verdict(self) -> str:
        """``'certified'``, ``'not certified'`` or ``'unknown'`` (:func:`verdict_of` of ``certified``)."""
        return verdict_of(self.certified)  # type: ignore[attr-defined]

    @property
    def status(self) -> str:
        """The verdict."""
        return self.verdict


class AnalysisResult:
    """Base of every certificate, margin and bound: ``certified``, ``verdict``, ``status``, ``message``.

    A subclass is a frozen dataclass that declares the four names of :data:`RESULT_FIELDS`
    as fields or properties (checked when the subclass is created: a class that lacks one
    raises ``TypeError`` naming it). Units go in each field's docstring.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Bound(AnalysisResult):
    ...     value: float
    ...     certified: bool = True
    ...     verdict: str = "certified"
    ...     status: str = "certified"
    ...     message: str = "bounded"
    >>> Bound(2.5).to_pandas()["value"]
    2.5
    """

    #: Units of the numeric fields, for :meth:`to_pandas`'s index (``'decay_rate': '1/s'``).
    units: ClassVar[dict[str, str]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        annotations: dict[str, Any] = {}
        for klass in reversed(cls.__mro__):
            annotations.update(getattr(klass, "__annotations__", {}))
        missing = [name for name in RESULT_FIELDS if name not in annotations and not hasattr(cls, name)]
        if missing:
            raise TypeError(f"result class {cls.__name__} lacks the common field(s) {', '.join(missing)} "
                            f"(every AnalysisResult has {', '.join(RESULT_FIELDS)})")

    if TYPE_CHECKING:  # each subclass declares them, as fields or properties

        @property
        def certified(self) -> bool | None: ...

        @property
        def verdict(self) -> str: ...

        @property
        def status(self) -> str: ...

        @property
        def message(self) -> str: ...

    def to_pandas(self) -> pd.Series:
        """The result as one row: the common fields, then its scalar fields (arrays left out).

        Returns
        -------
        pandas.Series
            Indexed by field name, with ``' [unit]'`` appended where :attr:`units` gives one.
        """
        data: dict[str, Any] = {name: getattr(self, name) for name in RESULT_FIELDS}
        if dataclasses.is_dataclass(self):
            for field in dataclasses.fields(self):
                value = getattr(self, field.name)
                if field.name in data or not _scalar(value):
                    continue
                unit = self.units.get(field.name)
                data[f"{field.name} [{unit}]" if unit else field.name] = value
        return pd.Series(data, dtype=object, name=type(self).__name__)



@dataclass(frozen=True)
class CertificateRow(AnalysisResult):
    """One verdict of one method on one design: a row of :func:`~scara_robust.certificate_table`.

    Attributes
    ----------
    certified : bool or None
        True certified, False disproved, None neither (a search that found nothing, a
        skipped row, a solver that did not answer).
    verdict : str
        ``'certified'``, ``'not certified'``, ``'skipped'``, ``'not installed'``, ...
    message : str
        The row's detail: what was tested and what it gave.
    max_eig : float
        ``max λ`` of the tested matrix (Theorem 1's Z, or ``PĀ + ĀᵀP`` at the worst
        vertex), in P's unit times 1/s; NaN where it does not apply.
    decay_rate : float
        The state's verified decay rate α, 1/s (``V̇ <= −2αV``); NaN where it does not apply.
    growth_rate : float
        The largest growth rate of ‖x‖ found, 1/s; NaN where it does not apply.
    value : float
        The number of a method that registers its own table column; NaN otherwise.
    """

    certified: bool | None
    verdict: str
    message: str
    max_eig: float = math.nan
    decay_rate: float = math.nan
    growth_rate: float = math.nan
    value: float = math.nan

    units: ClassVar[dict[str, str]] = {"decay_rate": "1/s", "growth_rate": "1/s"}

    @property
    def status(self) -> str:
        """The verdict."""
        return self.verdict

    @classmethod
    def of(cls, certified: bool | None, message: str, **numbers: float) -> CertificateRow:
        """A row whose verdict follows from `certified` (:func:`verdict_of`).

        Parameters
        ----------
        certified : bool or None
        message : str
        **numbers : float
            ``max_eig``, ``decay_rate``, ``growth_rate`` or ``value``.

        Returns
        -------
        CertificateRow
        """
        return cls(certified, verdict_of(certified), message, **numbers)

    @classmethod
    def skipped(cls, reason: str, verdict: str = "skipped") -> CertificateRow:
        """A row that did not run, and why.

        Parameters
        ----------
        reason : str
        verdict : str
            ``'skipped'`` or ``'not installed'``.

        Returns
        -------
        CertificateRow
        """
        return cls(None, verdict, reason)
