"""Exact tests for a fixed Lyapunov matrix over a polytope of closed-loop matrices.

For a fixed P, ``V̇ = xᵀ(PĀ(h) + Ā(h)ᵀP)x`` is affine in the uncertain parameters h, and
``λmax`` of a symmetric matrix is convex, so over a polytope of matrices its maximum is
attained at a vertex. Two polytopes are offered:

* the interval **box** of an :class:`~scara_robust.UncertainLTVModel` (2^N vertices), the
  set Theorem 1 covers; its test is exact where Theorem 1 only bounds each element;
* the **physical** polytope: the convex hull of the robot's own (A, B) pairs sampled
  along the reference and payload range (:func:`scara_robust.physical_samples`).

Both also report the largest real part of the frozen closed-loop eigenvalues over the
vertices: a vertex with a positive one means no quadratic or other certificate of any
kind can exist for that set, since the constant parameter held at that vertex is itself
an admissible, unstable, case.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_closed_loops, check_symmetric
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import ModelLike, as_box, as_model
from ..model.uncertain import ELEMENT_SETS, UncertainLTVModel
from ..results import AnalysisResult, VerdictFromCertified
from ._spectra import lyapunov_decreases, spectral_abscissae

__all__ = ["PolytopeCertificate", "polytope_certificate", "vertex_certificate"]

Array = NDArray[np.float64]

#: Largest number of uncertain elements a box test enumerates (2^16 = 65 536 vertices).
MAX_BOX_ELEMENTS = 16
_CHUNK = 4096


@dataclass(frozen=True)
class PolytopeCertificate(VerdictFromCertified, AnalysisResult):
    """Result of the exact fixed-P test over a polytope.

    Attributes
    ----------
    max_eig : float
        ``max_v λmax(PĀ_v + Ā_vᵀP)`` over the vertices, 1/s scaled by P. Negative means
        V(x) = xᵀPx decreases along every admissible time-varying parameter.
    worst_index : int
        Index of the vertex attaining `max_eig`.
    worst_point : ndarray, shape (p,)
        That vertex's coordinates: the element values h (box) or ``(t, m_p)`` in s and
        kg (physical samples).
    n_vertices : int
    max_real_pole : float
        Largest real part of the eigenvalues of any frozen ``Ā_v``, 1/s.
    n_unstable : int
        Number of vertices whose frozen closed loop has an eigenvalue with positive real
        part.
    set_name : str
        ``'box'`` or ``'physical'``.
    """

    max_eig: float
    worst_index: int
    worst_point: Array
    n_vertices: int
    max_real_pole: float
    n_unstable: int
    set_name: str

    @property
    def verdict(self) -> str:
        """``'certified'``, ``'not certified'``, or ``'no certificate can exist'`` (a vertex is unstable)."""
        if self.certified:
            return "certified"
        return "not certified" if self.certifiable else "no certificate can exist"

    @property
    def certified(self) -> bool:
        """``max_eig < 0``: P proves robust stability on the whole polytope."""
        return bool(self.max_eig < 0)

    @property
    def certifiable(self) -> bool:
        """False when a frozen vertex is unstable: then no certificate of any kind exists."""
        return self.n_unstable == 0

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        if self.certified:
            return f"certified: V decreases at all {self.n_vertices} vertices of the {self.set_name} set"
        if not self.certifiable:
            return (
                f"no certificate can exist: {self.n_unstable} of {self.n_vertices} frozen vertices are unstable "
                f"(largest real part {self.max_real_pole:.4g} 1/s)"
            )
        return (
            f"not certified with this P (max eig {self.max_eig:.4g} at vertex {self.worst_index}); "
            "all frozen vertices are stable, so another P may exist (see the LMI test)"
        )


def box_vertices(model: UncertainLTVModel) -> Array:
    """All 2^N corners of the model's interval box.

    Parameters
    ----------
    model : UncertainLTVModel

    Returns
    -------
    ndarray, shape (2**N, N)
        Row v holds the element values h of vertex v; bit j of v selects the upper bound
        of element j.

    Raises
    ------
    ValueError
        If N exceeds :data:`MAX_BOX_ELEMENTS`.
    """
    if "intervals" not in getattr(model, "capabilities", ()):
        raise TypeError(f"`model` must be an UncertainLTVModel, found {type(model).__name__}")
    n = model.n_elements
    if n > MAX_BOX_ELEMENTS:
        raise ValueError(
            f"`model` must have at most {MAX_BOX_ELEMENTS} uncertain elements for a vertex test "
            f"(2^N vertices), found {n}"
        )
    return model.box_vertices()


def box_closed_loops(model: UncertainLTVModel, K: ArrayLike) -> Array:
    """Frozen closed-loop matrices ``A + ΔA_v − (B + ΔB_v)K`` at every box vertex.

    Parameters
    ----------
    model : UncertainLTVModel
    K : array_like, shape (m, n)
        Gain of ``u = -Kx``.

    Returns
    -------
    ndarray, shape (2**N, n, n)
    """
    box_vertices(model)  # the type and size checks
    return model.vertex_closed_loops(K)


def polytope_certificate(
    closed_loops: ArrayLike, P: ArrayLike, points: ArrayLike | None = None, set_name: str = "polytope"
) -> PolytopeCertificate:
    """Exact fixed-P test over the convex hull of given closed-loop matrices.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
        Frozen closed-loop matrices Ā_v at the vertices.
    P : array_like, shape (n, n)
        Symmetric positive definite Lyapunov matrix; asymmetry beyond rounding
        (relative 1e-8) is refused.
    points : array_like, shape (V, p), optional
        Coordinates of each vertex, reported for the worst one (default: the index).
    set_name : str
        Name used in messages.

    Returns
    -------
    PolytopeCertificate
    """
    A_v = check_closed_loops("closed_loops", closed_loops)
    n = A_v.shape[1]
    P_sym = check_symmetric("P", check_array("P", P, shape=(n, n)))
    if np.linalg.eigvalsh(P_sym)[0] <= 0:
        raise ValueError("`P` must be positive definite, found a non-positive eigenvalue")
    pts = np.arange(A_v.shape[0], dtype=float)[:, None] if points is None else check_array("points", points, ndim=2)
    if pts.shape[0] != A_v.shape[0]:
        raise ValueError(f"`points` must have one row per vertex ({A_v.shape[0]}), found {pts.shape[0]}")
    worst_eig = np.empty(A_v.shape[0])
    real_part = np.empty(A_v.shape[0])
    for start in range(0, A_v.shape[0], _CHUNK):
        chunk = A_v[start : start + _CHUNK]
        PA = P_sym @ chunk
        worst_eig[start : start + _CHUNK] = np.linalg.eigvalsh(PA + np.swapaxes(PA, -1, -2))[:, -1]
        real_part[start : start + _CHUNK] = spectral_abscissae(chunk)  # numpy's eigvals, split between the cores
    worst = int(np.argmax(worst_eig))
    return PolytopeCertificate(
        max_eig=float(worst_eig[worst]),
        worst_index=worst,
        worst_point=pts[worst].copy(),
        n_vertices=int(A_v.shape[0]),
        max_real_pole=float(real_part.max()),
        n_unstable=int((real_part > 0).sum()),
        set_name=set_name,
    )


def fixed_p_certifies(closed_loops: ArrayLike, P: ArrayLike) -> bool:
    """``polytope_certificate(closed_loops, P).certified``, with the same checks of its arguments.

    A search needs the verdict alone: numpy's Cholesky factorization answers it where it
    proves every vertex's inequality with a margin (:func:`~scara_robust.robustness._spectra.
    lyapunov_decreases`), and the eigenvalues where it does not.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    P : array_like, shape (n, n)

    Returns
    -------
    bool
    """
    A_v = check_closed_loops("closed_loops", closed_loops)
    n = A_v.shape[1]
    P_sym = check_symmetric("P", check_array("P", P, shape=(n, n)))
    if np.linalg.eigvalsh(P_sym)[0] <= 0:
        raise ValueError("`P` must be positive definite, found a non-positive eigenvalue")
    return lyapunov_decreases(A_v, P_sym)


def vertex_certificate(
    model: ModelLike, design: Design, elements: str = "all"
) -> PolytopeCertificate:
    """Exact test of the design's P over the interval box (all 2^N vertices) or a polytope's vertices.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
    design : Design
        Supplies K and P (the Riccati/Lyapunov P of Theorem 1's step 1).
    elements : {'all', 'A', 'B'}
        Which uncertain elements vary; the others stay at their lower bounds (see
        :meth:`UncertainLTVModel.subset`). A polytope takes ``'all'`` only.

    Returns
    -------
    PolytopeCertificate
        ``max_eig`` is never above Theorem 1's ``max λ(Z)``, since Z bounds every vertex.

    See Also
    --------
    polytope_certificate : the same test over a polytope's vertices.
    lmi_certificate : any common P, not only the design's.

    Examples
    --------
    >>> import scara_robust as sr
    >>> m = sr.paper_model()
    >>> cert = sr.vertex_certificate(m, sr.design(m, 3, 90))
    >>> cert.n_vertices, cert.certifiable
    (1024, False)
    """
    if design_or_none(design) is None:
        raise TypeError(f"`design` must be a Design from scara_robust.design, found {type(design).__name__}")
    check_choice("elements", elements, ELEMENT_SETS)
    sub = as_model("model", model).subset(elements)
    if "intervals" in sub.capabilities:
        box_vertices(as_box("model", sub))  # the size check
    return polytope_certificate(sub.vertex_closed_loops(design.K), design.P, sub.vertex_points(), set_name=sub.kind)


