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
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd

from .._validation import check_choice, check_instance, check_int
from ..lyapunov.gain import Design
from ..lyapunov.theorem1 import certify
from ..model.polytopic import PolytopicModel
from ..model.robot import PayloadProfile, ScaraParams
from ..model.signals import Reference
from ..model.uncertain import UncertainLTVModel, physical_samples
from .falsifier import falsify
from .lmi import LMI_SOLVERS, NOT_INSTALLED, lmi_certificate, verify_lyapunov
from .polytope import box_closed_loops, physical_certificate, vertex_certificate

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
    model: UncertainLTVModel | PolytopicModel,
    design: Design,
    *,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    n_times: int = 721,
    n_masses: int = 21,
    lmi_times: int = 37,
    lmi_masses: int = 5,
    lmi_solver: str = "CLARABEL",
    falsifier_tries: int = 30,
    seed: int = 0,
) -> pd.DataFrame:
    """Run every certificate on one design and tabulate verdict, margin and time.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
        The interval box (published or derived bounds, or your plant's), or a polytope.
    design : Design
        The design K(ρ, η) and its P.
    params, reference, payload
        Robot, reference and payload of the physical set (defaults: the paper's).
    n_times, n_masses : int
        Sampling of the physical set over one reference period × the payload range. The
        physical rows are repeated at ``(2 n_times − 1, 2 n_masses − 1)`` samples and are
        certified only if both verdicts agree.
    lmi_times, lmi_masses : int
        Coarser sampling on which the physical LMI is solved; its P is then verified
        with numpy on both dense samplings above.
    lmi_solver : {'CLARABEL', 'SCS'}
    falsifier_tries : int
        Trajectories per falsifier row.
    seed : int
        Seed of the falsifier.

    Returns
    -------
    pandas.DataFrame
        One row per entry of :data:`CERTIFICATE_METHODS` (with ``polytope`` for ``box``
        for a polytope), columns ``method``, ``verdict`` (text), ``certified`` (True,
        False, or None for "no counterexample", "not installed" and "skipped"),
        ``max_eig``, ``decay_rate [1/s]``, ``growth_rate [1/s]`` (each filled on the rows it
        belongs to, NaN elsewhere; see the module's table), ``seconds`` and ``detail``.
    """
    check_instance("model", model, (UncertainLTVModel, PolytopicModel), "an UncertainLTVModel or a PolytopicModel")
    check_instance("design", design, Design, "a Design from scara_robust.design()")
    check_choice("lmi_solver", lmi_solver, LMI_SOLVERS)
    lmi_times, lmi_masses = check_int("lmi_times", lmi_times, 2), check_int("lmi_masses", lmi_masses, 1)
    fine_times, fine_masses = 2 * int(n_times) - 1, 2 * int(n_masses) - 1

    polytope = isinstance(model, PolytopicModel)

    def skipped(reason: str) -> Callable[[], dict[str, Any]]:
        return lambda: {"verdict": "skipped", "certified": None, "detail": reason}

    def theorem1(elements: str) -> dict[str, Any]:
        if polytope:
            return skipped("Theorem 1 needs interval elements; a polytope's box hull is model.box_hull()")()
        assert isinstance(model, UncertainLTVModel)
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

    def physical() -> dict[str, Any]:
        coarse = physical_certificate(design, params, reference, payload, n_times=n_times, n_masses=n_masses)
        refined = physical_certificate(design, params, reference, payload, n_times=fine_times, n_masses=fine_masses)
        agree = coarse.certified == refined.certified
        detail = (
            f"{coarse.message}; worst at t = {coarse.worst_point[0]:.4g} s, m_p = {coarse.worst_point[1]:.4g} kg; "
            f"{coarse.n_vertices} samples: max eig {coarse.max_eig:.6g}, {refined.n_vertices}: {refined.max_eig:.6g}"
            + ("" if agree else " (verdict changed under refinement)")
        )
        return {"certified": coarse.certified and agree, _MAX_EIG: max(coarse.max_eig, refined.max_eig),
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

    def sampled(n_t: int, n_m: int) -> np.ndarray:
        s = physical_samples(params, reference, payload, times=np.linspace(0.0, 2 * np.pi, n_t), n_masses=n_m)
        return s.A - s.B @ design.K

    def falsifier_row(vertices: np.ndarray) -> dict[str, Any]:
        result = falsify(vertices, design.P, n_tries=falsifier_tries, seed=seed)
        return {
            "verdict": "unstable trajectory found" if result.found else "no counterexample found",
            "certified": False if result.found else None,
            _GROWTH: result.growth_rate,
            "detail": result.message,
        }

    box = model.closed_loops(design.K) if isinstance(model, PolytopicModel) else box_closed_loops(model, design.K)
    rows = {
        "theorem1-all": lambda: theorem1("all"),
        "theorem1-A": lambda: theorem1("A"),
        "theorem1-B": lambda: theorem1("B"),
        "vertex-box": vertex_box,
        "physical-polytope": physical,
        "lmi-box": lambda: lmi_row(box, []),
        "lmi-physical": lambda: lmi_row(
            sampled(lmi_times, lmi_masses), [sampled(n_times, n_masses), sampled(fine_times, fine_masses)]
        ),
        "falsifier-box": lambda: falsifier_row(box),
        "falsifier-physical": lambda: falsifier_row(sampled(lmi_times, lmi_masses)),
    }
    if not getattr(model, "scara", False):
        reason = "applies to the SCARA's own error model only (the robot's sampled (A, B) along the reference)"
        for method in ("physical-polytope", "lmi-physical", "falsifier-physical"):
            rows[method] = skipped(reason)
    records = []
    for method in CERTIFICATE_METHODS:
        row = _timed(rows[method])
        row["method"] = method.replace("-box", "-polytope") if polytope else method
        if "verdict" not in row:
            row["verdict"] = "certified" if row["certified"] else "not certified"
        records.append(row)
    return pd.DataFrame(records, columns=_COLUMNS)
