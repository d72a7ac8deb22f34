"""The gain design of the paper's procedure, steps 2-3.

``P`` solves the Riccati equation ``PA + AᵀP - 2ρ P B Bᵀ P = -2I``, i.e.
``control.care(A, B, Q=2I, R=I/(2ρ))``; then ``K = ηρ BᵀP``, ``Ā = A - BK`` and
``Q = -(PĀ + ĀᵀP)/2 = I + ρ(η - 1) P B Bᵀ P``.
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import NDArray

from .._validation import check_real
from ..model.uncertain import UncertainLTVModel

__all__ = ["Design", "design", "riccati_solution", "check_stabilizable", "CARE_RTOL"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Design:
    """A gain designed from (ρ, η).

    Attributes
    ----------
    rho, eta : float
        Design parameters (ρ > 0, η >= 1).
    K : ndarray, shape (m, n)
        State-feedback gain of ``u = -K x``.
    P : ndarray, shape (n, n)
        Riccati solution, symmetric positive definite.
    A_cl : ndarray, shape (n, n)
        Nominal closed loop ``Ā = A - B K``.
    Q : ndarray, shape (n, n)
        ``-(PĀ + ĀᵀP)/2``, symmetric positive definite.
    poles : ndarray, shape (n,)
        Eigenvalues of ``Ā`` (complex).
    hurwitz : bool
        Every eigenvalue of ``Ā`` has a negative real part.
    care_residual : float
        ``‖PA + AᵀP - 2ρPBBᵀP + 2I‖_F / (1 + ‖P‖_F)``.
    """

    rho: float
    eta: float
    K: Array
    P: Array
    A_cl: Array
    Q: Array
    poles: NDArray[np.complex128]
    hurwitz: bool
    care_residual: float

    @property
    def spectral_abscissa(self) -> float:
        """Largest real part of the closed-loop eigenvalues, 1/s."""
        return float(np.max(self.poles.real))


def check_stabilizable(A: Array, B: Array, name: str = "model") -> None:
    """Raise if ``(A, B)`` is not stabilizable (PBH test on the closed right half-plane).

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    name : str
        Argument name used in the message.


    Raises
    ------
    ValueError
        Naming `name` and the first uncontrollable unstable eigenvalue.
    """
    n = A.shape[0]
    scale = max(float(np.linalg.norm(A)), float(np.linalg.norm(B)), 1.0)
    for lam in np.linalg.eigvals(A):
        if lam.real < -1e-9 * scale:
            continue
        pbh = np.hstack([A - lam * np.eye(n), B])
        sv = np.linalg.svd(pbh, compute_uv=False)
        if sv[-1] <= 1e-10 * scale:
            raise ValueError(
                f"`{name}`: (A, B) must be stabilizable, found the eigenvalue {lam:.4g} of A uncontrollable from B"
            )


#: Largest relative residual of the Riccati equation that :func:`design` accepts.
CARE_RTOL = 1e-8


def riccati_solution(model: UncertainLTVModel, rho: float) -> Array:
    """Solve step 2's Riccati equation ``PA + AᵀP - 2ρPBBᵀP = -2I`` for P.

    Parameters
    ----------
    model : UncertainLTVModel
        Supplies A, shape (n, n), and B, shape (n, m).
    rho : float
        ρ > 0.

    Returns
    -------
    ndarray, shape (n, n)
        The stabilizing, symmetric positive definite solution.

    Raises
    ------
    ValueError
        If ρ is not a finite positive number, (A, B) is not stabilizable, the
        Riccati solver fails, or its solution's relative residual exceeds
        :data:`CARE_RTOL` (the equation is ill-conditioned at this ρ).
    """
    rho = check_real("rho", rho, positive=True)
    n, m = model.n_states, model.n_inputs
    check_stabilizable(model.A, model.B)
    try:
        P, _, _ = ct.care(model.A, model.B, 2.0 * np.eye(n), np.eye(m) / (2.0 * rho))
    except Exception as err:  # slycot and scipy raise several types
        raise ValueError(f"`rho`={rho}: the Riccati equation of step 2 has no stabilizing solution ({err})") from err
    P = 0.5 * (P + P.T)
    if not np.all(np.isfinite(P)):
        raise ValueError(f"`rho`={rho}: the Riccati solution is not finite")
    PA, PBBP = P @ model.A, 2 * rho * P @ model.B @ model.B.T @ P
    residual = np.linalg.norm(PA + PA.T - PBBP + 2 * np.eye(n))
    scale = 2 * np.linalg.norm(PA) + np.linalg.norm(PBBP) + 2 * np.sqrt(n)
    if residual > CARE_RTOL * scale:
        raise ValueError(
            f"`rho`={rho:g}: the Riccati solution is inaccurate (relative residual {residual / scale:.1e} > "
            f"{CARE_RTOL:g}); the equation is ill-conditioned at this rho"
        )
    return np.asarray(P, dtype=float)


def design(model: UncertainLTVModel, rho: float, eta: float) -> Design:
    """Design the PID gain from (ρ, η): procedure steps 2-3.

    Parameters
    ----------
    model : UncertainLTVModel
        Nominal A, shape (n, n), and B, shape (n, m).
    rho : float
        ρ > 0.
    eta : float
        η >= 1.

    Returns
    -------
    Design

    Raises
    ------
    ValueError
        For ρ <= 0, η < 1, non-finite values, or a non-stabilizable (A, B).

    References
    ----------
    Paper, Section 3, procedure steps 2-3.

    Examples
    --------
    >>> import scara_robust as sr
    >>> d = sr.design(sr.paper_model(), rho=3, eta=90)
    >>> round(float(d.K[0, 0]), 1), d.hurwitz
    (-155.5, True)
    """
    if not isinstance(model, UncertainLTVModel):
        raise TypeError(f"`model` must be an UncertainLTVModel, found {type(model).__name__}")
    rho = check_real("rho", rho, positive=True)
    eta = check_real("eta", eta, minimum=1.0)
    P = riccati_solution(model, rho)
    A, B = model.A, model.B
    K = eta * rho * B.T @ P
    A_cl = A - B @ K
    Q = -0.5 * (P @ A_cl + A_cl.T @ P)
    Q = 0.5 * (Q + Q.T)
    residual = P @ A + A.T @ P - 2 * rho * P @ B @ B.T @ P + 2 * np.eye(model.n_states)
    poles = np.linalg.eigvals(A_cl)
    return Design(
        rho=rho,
        eta=eta,
        K=K,
        P=P,
        A_cl=A_cl,
        Q=Q,
        poles=poles.astype(complex),
        hurwitz=bool(np.all(poles.real < 0)),
        care_residual=float(np.linalg.norm(residual) / (1 + np.linalg.norm(P))),
    )
