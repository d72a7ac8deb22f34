"""The design surface ``max λ(Z(ρ, η))`` over a (ρ, η) grid (procedure steps 1-5, Figure 2).

The structured evaluation uses the shape of the procedure. For fixed ρ the Riccati
solution P is fixed, ``K = η K₁`` with ``K₁ = ρBᵀP``, and every E_j of a ΔB element is
η times its value for K₁. Because ``(ηΨ)⁺ = ηΨ⁺`` for η > 0, Theorem 1 gives

    Z(ρ, η) = Z₀(ρ) + η Z₁(ρ),

    Z₀ = PA + AᵀP + Σ_{ΔA} (h_l Ψ_j + (h_u - h_l) Ψ_j⁺),
    Z₁ = -(PBK₁ + K₁ᵀBᵀP) + Σ_{ΔB} (h_l Ψ_j(K₁) + (h_u - h_l) Ψ_j⁺(K₁)).

Every E_j is rank one (``E_j = a_j b_jᵀ``), so every Ψ_j is ``u vᵀ + v uᵀ`` with
``u = P a_j`` and its positive part has a closed form
(:func:`scara_robust.lyapunov.theorem1.rank2_positive_part`): each ρ costs one Riccati solve
and a few small matrix products, all batched over ρ, and each grid point one batched 6x6
symmetric eigenvalue. The Hurwitz flags come from a Lyapunov argument: ``PĀ + ĀᵀP =
N₀ + ηN₁`` with ``N₁ = −2ρPBBᵀP ⪯ 0``, so one eigenvalue per ρ proves all η at once;
closed-loop eigenvalues are computed only where that proof fails.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._deprecation import renamed_argument
from .._resources import check_memory
from .._validation import check_array, check_choice
from ..exceptions import ArgumentValueError
from ..model.plant import as_box
from ..model.uncertain import ELEMENT_SETS, UncertainLTVModel
from .gain import design, riccati_solution
from .theorem1 import affine_margin, certify, rank2_positive_part

__all__ = [
    "DesignSurface",
    "design_surface",
    "SURFACE_FORMULATIONS",
    "SURFACE_METHODS",
    "SURFACE_MEASURES",
    "MARGIN_MAP_METHODS",
    "MAX_SURFACE_POINTS",
]

Array = NDArray[np.float64]
#: How the surface is computed: ``Z = Z₀(ρ) + η Z₁(ρ)`` per ρ, or design and certify point by point.
SURFACE_FORMULATIONS = ("structured", "reference")
#: Deprecated name of :data:`SURFACE_FORMULATIONS` (``method`` names an analysis method).
SURFACE_METHODS = SURFACE_FORMULATIONS
#: What a surface holds besides max λ(Z): nothing more, or the robustness margin θ.
SURFACE_MEASURES = ("max_eig", "margin")
#: Certificates of a margin map: Theorem 1, or the design's P at the box's vertices.
MARGIN_MAP_METHODS = ("theorem1", "vertex")
#: Largest grid (n_rho × n_eta points) one :func:`design_surface` call evaluates: about
#: 0.9 GB of working memory for a 6-state model (see :func:`surface_memory`) and a few
#: seconds; split larger sweeps into several calls.
MAX_SURFACE_POINTS = 1_000_000


def surface_memory(n_points: int, n_states: int) -> int:
    """Working memory of the structured surface, bytes: three float64 n x n matrices per point.

    Parameters
    ----------
    n_points : int
        Grid points, n_rho × n_eta.
    n_states : int
        n.

    Returns
    -------
    int
    """
    return 3 * 8 * int(n_points) * int(n_states) ** 2


@dataclass(frozen=True)
class DesignSurface:
    """``max λ(Z)`` on a (ρ, η) grid.

    Attributes
    ----------
    rhos : ndarray, shape (n_rho,)
    etas : ndarray, shape (n_eta,)
    max_eig : ndarray, shape (n_rho, n_eta)
        ``max λ(Z(ρ_i, η_k))``.
    hurwitz : ndarray of bool, shape (n_rho, n_eta)
        ``Ā(ρ_i, η_k)`` is Hurwitz.
    elements : str
        Elements that entered Z (``'all'``, ``'A'`` or ``'B'``).
    model_name : str
    margin : ndarray, shape (n_rho, n_eta), or None
        With ``measure='margin'``: the robustness margin θ of each design (the largest
        scaling of every element range certified by `margin_method`); None otherwise.
    margin_method : str or None
        ``'theorem1'`` or ``'vertex'``.
    """

    rhos: Array
    etas: Array
    max_eig: Array
    hurwitz: NDArray[np.bool_]
    elements: str
    model_name: str
    margin: Array | None = None
    margin_method: str | None = None

    @property
    def certified(self) -> NDArray[np.bool_]:
        """Points with ``Ā`` Hurwitz and ``max λ(Z) < 0``, shape (n_rho, n_eta)."""
        return self.hurwitz & (self.max_eig < 0)

    def to_pandas(self) -> pd.DataFrame:
        """Tidy table, one row per grid point: rho, eta, max_eig_Z, closed_loop_hurwitz, certified (, margin)."""
        rho, eta = np.meshgrid(self.rhos, self.etas, indexing="ij")
        columns = {
            "rho": rho.ravel(),
            "eta": eta.ravel(),
            "max_eig_Z": self.max_eig.ravel(),
            "closed_loop_hurwitz": self.hurwitz.ravel(),
            "certified": self.certified.ravel(),
        }
        if self.margin is not None:
            columns["margin"] = self.margin.ravel()
        return pd.DataFrame(columns)

    def best_margin(self) -> tuple[float, float, float]:
        """``(rho, eta, margin)`` of the grid point with the largest robustness margin.

        Returns
        -------
        tuple of float

        Raises
        ------
        ValueError
            If the surface has no margins (``measure='margin'`` was not asked for).
        """
        if self.margin is None:
            raise ValueError("`surface` has no margins: compute it with design_surface(..., measure='margin')")
        i, k = np.unravel_index(int(np.argmax(self.margin)), self.margin.shape)
        return float(self.rhos[i]), float(self.etas[k]), float(self.margin[i, k])

    def best(self) -> tuple[float, float, float]:
        """``(rho, eta, max_eig)`` of the Hurwitz grid point with the smallest max λ(Z).

        Raises
        ------
        ValueError
            If no grid point has a Hurwitz closed loop.
        """
        if not self.hurwitz.any():
            raise ValueError("`surface` has no grid point with a Hurwitz closed loop")
        masked = np.where(self.hurwitz, self.max_eig, np.inf)
        i, k = np.unravel_index(int(np.argmin(masked)), masked.shape)
        return float(self.rhos[i]), float(self.etas[k]), float(self.max_eig[i, k])


def _grid(name: str, values: ArrayLike, minimum: float, strict: bool) -> Array:
    arr = check_array(name, values, ndim=1)
    if arr.size == 0:
        raise ArgumentValueError(name, "must hold at least one value, found none")
    bad = arr <= minimum if strict else arr < minimum
    if bad.any():
        op = ">" if strict else ">="
        raise ArgumentValueError(name, f"must be {op} {minimum}, found {arr[bad][0]}")
    return arr


def _sym(M: Array) -> Array:
    return np.asarray(M + np.swapaxes(M, -1, -2), dtype=float)


def _structured_terms(model: UncertainLTVModel, elements: str, rhos: Array) -> tuple[Array, ...]:
    """``Z₀, Z₁``, the nominal ``PĀ + ĀᵀP = N₀ + ηN₁``, P and ``BK₁`` for every ρ, shape (n_rho, n, n).

    The gain is designed on the whole model's nominal (A, B); Z is built on
    ``model.subset(elements)``, whose nominal holds the left-out elements at their lower bounds.
    """
    P = np.array([riccati_solution(model, rho) for rho in rhos])
    A, B = model.A, model.B
    K1 = rhos[:, None, None] * np.einsum("ji,rjk->rik", B, P)  # ρBᵀP
    N0 = _sym(P @ A)
    N1 = -_sym(P @ B @ K1)
    model = model.subset(elements)
    a, b = model.perturbation_factors(K1)  # E_j = a_j b_jᵀ: a (N, n), b (n_rho, N, n)
    u = np.einsum("rik,jk->rji", P, a)  # P a_j
    Psi = u[..., :, None] * b[..., None, :]
    Psi = Psi + np.swapaxes(Psi, -1, -2)
    lower, width = model.lower_bounds(), model.upper_bounds() - model.lower_bounds()
    terms = lower[:, None, None] * Psi + width[:, None, None] * rank2_positive_part(u, b)
    in_A = np.array([el.matrix == "A" for el in model.elements], dtype=bool)
    Z0 = _sym(P @ model.A) + terms[:, in_A].sum(axis=1)
    Z1 = -_sym(P @ model.B @ K1) + terms[:, ~in_A].sum(axis=1)
    return Z0, Z1, N0, N1, P, B @ K1


def _hurwitz(A: Array, etas: Array, N0: Array, N1: Array, P: Array, BK1: Array) -> NDArray[np.bool_]:
    """Hurwitz flags of ``Ā = A − ηBK₁`` by a Lyapunov argument, eigenvalues where it fails.

    ``PĀ + ĀᵀP = N₀ + ηN₁`` with ``N₁ = −2ρPBBᵀP ⪯ 0``, so if P ≻ 0 and it is negative
    definite at the smallest η of the grid, it is at every larger η and Ā is Hurwitz
    there. Rows of ρ where this does not hold get the closed-loop eigenvalues.
    """
    eta_min = etas.min()
    lyap_min = np.linalg.eigvalsh(N0 + eta_min * N1)[:, -1]
    n1_max = np.linalg.eigvalsh(N1)[:, -1]
    scale = np.abs(N1).max(axis=(-1, -2)) + np.abs(N0).max(axis=(-1, -2))
    proven = (np.linalg.eigvalsh(P)[:, 0] > 0) & (lyap_min < 0) & (n1_max <= 1e-12 * scale)
    hurwitz = np.ones((P.shape[0], etas.size), dtype=bool)
    rest = np.flatnonzero(~proven)
    if rest.size:
        A_cl = A[None, None] - etas[None, :, None, None] * BK1[rest][:, None]
        hurwitz[rest] = np.all(np.linalg.eigvals(A_cl).real < 0, axis=-1)
    return hurwitz


def _vertex_margins(
    model: UncertainLTVModel, elements: str, rhos: Array, etas: Array, P: Array, base: Array
) -> Array:
    """min over the box's vertices of the exact margin of the design's P, shape (n_rho, n_eta)."""
    sub = model.subset(elements)
    held = np.array([elements not in ("all", el.matrix) for el in model.elements], dtype=bool)
    in_A = np.array([el.matrix == "A" for el in model.elements], dtype=bool)
    H = sub.box_vertices()  # (V, N_sub)
    sub_A = np.array([el.matrix == "A" for el in sub.elements], dtype=bool)
    margins = np.empty((rhos.size, etas.size))
    for r, rho in enumerate(rhos):
        K1 = rho * model.B.T @ P[r]
        E_all = model.perturbation_matrices(K1)  # ΔB elements at η = 1: E scales with η
        E_sub = sub.perturbation_matrices(K1)
        lower = model.lower_bounds() * held
        shift_A = np.einsum("j,jik->ik", lower * in_A, E_all)
        shift_B = np.einsum("j,jik->ik", lower * ~in_A, E_all)
        D_A = shift_A + np.einsum("vj,jik->vik", H[:, sub_A], E_sub[sub_A])
        D_B = shift_B + np.einsum("vj,jik->vik", H[:, ~sub_A], E_sub[~sub_A])
        S_A = P[r] @ D_A + np.swapaxes(D_A, -1, -2) @ P[r]
        S_B = P[r] @ D_B + np.swapaxes(D_B, -1, -2) @ P[r]
        S = S_A[None] + etas[:, None, None, None] * S_B[None]  # (n_eta, V, n, n)
        margins[r] = affine_margin(np.broadcast_to(base[r][:, None], S.shape), S).min(axis=1)
    return margins


def design_surface(
    model: UncertainLTVModel,
    rhos: ArrayLike,
    etas: ArrayLike,
    elements: str = "all",
    *,
    formulation: str = "structured",
    measure: str = "max_eig",
    margin_method: str = "theorem1",
    method: str | None = None,
) -> DesignSurface:
    """Evaluate ``max λ(Z)`` of Theorem 1 on the grid ``rhos × etas``.

    Parameters
    ----------
    model : UncertainLTVModel
    rhos : array_like, shape (n_rho,)
        ρ values (> 0).
    etas : array_like, shape (n_eta,)
        η values (>= 1).
    elements : {'all', 'A', 'B'}
        Which uncertain elements vary and enter Z; the others stay at their lower bounds.
    formulation : {'structured', 'reference'}
        ``'structured'`` (default) uses ``Z = Z₀(ρ) + η Z₁(ρ)``; ``'reference'`` runs
        :func:`design` and :func:`certify` point by point, literally as the paper does.
    measure : {'max_eig', 'margin'}
        ``'margin'`` also computes the robustness margin θ(ρ, η) of every design: the
        largest scaling of every element range about the nominal that `margin_method`
        certifies (exact, no bisection: Z is affine in θ; see
        ``scara_robust.lyapunov.theorem1.affine_margin``). Structured formulation only.
    margin_method : {'theorem1', 'vertex'}
        Theorem 1's Z, or the design's P at every vertex of the box (2^N per point).
    method : str, optional
        Deprecated name of `formulation`.

    Returns
    -------
    DesignSurface

    See Also
    --------
    design, certify : one point of the surface.
    plot_surface : draws it.

    References
    ----------
    Paper, Section 3, procedure steps 1-5; Figure 2.

    Examples
    --------
    >>> import scara_robust as sr
    >>> s = sr.design_surface(sr.paper_model(), [1, 3], [10, 90], elements="A")
    >>> s.max_eig.shape
    (2, 2)
    """
    model = as_box("model", model)
    rho_grid = _grid("rhos", rhos, 0.0, strict=True)
    eta_grid = _grid("etas", etas, 1.0, strict=False)
    check_choice("elements", elements, ELEMENT_SETS)
    formulation = renamed_argument("design_surface", "method", "formulation", method, formulation, "structured")
    check_choice("formulation", formulation, SURFACE_FORMULATIONS)
    check_choice("measure", measure, SURFACE_MEASURES)
    check_choice("margin_method", margin_method, MARGIN_MAP_METHODS)
    if measure == "margin" and formulation != "structured":
        raise ArgumentValueError("formulation", f"must be 'structured' for measure='margin', found {formulation!r}")
    if measure == "margin" and model.n_elements == 0:
        raise ArgumentValueError("model", "has no uncertain elements: there is no margin to compute")
    shape = (rho_grid.size, eta_grid.size)
    check_memory("rhos", surface_memory(shape[0] * shape[1], model.n_states),
                 f"a grid of {shape[0] * shape[1]:,} points with `etas`")
    if shape[0] * shape[1] > MAX_SURFACE_POINTS:
        need = surface_memory(shape[0] * shape[1], model.n_states) / 1e9
        raise ArgumentValueError(
            "rhos",
            f"× `etas` is a grid of {shape[0] * shape[1]:,} points (about {need:.3g} GB of memory); "
            f"at most {MAX_SURFACE_POINTS:,} points are evaluated in one call",
        )
    if formulation == "reference":
        max_eig = np.empty(shape)
        hurwitz = np.empty(shape, dtype=bool)
        for i, rho in enumerate(rho_grid):
            for k, eta in enumerate(eta_grid):
                d = design(model, rho, eta)
                max_eig[i, k] = certify(model, d, elements).max_eig
                hurwitz[i, k] = d.hurwitz
    else:
        Z0, Z1, N0, N1, P, BK1 = _structured_terms(model, elements, rho_grid)
        Z = Z0[:, None] + eta_grid[None, :, None, None] * Z1[:, None]
        max_eig = np.asarray(np.linalg.eigvalsh(Z)[..., -1], dtype=float)
        hurwitz = _hurwitz(model.A, eta_grid, N0, N1, P, BK1)
        if measure == "margin":
            base = N0[:, None] + eta_grid[None, :, None, None] * N1[:, None]
            if margin_method == "theorem1":  # Z(θ) = base + θ (Z − base)
                margin = affine_margin(base, Z - base)
            else:
                margin = _vertex_margins(model, elements, rho_grid, eta_grid, P, base)
    return DesignSurface(
        rhos=rho_grid,
        etas=eta_grid,
        max_eig=max_eig,
        hurwitz=hurwitz,
        elements=elements,
        model_name=model.name,
        margin=margin if measure == "margin" else None,
        margin_method=margin_method if measure == "margin" else None,
    )
