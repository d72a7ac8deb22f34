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

import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from .._validation import check_choice, check_int
from ..lyapunov.gain import Design, as_design
from ..lyapunov.theorem1 import certify
from ..model.plant import ModelLike, UncertainPlant, as_model, as_plant
from .falsifier import falsify
from .lmi import LMI_SOLVERS, NOT_INSTALLED, lmi_certificate, verify_lyapunov
from .polytope import MAX_BOX_ELEMENTS, polytope_certificate, vertex_certificate

__all__ = ["CERTIFICATE_METHODS", "certificate_table"]

#: Rows of :func:`certificate_table`, in order.
CERTIFICATE_METHODS = (
    "theorem1-all",
    "theorem1-A",
    "theorem1-B",
    "vertex-box",
    "physical-polytope",
    "lmi-box",
    "lmi-physical",
    "falsifier-box",
    "falsifier-physical",
)
_MAX_EIG, _DECAY, _GROWTH = "max_eig", "decay_rate [1/s]", "growth_rate [1/s]"
_COLUMNS = ["method", "verdict", "certified", _MAX_EIG, _DECAY, _GROWTH, "seconds", "detail"]


def _timed(fn: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    start = time.perf_counter()
    row = fn()
    row["seconds"] = time.perf_counter() - start
    return row


def certificate_table(
    model: ModelLike,
    design: Design | ArrayLike,
    *,
    plant: UncertainPlant | None = None,
    points: Mapping[str, int] | None = None,
    lmi_points: Mapping[str, int] | None = None,
    lmi_solver: str = "CLARABEL",
    falsifier_tries: int = 30,
    seed: int = 0,
    methods: Sequence[str] = CERTIFICATE_METHODS,
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
    lmi_solver : {'CLARABEL', 'SCS'}
    falsifier_tries : int
        Trajectories per falsifier row.
    seed : int
        Seed of the falsifier.
    methods : sequence of str
        The rows to run, from :data:`CERTIFICATE_METHODS` (default all; the box rows by
        their ``-box`` names also for a polytope).

    Returns
    -------
    pandas.DataFrame
        One row per entry of `methods`, in the order of :data:`CERTIFICATE_METHODS` (with ``polytope`` for ``box``
        for a polytope), columns ``method``, ``verdict`` (text), ``certified`` (True,
        False, or None for "no counterexample", "not installed" and "skipped"),
        ``max_eig``, ``decay_rate [1/s]``, ``growth_rate [1/s]`` (each filled on the rows it
        belongs to, NaN elsewhere; see the module's table), ``seconds`` and ``detail``.

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
    check_choice("lmi_solver", lmi_solver, LMI_SOLVERS)
    for method in methods:
        check_choice("methods", method, CERTIFICATE_METHODS)
    if plant is not None:
        grid = {**{p.name: p.samples for p in plant.parameters}, **dict(points or {})}
        fine = {k: 2 * v - 1 for k, v in grid.items()}
        coarse = {**plant.coarse_points(), **dict(lmi_points or {})}
        for key, value in coarse.items():
            check_int(f"lmi_points[{key!r}]", value, 1)

    polytope = model.kind == "polytope"

    def skipped(reason: str) -> Callable[[], dict[str, Any]]:
        return lambda: {"verdict": "skipped", "certified": None, "detail": reason}

    def theorem1(elements: str) -> dict[str, Any]:
        if polytope:
            return skipped("Theorem 1 needs interval elements; a polytope's box hull is model.box_hull()")()
        cert = certify(model, design, elements)
        return {
            "certified": cert.certified,
            _MAX_EIG: cert.max_eig,
            "detail": f"max eig Z = {cert.max_eig:.6g}",
        }

    def vertex_box() -> dict[str, Any]:
        cert = vertex_certificate(model, design)
        row = {"certified": cert.certified, _MAX_EIG: cert.max_eig, "detail": cert.message}
        if not cert.certifiable:
            row["verdict"] = "no certificate can exist"
        return row

    cache: dict[tuple[tuple[str, int], ...], tuple[np.ndarray, np.ndarray, tuple[str, ...]]] = {}

    def sampled(at: Mapping[str, int]) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
        # the physical rows share their grids: each is sampled once
        key = tuple(sorted(at.items()))
        if key not in cache:
            assert plant is not None
            s = plant.samples(at)
            cache[key] = (s.closed_loops(design.K), s.values, s.names)
        return cache[key]

    def physical() -> dict[str, Any]:
        (loops, values, names), (loops_f, values_f, _) = sampled(grid), sampled(fine)
        coarse_cert = polytope_certificate(loops, design.P, values, set_name="physical")
        refined = polytope_certificate(loops_f, design.P, values_f, set_name="physical")
        agree = coarse_cert.certified == refined.certified
        assert plant is not None
        worst = ", ".join(f"{name} = {v:.4g} {plant.parameter(name).unit}"
                          for name, v in zip(names, np.atleast_1d(coarse_cert.worst_point)))
        detail = (
            f"{coarse_cert.message}; worst at {worst}; "
            f"{coarse_cert.n_vertices} samples: max eig {coarse_cert.max_eig:.6g}, {refined.n_vertices}: "
            f"{refined.max_eig:.6g}" + ("" if agree else " (verdict changed under refinement)")
        )
        return {"certified": coarse_cert.certified and agree, _MAX_EIG: max(coarse_cert.max_eig, refined.max_eig),
                "detail": detail}

    def lmi_row(vertices: np.ndarray, checks: list[np.ndarray]) -> dict[str, Any]:
        result = lmi_certificate(vertices, solver=lmi_solver)
        if result.status == NOT_INSTALLED:
            return {"verdict": NOT_INSTALLED, "certified": None, "detail": result.message}
        if result.P is None or not checks:
            return {"verdict": result.verdict, "certified": result.certified, _DECAY: result.margin,
                    "detail": result.message}
        margins = [verify_lyapunov(c, result.P)[1] for c in checks]
        margin = float(min(result.margin, *margins))
        detail = f"{result.message}; verified with numpy on {', '.join(str(len(c)) for c in checks)} samples"
        ok = margin > 0 and margin >= result.floor
        verdict = "certified" if ok else ("marginal" if margin > 0 else "inaccurate")
        return {"verdict": verdict, "certified": ok, _DECAY: margin, "detail": detail}

    def falsifier_row(vertices: np.ndarray) -> dict[str, Any]:
        result = falsify(vertices, design.P, n_tries=falsifier_tries, seed=seed)
        return {
            "verdict": "unstable trajectory found" if result.found else "no counterexample found",
            "certified": False if result.found else None,
            _GROWTH: result.growth_rate,
            "detail": result.message,
        }

    n_elements = 0 if polytope else len(model.elements)  # type: ignore[union-attr]
    too_many = n_elements > MAX_BOX_ELEMENTS
    box = model.vertex_closed_loops(design.K) if any(m.endswith("-box") for m in methods) and not too_many else None
    rows = {
        "theorem1-all": lambda: theorem1("all"),
        "theorem1-A": lambda: theorem1("A"),
        "theorem1-B": lambda: theorem1("B"),
        "vertex-box": vertex_box,
        "physical-polytope": physical,
        "lmi-box": lambda: lmi_row(np.asarray(box), []),
        "lmi-physical": lambda: lmi_row(sampled(coarse)[0], [sampled(grid)[0], sampled(fine)[0]]),
        "falsifier-box": lambda: falsifier_row(np.asarray(box)),
        "falsifier-physical": lambda: falsifier_row(sampled(coarse)[0]),
    }
    if too_many:
        reason = (f"the box has 2^{n_elements} = {2.0 ** n_elements:.3g} corners, beyond the exact "
                  f"vertex tests (at most 2^{MAX_BOX_ELEMENTS}); Theorem 1 and the physical rows answer")
        for method in ("vertex-box", "lmi-box", "falsifier-box"):
            rows[method] = skipped(reason)
    if plant is None:
        reason = "needs a plant with physical parameters (its frozen plants on the parameter grid)"
        for method in ("physical-polytope", "lmi-physical", "falsifier-physical"):
            rows[method] = skipped(reason)
    records = []
    for method in (m for m in CERTIFICATE_METHODS if m in methods):
        row = _timed(rows[method])
        row["method"] = method.replace("-box", "-polytope") if polytope else method
        if "verdict" not in row:
            row["verdict"] = "certified" if row["certified"] else "not certified"
        records.append(row)
    return pd.DataFrame(records, columns=_COLUMNS)
