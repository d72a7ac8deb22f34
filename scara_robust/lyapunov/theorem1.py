"""Theorem 1 (robust stability certificate) and Corollary 1 (ultimate bound).

For the closed loop ``ẋ = Ā x + Σ_j h_j(t) E_j x`` with ``h_j ∈ [h_lj, h_uj]`` and
``V = xᵀPx/2``, Theorem 1 builds ``Z`` with ``V̇ <= xᵀZx/2``:

1. P from ``-Q = (PĀ + ĀᵀP)/2`` (``control.lyap``). With the Q of procedure step 3
   this returns the Riccati P of step 2: the certificate checks that it does.
2. ``Ā₁ = Ā + Σ h_lj E_j``, ``Φ = PĀ₁ + Ā₁ᵀP``.
3. ``Ψ_j = PE_j + E_jᵀP``.
4-6. ``Ψ_j⁺``: Ψ_j with its negative eigenvalues set to zero.
7. ``Z = Φ + Σ (h_uj - h_lj) Ψ_j⁺``; ``max λ(Z) < 0`` certifies.
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from .._validation import check_choice, check_instance, check_real
from ..exceptions import ArgumentValueError
from ..model.plant import ModelLike, as_box
from ..model.uncertain import ANCHORS, ELEMENT_SETS
from ..results import AnalysisResult, VerdictFromCertified
from .gain import Design

__all__ = ["Certificate", "UltimateBound", "certify"]

Array = NDArray[np.float64]


def positive_part(S: Array) -> Array:
    """Theorem 1 steps 4-6: ``T diag(max(λ, 0)) Tᵀ`` for symmetric ``S`` of shape (..., n, n).

    Parameters
    ----------
    S : ndarray, shape (..., n, n)
        Symmetric matrices.

    Returns
    -------
    ndarray, shape (..., n, n)
        Their positive parts (symmetric positive semidefinite, ``S⁺ ⪰ S``).
    """
    w, T = np.linalg.eigh(S)
    return np.asarray(np.einsum("...ik,...k,...jk->...ij", T, np.maximum(w, 0.0), T), dtype=float)


def rank2_positive_part(u: Array, v: Array) -> Array:
    """Positive part of ``S = u vᵀ + v uᵀ`` in closed form, for stacks of vectors.

    With ``û = u/‖u‖`` and ``v̂ = v/‖v‖``, S has the eigenpairs
    ``‖u‖‖v‖(1 ± ûᵀv̂)``, ``û ± v̂`` (and zeros), so

        S⁺ = (‖u‖‖v‖ / 2) (û + v̂)(û + v̂)ᵀ.

    Every Ψ_j of Theorem 1 has this form (``E_j = a bᵀ`` gives ``u = P a``, ``v = b``),
    which spares an eigendecomposition per element.

    Parameters
    ----------
    u, v : ndarray, shape (..., n)

    Returns
    -------
    ndarray, shape (..., n, n)
    """
    nu = np.linalg.norm(u, axis=-1, keepdims=True)
    nv = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(nu > 0, u / nu, 0.0) + np.where(nv > 0, v / nv, 0.0)
    scale = 0.5 * (nu * nv)[..., 0]
    return np.asarray(scale[..., None, None] * w[..., :, None] * w[..., None, :], dtype=float)


def theorem1_z(P: Array, A_cl: Array, E: Array, lower: Array, upper: Array) -> tuple[Array, Array, Array, Array]:
    """Theorem 1 steps 2-7 for a given P.

    Parameters
    ----------
    P, A_cl : ndarray, shape (n, n)
    E : ndarray, shape (N, n, n)
    lower, upper : ndarray, shape (N,)

    Returns
    -------
    Z, Phi : ndarray, shape (n, n)
    Psi, Psi_plus : ndarray, shape (N, n, n)
    """
    A1 = A_cl + np.einsum("j,jik->ik", lower, E)
    Phi = P @ A1 + A1.T @ P
    Psi = P @ E + np.swapaxes(E, -1, -2) @ P
    Psi_plus = positive_part(Psi)
    Z = Phi + np.einsum("j,jik->ik", upper - lower, Psi_plus)
    return 0.5 * (Z + Z.T), Phi, Psi, Psi_plus


def affine_margin(base: ArrayLike, direction: ArrayLike) -> Array:
    """``sup{θ >= 0 : base + θ·direction ≺ 0}`` for stacks of symmetric matrices, exactly.

    With ``N = −base ≻ 0``, ``base + θS ≺ 0`` holds exactly while ``θ λmax(N^{-1/2} S N^{-1/2}) < 1``,
    so the supremum is ``1/λmax`` (infinite when ``λmax <= 0``), and the set of such θ is an
    interval ``[0, θ*)``: λmax of an affine matrix function is convex in θ and negative at 0.

    Parameters
    ----------
    base : array_like, shape (..., n, n)
        Symmetric; where it is not negative definite the margin is 0.
    direction : array_like, shape (..., n, n)
        Symmetric.

    Returns
    -------
    ndarray, shape (...)
        θ* (may be ``inf``).
    """
    N = -0.5 * (np.asarray(base, dtype=float) + np.swapaxes(np.asarray(base, dtype=float), -1, -2))
    S = 0.5 * (np.asarray(direction, dtype=float) + np.swapaxes(np.asarray(direction, dtype=float), -1, -2))
    w, V = np.linalg.eigh(N)
    definite = w[..., 0] > 1e-12 * np.maximum(np.abs(w[..., -1]), 1e-300)
    inv_sqrt = np.einsum("...ik,...k,...jk->...ij", V, 1.0 / np.sqrt(np.where(definite[..., None], w, 1.0)), V)
    top = np.linalg.eigvalsh(inv_sqrt @ S @ inv_sqrt)[..., -1]
    with np.errstate(divide="ignore"):
        theta = np.where(top > 0, 1.0 / np.where(top > 0, top, 1.0), np.inf)
    return np.asarray(np.where(definite, theta, 0.0), dtype=float)


def theorem1_scaling(
    model: ModelLike, design: Design, elements: str = "all", anchor: str = "lower"
) -> tuple[Array, Array]:
    """Z of Theorem 1 for the box scaled by θ, as ``Z(θ) = base + θ·direction``.

    With ``anchor='lower'`` every element range scales about the nominal (``[θ l_j, θ u_j]``,
    the elements left out of `elements` held at ``θ l_j``), so ``Ā₁(θ) = Ā + θ Σ l_j E_j`` and
    ``Z(θ) = PĀ + ĀᵀP + θ (Σ_all l_j Ψ_j + Σ_varying (u_j − l_j) Ψ_j⁺)``, with P the design's
    (Theorem 1's step 1 returns it). With ``anchor='center'`` (every element varying) the
    range is ``[c_j − θw_j/2, c_j + θw_j/2]`` (centre c, width w), so
    ``Z(θ) = PĀ + ĀᵀP + Σ c_j Ψ_j + θ Σ w_j (Ψ_j⁺ − Ψ_j/2)``.

    Parameters
    ----------
    model : UncertainLTVModel
    design : Design
    elements : {'all', 'A', 'B'}
    anchor : {'lower', 'center'}
        ``'center'`` needs ``elements='all'``.

    Returns
    -------
    base, direction : ndarray, shape (n, n)
    """
    model = as_box("model", model)
    check_choice("elements", elements, ELEMENT_SETS)
    check_choice("anchor", anchor, ANCHORS)
    if anchor == "center" and elements != "all":
        raise ArgumentValueError("elements", f"must be 'all' with anchor 'center', found {elements!r}")
    P = design.P
    A_cl = model.A - model.B @ design.K  # the set's own nominal loop (the design's, for its own model)
    base = P @ A_cl + A_cl.T @ P
    E = model.perturbation_matrices(design.K)
    Psi = P @ E + np.swapaxes(E, -1, -2) @ P
    varying = np.array([elements in ("all", el.matrix) for el in model.elements], dtype=bool)
    widths = (model.upper_bounds() - model.lower_bounds()) * varying
    if anchor == "center":
        centre = 0.5 * (model.upper_bounds() + model.lower_bounds())
        base = base + np.einsum("j,jik->ik", centre, Psi)
        direction = np.einsum("j,jik->ik", widths, positive_part(Psi) - 0.5 * Psi) if len(widths) else 0 * base
        return 0.5 * (base + base.T), 0.5 * (direction + direction.T)
    direction = np.einsum("j,jik->ik", model.lower_bounds(), Psi)
    if varying.any():
        direction = direction + np.einsum("j,jik->ik", widths[varying], positive_part(Psi[varying]))
    return 0.5 * (base + base.T), 0.5 * (direction + direction.T)


@dataclass(frozen=True)
class UltimateBound:
    """Corollary 1's bounds for ``‖w(t)‖ < phi``.

    Attributes
    ----------
    phi : float
        Bound on the perturbation ``‖w‖`` (units of ẋ).
    decrease_radius : float
        ``V̇ < 0`` whenever ``‖x‖ > 2 λmax(P) φ / |max λ(Z)|``.
    ultimate_radius : float
        Every trajectory ends inside ``‖x‖ <= decrease_radius·sqrt(λmax(P)/λmin(P))``
        (the smallest level set of V holding the decrease ball). ``inf`` if uncertified.
    """

    phi: float
    decrease_radius: float
    ultimate_radius: float


@dataclass(frozen=True)
class Certificate(VerdictFromCertified, AnalysisResult):
    """Theorem 1 evaluated for one design.

    Attributes
    ----------
    Z : ndarray, shape (n, n)
    max_eig : float
        ``max λ(Z)``; negative certifies.
    certified : bool
        ``Ā`` Hurwitz and ``max_eig < 0``.
    hurwitz : bool
    elements : str
        Which elements entered Z: ``'all'``, ``'A'`` or ``'B'``.
    labels : tuple of str, length N
    widths : ndarray, shape (N,)
        ``h_uj - h_lj``.
    Phi : ndarray, shape (n, n)
    Psi, Psi_plus : ndarray, shape (N, n, n)
    P : ndarray, shape (n, n)
        The Lyapunov solution of step 1.
    lyapunov_residual : float
        ``‖PĀ + ĀᵀP + 2Q‖_F / (1 + ‖P‖_F)``.
    riccati_mismatch : float
        ``‖P_lyap - P_riccati‖_F / ‖P_riccati‖_F`` (theory: 0).
    """

    Z: Array
    max_eig: float
    certified: bool
    hurwitz: bool
    elements: str
    labels: tuple[str, ...]
    widths: Array
    Phi: Array
    Psi: Array
    Psi_plus: Array
    P: Array
    lyapunov_residual: float
    riccati_mismatch: float

    @property
    def message(self) -> str:
        """One sentence saying what the result means."""
        return (f"Theorem 1 over the {self.elements!r} elements: max eig Z = {self.max_eig:.6g}"
                + ("" if self.hurwitz else "; the design loop is not Hurwitz"))

    def contributions(self) -> pd.DataFrame:
        """Each element's share of Z.

        Columns: ``element``, ``width``, ``lambda_max_psi_plus`` (largest eigenvalue of
        Ψ_j⁺), ``weight`` (width × that eigenvalue: by Weyl's inequality, an upper bound on
        how much the element raises max λ(Z)) and ``max_eig_without`` (max λ(Z) with the
        element left out).
        """
        lam = np.linalg.eigvalsh(self.Psi_plus)[:, -1] if len(self.labels) else np.zeros(0)
        without = []
        for j in range(len(self.labels)):
            Zj = self.Z - self.widths[j] * self.Psi_plus[j]
            without.append(float(np.linalg.eigvalsh(0.5 * (Zj + Zj.T))[-1]))
        return pd.DataFrame(
            {
                "element": list(self.labels),
                "width": self.widths,
                "lambda_max_psi_plus": lam,
                "weight": self.widths * lam,
                "max_eig_without": without,
            }
        )

    def ultimate_bound(self, phi: float) -> UltimateBound:
        """Corollary 1: where trajectories end up when ``‖w(t)‖ < phi``.

        Parameters
        ----------
        phi : float
            Bound on ``‖w‖`` (>= 0).

        Returns
        -------
        UltimateBound
            Radii are ``inf`` when the design is not certified.
        """
        phi = check_real("phi", phi, nonnegative=True)
        if not self.certified:
            return UltimateBound(phi, float("inf"), float("inf"))
        eig_p = np.linalg.eigvalsh(self.P)
        radius = 2.0 * eig_p[-1] * phi / (-self.max_eig)
        return UltimateBound(phi, float(radius), float(radius * np.sqrt(eig_p[-1] / eig_p[0])))


def certify(model: ModelLike, design: Design, elements: str = "all") -> Certificate:
    """Theorem 1 for a design: Z, its largest eigenvalue and the verdict.

    Parameters
    ----------
    model : UncertainLTVModel
        The interval model (bounds and E_j positions).
    design : Design
        From :func:`scara_robust.design`; supplies K, Ā and Q.
    elements : {'all', 'A', 'B'}
        Which uncertain elements vary and enter Z; the others stay at their lower bounds
        (see :meth:`UncertainLTVModel.subset`).

    Returns
    -------
    Certificate

    See Also
    --------
    design : the gain and the P that Theorem 1 tests.
    certificate_table : every certificate of the design side by side.
    robustness_margin : the largest scaling of the box that stays certified.

    References
    ----------
    Paper, Section 3, Theorem 1 (steps 1-7).

    Examples
    --------
    >>> import scara_robust as sr
    >>> model = sr.paper_model()
    >>> cert = sr.certify(model, sr.design(model, 3, 90), elements="A")
    >>> cert.certified
    True
    """
    model = as_box("model", model, "Theorem 1 needs interval elements: use vertex_certificate, lmi_certificate, "
                                   "falsify or certificate_table, or certify(model.box_hull(), design) for the box "
                                   "around the polytope")
    check_instance("design", design, Design, "a Design")
    check_choice("elements", elements, ELEMENT_SETS)
    if design.K.shape != (model.n_inputs, model.n_states):
        raise ValueError(
            f"`design` has K of shape {design.K.shape}, expected {(model.n_inputs, model.n_states)} for `model`"
        )
    sub = model.subset(elements)
    A_cl, Q = design.A_cl, design.Q
    try:
        P = np.asarray(ct.lyap(A_cl.T, 2.0 * Q), dtype=float)
    except Exception as err:  # slycot raises RuntimeError subclasses with bare INFO codes
        raise ValueError(
            f"Theorem 1 step 1: the Lyapunov equation for K(rho={design.rho:g}, eta={design.eta:g}) cannot be solved "
            f"({err}); |K| = {np.abs(design.K).max():.3g} is beyond what double precision resolves"
        ) from err
    P = 0.5 * (P + P.T)
    lyap_res = np.linalg.norm(P @ A_cl + A_cl.T @ P + 2 * Q) / (1 + np.linalg.norm(P))
    mismatch = np.linalg.norm(P - design.P) / np.linalg.norm(design.P)
    E = sub.perturbation_matrices(design.K)
    lower, upper = sub.lower_bounds(), sub.upper_bounds()
    # elements left out of `elements` sit at their lower bounds, folded into sub's nominal
    Z, Phi, Psi, Psi_plus = theorem1_z(P, sub.A - sub.B @ design.K, E, lower, upper)
    max_eig = float(np.linalg.eigvalsh(Z)[-1])
    return Certificate(
        Z=Z,
        max_eig=max_eig,
        certified=bool(design.hurwitz and max_eig < 0),
        hurwitz=design.hurwitz,
        elements=elements,
        labels=tuple(el.label for el in sub.elements),
        widths=upper - lower,
        Phi=Phi,
        Psi=Psi,
        Psi_plus=Psi_plus,
        P=P,
        lyapunov_residual=float(lyap_res),
        riccati_mismatch=float(mismatch),
    )
