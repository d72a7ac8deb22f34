"""The built-in certificate methods: Theorem 1, the design's P at the vertices, LMIs, the falsifier.

Each function takes a :class:`~scara_robust.CertificateContext` and returns a
:class:`~scara_robust.CertificateRow`; each is registered in the ``'certificate'`` family in
the order :func:`~scara_robust.certificate_table` shows them. On a polytope the ``-box``
methods run over its vertices (the table names them ``-polytope``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..lyapunov.theorem1 import certify
from ..results import CertificateRow
from .context import CertificateContext
from .falsifier import falsify
from .lmi import NOT_INSTALLED, lmi_certificate
from .polytope import polytope_certificate, vertex_certificate
from .registry import AnalysisMethod, register_method

__all__: list[str] = []


def _theorem1(elements: str) -> Callable[[CertificateContext], CertificateRow]:
    def run(context: CertificateContext) -> CertificateRow:
        cert = certify(context.model, context.design, elements)
        return CertificateRow.of(cert.certified, f"max eig Z = {cert.max_eig:.6g}", max_eig=cert.max_eig)

    return run


def _vertex_box(context: CertificateContext) -> CertificateRow:
    cert = vertex_certificate(context.model, context.design)
    return CertificateRow(cert.certified, cert.verdict, cert.message, max_eig=cert.max_eig)


def _physical(context: CertificateContext) -> CertificateRow:
    (loops, values, names), (loops_f, values_f, _) = context.sampled(context.grid), context.sampled(context.fine)
    P = context.design.P
    coarse = polytope_certificate(loops, P, values, set_name="physical")
    refined = polytope_certificate(loops_f, P, values_f, set_name="physical")
    agree = coarse.certified == refined.certified
    assert context.plant is not None
    plant = context.plant
    worst = ", ".join(f"{name} = {v:.4g} {plant.parameter(name).unit}"
                      for name, v in zip(names, np.atleast_1d(coarse.worst_point)))
    detail = (
        f"{coarse.message}; worst at {worst}; "
        f"{coarse.n_vertices} samples: max eig {coarse.max_eig:.6g}, {refined.n_vertices}: "
        f"{refined.max_eig:.6g}" + ("" if agree else " (verdict changed under refinement)")
    )
    return CertificateRow.of(coarse.certified and agree, detail, max_eig=max(coarse.max_eig, refined.max_eig))


def _lmi(context: CertificateContext, vertices: np.ndarray, checks: list[np.ndarray]) -> CertificateRow:
    # cutting planes on the vertices, grown from the checks' most violated loops: P holds on all of them
    result = lmi_certificate(vertices, check=checks, solver=context.lmi_solver)
    if result.status == NOT_INSTALLED:
        return CertificateRow.skipped(result.message, NOT_INSTALLED)
    if result.P is None or not checks:
        return CertificateRow(result.certified, result.verdict, result.message, decay_rate=result.decay_rate)
    margin = result.decay_rate  # numpy's rate on the vertices and every check together
    solved_on = len(vertices) if result.active is None else len(result.active)
    detail = (f"{result.message}; solved on {solved_on} of them (cutting planes); verified with numpy "
              f"on {len(vertices)}, {', '.join(str(len(c)) for c in checks)} samples")
    ok = margin > 0 and margin >= result.floor
    verdict = "certified" if ok else ("marginal" if margin > 0 else "inaccurate")
    return CertificateRow(ok, verdict, detail, decay_rate=margin)


def _lmi_box(context: CertificateContext) -> CertificateRow:
    return _lmi(context, context.vertex_loops(), [])


def _lmi_physical(context: CertificateContext) -> CertificateRow:
    checks = [context.sampled(context.grid)[0], context.sampled(context.fine)[0]]
    return _lmi(context, context.sampled(context.coarse)[0], checks)


def _falsify(context: CertificateContext, vertices: np.ndarray) -> CertificateRow:
    result = falsify(vertices, context.design.P, n_tries=context.falsifier_tries, seed=context.seed)
    return CertificateRow(result.certified, result.verdict, result.message, growth_rate=result.growth_rate)


def _falsifier_box(context: CertificateContext) -> CertificateRow:
    return _falsify(context, context.vertex_loops())


def _falsifier_physical(context: CertificateContext) -> CertificateRow:
    return _falsify(context, context.sampled(context.coarse)[0])


for _method in (
    AnalysisMethod("theorem1-all", "certificate", "certificate", _theorem1("all"),
                   "the paper's Theorem 1 over every interval element: max λ(Z) < 0",
                   frozenset({"P", "intervals"}), cheap=True),
    AnalysisMethod("theorem1-A", "certificate", "certificate", _theorem1("A"),
                   "Theorem 1 over the ΔA elements", frozenset({"P", "intervals"}), cheap=True),
    AnalysisMethod("theorem1-B", "certificate", "certificate", _theorem1("B"),
                   "Theorem 1 over the ΔB elements", frozenset({"P", "intervals"}), cheap=True),
    AnalysisMethod("vertex-box", "certificate", "certificate", _vertex_box,
                   "the design's P, exact over the interval box's corners", frozenset({"P", "vertices"}), cheap=True),
    AnalysisMethod("physical-polytope", "certificate", "certificate", _physical,
                   "the design's P on the plant's own frozen plants (grid and its refinement)",
                   frozenset({"P", "parameters"}), cheap=True),
    AnalysisMethod("lmi-box", "certificate", "certificate", _lmi_box,
                   "any common quadratic P over the box's corners (cvxpy)", frozenset({"vertices", "lmi"})),
    AnalysisMethod("lmi-physical", "certificate", "certificate", _lmi_physical,
                   "any common quadratic P over the plant's frozen plants, verified by numpy on two grids",
                   frozenset({"parameters", "lmi"})),
    AnalysisMethod("falsifier-box", "certificate", "upper", _falsifier_box,
                   "a switching signal among the corners that makes ‖x‖ grow", frozenset({"vertices"})),
    AnalysisMethod("falsifier-physical", "certificate", "upper", _falsifier_physical,
                   "a switching signal among the frozen plants that makes ‖x‖ grow", frozenset({"parameters"})),
):
    register_method(_method)
