"""The design surface ``max λ(Z(ρ, η))`` over a (ρ, η) grid (procedure steps 1-5, Figure 2).

The structured evaluation uses the shape of the procedure. For fixed ρ the Riccati
solution P is fixed, ``K = η K₁`` with ``K₁ = ρBᵀP``, and every E_j of a ΔB element is
η times its value for K₁. Because ``(ηΨ)⁺ = ηΨ⁺`` for η > 0, Theorem 1 gives

    Z(ρ, η) = Z₀(ρ) + η Z₁(ρ),

    Z₀ = PA + AᵀP + Σ_{ΔA} (h_l Ψ_j + (h_u - h_l) Ψ_j⁺),
    Z₁ = -(PBK₁ + K₁ᵀBᵀP) + Σ_{ΔB} (h_l Ψ_j(K₁) + (h_u - h_l) Ψ_j⁺(K₁)).

Each ρ costs one Riccati solve and N small eigendecompositions; each grid point one
batched 6x6 symmetric eigenvalue problem.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from ._validation import check_array, check_choice
from .certificate import certify, positive_part
from .design import design, riccati_solution
from .uncertain import ELEMENT_SETS, UncertainLTVModel

__all__ = ["DesignSurface", "design_surface", "SURFACE_METHODS"]

Array = NDArray[np.float64]
SURFACE_METHODS = ("structured", "reference")


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
    """

    rhos: Array
    etas: Array
    max_eig: Array
    hurwitz: NDArray[np.bool_]
    elements: str
    model_name: str

    @property
    def certified(self) -> NDArray[np.bool_]:
        """Points with ``Ā`` Hurwitz and ``max λ(Z) < 0``, shape (n_rho, n_eta)."""
        return self.hurwitz & (self.max_eig < 0)

    def to_frame(self) -> pd.DataFrame:
        """Tidy table, one row per grid point: rho, eta, max_eig_Z, closed_loop_hurwitz, certified."""
        rho, eta = np.meshgrid(self.rhos, self.etas, indexing="ij")
        return pd.DataFrame(
            {
                "rho": rho.ravel(),
                "eta": eta.ravel(),
                "max_eig_Z": self.max_eig.ravel(),
                "closed_loop_hurwitz": self.hurwitz.ravel(),
                "certified": self.certified.ravel(),
            }
        )

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

    def plot(self, mark: tuple[float, float] | None = None, ax: Any = None) -> Any:
        """3D plot; see :func:`scara_robust.plotting.plot_surface`."""
        from .plotting import plot_surface

        return plot_surface(self, mark=mark, ax=ax)


def _grid(name: str, values: ArrayLike, minimum: float, strict: bool) -> Array:
    arr = check_array(name, values, ndim=1)
    if arr.size == 0:
        raise ValueError(f"`{name}` must hold at least one value, found none")
    bad = arr <= minimum if strict else arr < minimum
    if bad.any():
        op = ">" if strict else ">="
        raise ValueError(f"`{name}` must be {op} {minimum}, found {arr[bad][0]}")
    return arr


def _structured_terms(model: UncertainLTVModel, rho: float) -> tuple[Array, Array, Array, Array]:
    """``Z₀, Z₁`` for one ρ, and ``A``, ``B K₁`` for the Hurwitz test."""
    P = riccati_solution(model, rho)
    A, B = model.A, model.B
    K1 = rho * B.T @ P
    G = P @ B @ K1
    Z0 = P @ A + A.T @ P
    Z1 = -(G + G.T)
    E = model.perturbation_matrices(K1)
    for j, el in enumerate(model.elements):
        Psi = P @ E[j] + E[j].T @ P
        term = el.lower * Psi + el.width * positive_part(Psi)
        if el.matrix == "A":
            Z0 += term
        else:
            Z1 += term
    return Z0, Z1, A, B @ K1


def design_surface(
    model: UncertainLTVModel,
    rhos: ArrayLike,
    etas: ArrayLike,
    elements: str = "all",
    *,
    method: str = "structured",
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
        Which uncertain elements enter Z.
    method : {'structured', 'reference'}
        ``'structured'`` (default) uses ``Z = Z₀(ρ) + η Z₁(ρ)``; ``'reference'`` runs
        :func:`design` and :func:`certify` point by point, literally as the paper does.

    Returns
    -------
    DesignSurface

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
    if not isinstance(model, UncertainLTVModel):
        raise TypeError(f"`model` must be an UncertainLTVModel, found {type(model).__name__}")
    rho_grid = _grid("rhos", rhos, 0.0, strict=True)
    eta_grid = _grid("etas", etas, 1.0, strict=False)
    check_choice("elements", elements, ELEMENT_SETS)
    check_choice("method", method, SURFACE_METHODS)
    shape = (rho_grid.size, eta_grid.size)
    if method == "reference":
        max_eig = np.empty(shape)
        hurwitz = np.empty(shape, dtype=bool)
        for i, rho in enumerate(rho_grid):
            for k, eta in enumerate(eta_grid):
                d = design(model, rho, eta)
                max_eig[i, k] = certify(model, d, elements).max_eig
                hurwitz[i, k] = d.hurwitz
    else:
        sub = model.subset(elements)
        terms = [_structured_terms(sub, rho) for rho in rho_grid]
        Z0 = np.array([t[0] for t in terms])
        Z1 = np.array([t[1] for t in terms])
        Z = Z0[:, None] + eta_grid[None, :, None, None] * Z1[:, None]
        Z = 0.5 * (Z + np.swapaxes(Z, -1, -2))
        max_eig = np.linalg.eigvalsh(Z)[..., -1]
        A_cl = model.A[None, None] - eta_grid[None, :, None, None] * np.array([t[3] for t in terms])[:, None]
        hurwitz = np.all(np.linalg.eigvals(A_cl).real < 0, axis=-1)
    return DesignSurface(
        rhos=rho_grid,
        etas=eta_grid,
        max_eig=max_eig,
        hurwitz=hurwitz,
        elements=elements,
        model_name=model.name,
    )
