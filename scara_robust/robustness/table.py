"""How conservative is Theorem 1? Every certificate of one design, side by side.

:func:`certificate_table` runs, for one design K(ρ, η):

=========================  =====================================================  ======================
method                     question answered                                      its number (column)
=========================  =====================================================  ======================
theorem1-all/-A/-B         the paper's Theorem 1 (elements: all, ΔA, ΔB)           max λ(Z) (``max_eig``)
vertex-box                 design P, exact over the interval box                  max λ(PĀ_v + Ā_vᵀP)
physical-polytope          design P, exact over the robot's own sampled (A, B)    the same
lmi-box                    any common quadratic P over the box (cvxpy)            ``decay_rate [1/s]``
lmi-physical               any common quadratic P over the sampled robot          ``decay_rate [1/s]``
falsifier-box              a switching h(t) in the box that makes ‖x‖ grow        ``growth_rate [1/s]``
falsifier-physical         the same over the sampled robot                        ``growth_rate [1/s]``
=========================  =====================================================  ======================

``max_eig`` < 0 certifies (its unit is P's times 1/s); ``decay_rate`` is the state's
verified decay rate α, ``V̇ <= −2αV`` (> 0 certifies); ``growth_rate`` is the largest growth
rate of ‖x‖ the falsifier found (> 0 disproves). ``python -m
scara_robust certify`` prints the table. For a :class:`~scara_robust.PolytopicModel` the
box rows run over the polytope's vertices and are named ``vertex-polytope``,
``lmi-polytope`` and ``falsifier-polytope``; rows that do not apply (Theorem 1 for a
polytope, the physical rows for any model but the SCARA's own) are kept with verdict
``skipped`` and the reason.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence

import pandas as pd
from numpy.typing import ArrayLike

from .._validation import check_choice, check_int
from ..lyapunov.gain import Design, as_design
from ..model.plant import ModelLike, UncertainPlant, as_model, as_plant
from ..results import CertificateRow
from ..sdp.backends import default_lmi_solver
from .context import CertificateContext
from .lmi import LMI_SOLVERS
from .registry import analysis_methods, checked_result, get_method

__all__ = ["CERTIFICATE_METHODS", "certificate_table"]

#: The built-in rows of :func:`certificate_table`, in order (the registry holds them, and any
#: method registered since: :func:`~scara_robust.analysis_methods` ``('certificate')``).
CERTIFICATE_METHODS = analysis_methods("certificate", defaults=True)
_MAX_EIG, _DECAY, _GROWTH = "max_eig", "decay_rate [1/s]", "growth_rate [1/s]"
_COLUMNS = ["method", "verdict", "certified", _MAX_EIG, _DECAY, _GROWTH, "seconds", "detail"]


def certificate_table(
    model: ModelLike,
    design: Design | ArrayLike,
    *,
    plant: UncertainPlant | None = None,
    points: Mapping[str, int] | None = None,
    lmi_points: Mapping[str, int] | None = None,
    lmi_solver: str | None = None,
    falsifier_tries: int = 30,
    seed: int = 0,
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """Run every certificate on one design and tabulate verdict, margin and time.

    Parameters
    ----------
    model : UncertainPlant, UncertainLTVModel or PolytopicModel
        The uncertainty set: a plant (its interval hull, and its samples for the
        ``physical`` rows), an interval box or a polytope.
    design : Design or array_like, shape (m, n)
        The design K(ρ, η) and its P, or a gain K of your own (``Design.from_gain(model, K)``:
        the rows that test one P, Theorem 1 and the vertex tests, use the P of
        ``PĀ + ĀᵀP = −2I``).
    plant : UncertainPlant, optional
        Whose frozen plants on the parameter grid make the ``physical`` rows (default:
        `model` when it is a plant; the rows are skipped without one).
    points : mapping of str to int, optional
        Grid of the physical rows, points per parameter (default: each parameter's
        ``samples``; for the SCARA 721 reference times × 21 masses). The rows are repeated
        on the grid refined once (``2k − 1`` points) and are certified only if both
        verdicts agree.
    lmi_points : mapping of str to int, optional
        Coarser grid on which the physical LMI is solved (default: each parameter's
        ``coarse``); its P is then verified with numpy on both grids above.
    lmi_solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    falsifier_tries : int
        Trajectories per falsifier row.
    seed : int
        Seed of the falsifier.
    methods : sequence of str, optional
        The rows to run, by registered name (:func:`~scara_robust.analysis_methods`
        ``('certificate')``; the box rows by their ``-box`` names also for a polytope).
        Default: every method registered as a default, which are the built-in rows of
        :data:`CERTIFICATE_METHODS`.

    Returns
    -------
    pandas.DataFrame
        One row per entry of `methods`, in the registry's order (with ``polytope`` for ``box``
        for a polytope), columns ``method``, ``verdict`` (text), ``certified`` (True,
        False, or None for "no counterexample", "not installed" and "skipped"),
        ``max_eig``, ``decay_rate [1/s]``, ``growth_rate [1/s]`` (each filled on the rows it
        belongs to, NaN elsewhere; see the module's table), ``seconds`` and ``detail``; a
        registered method with a ``column`` of its own adds that column.

    See Also
    --------
    certify : Theorem 1.
    vertex_certificate : the design's P at every corner of the box.
    lmi_certificate : a common quadratic P.
    falsify : a destabilizing switching signal.
    max_sample_time : the largest certified sample time.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> table = sr.certificate_table(box, sr.design(box, 1.0, 2.0), methods=("theorem1-all", "vertex-box"))
    >>> table["verdict"].tolist()
    ['certified', 'certified']
    """
    plant = plant if plant is not None else as_plant("model", model)
    model = as_model("model", model)
    design = as_design(model, design)
    lmi_solver = default_lmi_solver() if lmi_solver is None else check_choice("lmi_solver", lmi_solver, LMI_SOLVERS)
    names = analysis_methods("certificate", defaults=True) if methods is None else tuple(methods)
    chosen = {name: get_method("certificate", name, argument="methods") for name in names}
    context = CertificateContext(model, design, plant, lmi_solver=lmi_solver, falsifier_tries=falsifier_tries,
                                 seed=seed)
    if plant is not None:
        context.grid = {**plant.grid_points(), **dict(points or {})}
        context.fine = {k: 2 * v - 1 for k, v in context.grid.items()}
        context.coarse = {**plant.coarse_points(), **dict(lmi_points or {})}
        for key, value in context.coarse.items():
            check_int(f"lmi_points[{key!r}]", value, 1)
    records = []
    columns = list(_COLUMNS)
    for name in (m for m in analysis_methods("certificate") if m in chosen):
        method = chosen[name]
        start = time.perf_counter()
        reason = context.missing(method.needs)
        result = CertificateRow.skipped(reason) if reason else checked_result(method, method.run(context))
        row = {
            "method": name.replace("-box", "-polytope") if context.is_polytope else name,
            "verdict": result.verdict,
            "certified": result.certified,
            _MAX_EIG: getattr(result, "max_eig", math.nan),
            _DECAY: getattr(result, "decay_rate", math.nan),
            _GROWTH: getattr(result, "growth_rate", math.nan),
            "seconds": time.perf_counter() - start,
            "detail": result.message,
        }
        if method.column is not None:
            row[method.column] = getattr(result, "value", math.nan)
            if method.column not in columns:
                columns.insert(columns.index("seconds"), method.column)
        records.append(row)
    return pd.DataFrame(records, columns=columns)
