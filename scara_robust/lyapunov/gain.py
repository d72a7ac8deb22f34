"""The gain design of the paper's procedure, steps 2-3.

``P`` solves the Riccati equation ``PA + AᵀP - 2ρ P B Bᵀ P = -2I``, i.e.
``control.care(A, B, Q=2I, R=I/(2ρ))``; then ``K = ηρ BᵀP``, ``Ā = A - BK`` and
``Q = -(PĀ + ĀᵀP)/2 = I + ρ(η - 1) P B Bᵀ P``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_real
from ..controller.discrete import DiscretePID
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..model.plant import ModelLike, as_model

__all__ = ["Design", "design", "design_or_none", "riccati_solution"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Design:
    """A gain designed from (ρ, η), or a gain of your own (:meth:`from_gain`).

    Attributes
    ----------
    rho, eta : float
        Design parameters (ρ > 0, η >= 1); NaN for a gain of your own.
    K : ndarray, shape (m, n)
        State-feedback gain of ``u = -K x``.
    P : ndarray, shape (n, n)
        Riccati solution, symmetric positive definite (for a gain of your own: the P given,
        or the solution of ``PĀ + ĀᵀP = −2I``; see `P_source`).
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
    n_joints : int or None
        Joints p of a model in the paper's PID form ``x = [∫e, e, ė]`` (n = 3p), from the
        model; None for a plain state-feedback model.
    P_source : str
        Where P comes from: ``'riccati'`` (the paper's step 2), ``'given'``, ``'lyapunov'``
        or ``'lmi'`` (the common P of a synthesis).
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
    n_joints: int | None = None
    P_source: str = "riccati"

    @classmethod
    def from_gain(cls, model: ModelLike, K: ArrayLike, P: ArrayLike | None = None) -> Design:
        """A design for a gain of your own (``u = −Kx``; K = 0 for the open loop), on `model`'s nominal plant.

        Every analysis that takes a design takes it: the margins, the certificate table and
        the sampled-data limit. The methods that test one Lyapunov matrix (Theorem 1, the
        vertex test) test `P`; the others (LMI, frozen bounds, falsifier) do not use it.

        Parameters
        ----------
        model : UncertainPlant, UncertainLTVModel or PolytopicModel
            Its nominal ``(A, B)`` makes ``Ā = A − BK``.
        K : array_like, shape (m, n)
            The gain, input units per state unit.
        P : array_like, shape (n, n), optional
            A Lyapunov matrix for the tests that need one (symmetric positive definite).
            Default: the solution of ``PĀ + ĀᵀP = −2I`` (python-control's ``lyap``), which
            exists only for a Hurwitz Ā.

        Returns
        -------
        Design
            ``rho = eta = NaN``, ``care_residual = NaN``, ``P_source`` ``'given'`` or ``'lyapunov'``.

        Raises
        ------
        ArgumentValueError
            If K or P has the wrong shape, P is not symmetric positive definite, or no P is
            given and Ā is not Hurwitz.

        See Also
        --------
        design : the paper's gain from (ρ, η).

        Examples
        --------
        >>> import numpy as np, scara_robust as sr
        >>> plant = sr.UncertainLTVModel(np.array([[0, 1], [0, -0.1]]), np.array([[0], [0.1]]))  # q̈ = −0.1q̇ + 0.1u
        >>> d = sr.Design.from_gain(plant, [[3.75, 11.5]])   # u = −(3.75 q + 11.5 q̇)
        >>> d.P_source, d.hurwitz
        ('lyapunov', True)
        """
        model = as_model("model", model)
        A, B = model.A, model.B
        K = check_array("K", K, shape=(B.shape[1], A.shape[0]))
        A_cl = A - B @ K
        poles = np.linalg.eigvals(A_cl).astype(complex)
        hurwitz = bool(np.all(poles.real < 0))
        P_mat: Array
        if P is not None:
            given = check_array("P", P, shape=A.shape)
            scale = max(float(np.abs(given).max()), 1e-300)
            if not np.allclose(given, given.T, rtol=0.0, atol=1e-10 * scale) or \
                    np.linalg.eigvalsh(0.5 * (given + given.T))[0] <= 0:
                raise ArgumentValueError("P", "must be symmetric positive definite")
            P_mat, source = 0.5 * (given + given.T), "given"
        elif hurwitz:
            X = np.asarray(ct.lyap(A_cl.T, 2.0 * np.eye(A.shape[0])), dtype=float)  # A_clᵀX + X A_cl + 2I = 0
            P_mat, source = 0.5 * (X + X.T), "lyapunov"
        else:
            raise ArgumentValueError(
                "K", f"gives a closed loop that is not Hurwitz (eigenvalue {poles[np.argmax(poles.real)]:.4g}), "
                "so no Lyapunov matrix exists for it; pass P to test one anyway")
        return cls._of_gain(A, B, K, P_mat, source, getattr(model, "n_joints", None))

    @classmethod
    def _of_gain(cls, A: Array, B: Array, K: Array, P: Array, source: str, n_joints: int | None) -> Design:
        """The design of ``u = −Kx`` on the nominal ``(A, B)`` with the Lyapunov matrix P, unchecked."""
        A_cl = A - B @ K
        Q = -0.5 * (P @ A_cl + A_cl.T @ P)
        poles = np.linalg.eigvals(A_cl).astype(complex)
        return cls(rho=float("nan"), eta=float("nan"), K=K, P=P, A_cl=A_cl, Q=0.5 * (Q + Q.T), poles=poles,
                   hurwitz=bool(np.all(poles.real < 0)), care_residual=float("nan"), n_joints=n_joints,
                   P_source=source)

    @property
    def spectral_abscissa(self) -> float:
        """Largest real part of the closed-loop eigenvalues, 1/s."""
        return float(np.max(self.poles.real))

    def pid_matrices(self) -> tuple[Array, Array, Array]:
        """The gain as PID matrices: ``u = K_I ∫e + K_P e + K_D ė`` (the same law as ``u = −Kx``).

        Returns
        -------
        K_I, K_P, K_D : ndarray, each shape (m, p)
            ``K = −[K_I, K_P, K_D]``, so for the SCARA ``K_P`` is in N·m/rad, ``K_I`` in
            N·m/(rad·s) and ``K_D`` in N·m·s/rad.

        Raises
        ------
        ArgumentValueError
            If the design's model is not in the PID form (``n_joints`` is None).
        """
        if self.n_joints is None:
            raise ArgumentValueError(
                "design", "is not for a model in the PID form x = [∫e, e, ė]; build the model with sr.pid_augment"
            )
        p = self.n_joints
        return -self.K[:, :p], -self.K[:, p : 2 * p], -self.K[:, 2 * p :]

    def controller(self) -> ct.StateSpace:
        """The controller as a python-control system.

        Returns
        -------
        control.StateSpace
            PID form: inputs ``e[0..p-1], edot[0..p-1]``, states ``int_e[0..p-1]``
            (``∫e``), outputs ``u[0..m-1]`` with ``u = K_I ∫e + K_P e + K_D ė``. Otherwise
            the static gain ``u = −K x`` with inputs ``x[0..n-1]``.
        """
        m, n = self.K.shape
        outputs = [f"u[{i}]" for i in range(m)]
        if self.n_joints is None:
            return ct.ss([], [], [], -self.K, inputs=[f"x[{i}]" for i in range(n)], outputs=outputs, name="K")
        p = self.n_joints
        K_I, K_P, K_D = self.pid_matrices()
        return ct.ss(
            np.zeros((p, p)),
            np.hstack([np.eye(p), np.zeros((p, p))]),
            K_I,
            np.hstack([K_P, K_D]),
            inputs=[f"e[{i}]" for i in range(p)] + [f"edot[{i}]" for i in range(p)],
            states=[f"int_e[{i}]" for i in range(p)],
            outputs=outputs,
            name="pid",
        )

    def discretize(
        self,
        Ts: float,
        *,
        integrator: str = "tustin",
        derivative: str = "measured",
        N: float = 100.0,
        torque_limit: Any = None,
        tracking_time: Any = None,
        anti_windup: bool = True,
        error_deadband: float | None = None,
        feedforward: Any = None,
    ) -> DiscretePID:
        """The PID as a sampled controller, ready to run on a controller board.

        Parameters
        ----------
        Ts : float
            Sample time, s (> 0).
        integrator : {'tustin', 'forward', 'backward'}
            Discretization of ``∫e``.
        derivative : {'measured', 'filtered'}
            ``K_D ė`` with ė measured, or a filtered difference of e (no q̇ needed).
        N : float
            Derivative filter bandwidth, 1/s (> 0), for ``derivative='filtered'``.
        torque_limit : None, float or array_like of shape (m,)
            Per-torque limit, N·m (> 0).
        tracking_time : None, float or array_like of shape (m,)
            Back-calculation time constant, s (> 0; below Ts it overshoots, as control_toolbox
            runs it); default ``sqrt(T_i T_d)`` per torque, at least Ts.
        anti_windup : bool
            Back-calculation on (default) or off.
        error_deadband : float, optional
            rad: within it a joint's integral term is not updated (control_toolbox's rule);
            default none.
        feedforward : ArmFeedforward, optional
            An arm's model feedforward (:func:`scara_robust.arm_feedforward`), in the
            controller: the limit then acts on the total torque.

        Returns
        -------
        DiscretePID
            ``reset(...)``, ``step(e, edot) -> u``; ``to_statespace()`` gives its linear
            part as a python-control system with ``dt = Ts``.

        Raises
        ------
        ArgumentValueError
            If the design is not in the PID form, or for a bad option.

        Examples
        --------
        >>> import scara_robust as sr
        >>> pid = sr.design(sr.paper_model(), 3, 90).discretize(1e-3)
        >>> pid.to_statespace().dt
        0.001
        """
        K_I, K_P, K_D = self.pid_matrices()
        return DiscretePID(
            Ts, K_I, K_P, K_D, integrator=integrator, derivative=derivative, N=N,
            torque_limit=torque_limit, tracking_time=tracking_time, anti_windup=anti_windup,
            error_deadband=error_deadband, feedforward=feedforward,
        )

    def closed_loop(self, A: ArrayLike, B: ArrayLike) -> ct.StateSpace:
        """The loop of the frozen plant ``ẋ = Ax + Bu`` with ``u = −Kx``, built by python-control.

        Parameters
        ----------
        A : array_like, shape (n, n)
        B : array_like, shape (n, m)
            A plant of the uncertainty set (a vertex, a sample, the nominal).

        Returns
        -------
        control.StateSpace
            ``control.feedback`` of the plant (all states measured) and the gain; its
            poles are the eigenvalues of ``A − BK``.
        """
        m, n = self.K.shape
        A = check_array("A", A, shape=(n, n))
        B = check_array("B", B, shape=(n, m))
        plant = ct.ss(A, B, np.eye(n), np.zeros((n, m)))
        return ct.feedback(plant, ct.ss([], [], [], self.K))


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


#: Relative residual of the Riccati equation below which its solution is taken as it is.
CARE_RTOL = 1e-8
#: Largest relative residual accepted after Newton refinement, from a stabilizing, positive definite P.
#: The design needs no more: Theorem 1 and every certificate test the P they are given (numpy re-verifies
#: them), so the residual only says how far P is from the exact solution of step 2 (``Design.care_residual``).
CARE_ACCEPT = 1e-6
#: Newton (Kleinman) steps tried on a solution whose residual is above CARE_RTOL.
CARE_NEWTON_STEPS = 3


def riccati_solution(model: ModelLike, rho: float) -> Array:
    """Solve step 2's Riccati equation ``PA + AᵀP - 2ρPBBᵀP = -2I`` for P.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
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
        Riccati solver fails, or its solution's relative residual stays above 1e-6 after
        three Newton (Kleinman) steps, or above 1e-8 with a P that is not stabilizing and
        positive definite: the equation is ill-conditioned at this ρ.

    Examples
    --------
    >>> import numpy as np, scara_robust as sr
    >>> box = sr.UncertainLTVModel(np.array([[0.0, 1.0], [0.0, -0.15]]), np.array([[0.0], [0.05]]),
    ...                            (sr.UncertainElement("A", 1, 1, 0.0, 0.1), sr.UncertainElement("B", 1, 0, 0.0, 0.1)))
    >>> P = sr.riccati_solution(box, 1.0)
    >>> P.shape, bool(np.all(np.linalg.eigvalsh(P) > 0))
    ((2, 2), True)
    """
    rho = check_real("rho", rho, positive=True)
    model = as_model("model", model)
    n, m = model.n_states, model.n_inputs
    check_stabilizable(model.A, model.B)
    try:
        P, _, _ = ct.care(model.A, model.B, 2.0 * np.eye(n), np.eye(m) / (2.0 * rho))
    except Exception as err:  # slycot and scipy raise several types
        raise ValueError(f"`rho`={rho}: the Riccati equation of step 2 has no stabilizing solution ({err})") from err
    P = 0.5 * (P + P.T)
    if not np.all(np.isfinite(P)):
        raise ValueError(f"`rho`={rho}: the Riccati solution is not finite")
    error = _care_error(model.A, model.B, rho, P)
    for _ in range(CARE_NEWTON_STEPS if error > CARE_RTOL else 0):
        better = _newton_step(model.A, model.B, rho, P)
        better_error = _care_error(model.A, model.B, rho, better)
        if not better_error < error:
            break
        P, error = better, better_error
    if error > CARE_RTOL and not (error <= CARE_ACCEPT and _stabilizing(model.A, model.B, rho, P)):
        raise ValueError(
            f"`rho`={rho:g}: the Riccati solution is inaccurate (relative residual {error:.1e} > {CARE_ACCEPT:g} "
            f"after {CARE_NEWTON_STEPS} Newton steps, or P not stabilizing and positive definite); the equation "
            "is ill-conditioned at this rho"
        )
    return np.asarray(P, dtype=float)


def _care_error(A: Array, B: Array, rho: float, P: Array) -> float:
    """Relative residual of step 2's Riccati equation ``PA + AᵀP − 2ρPBBᵀP + 2I = 0`` at P.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    rho : float
    P : ndarray, shape (n, n)

    Returns
    -------
    float
        ``‖R‖_F / (2‖PA‖_F + ‖2ρPBBᵀP‖_F + 2√n)``, R the residual: the size of the
        residual against the size of the terms that cancel in it.
    """
    n = A.shape[0]
    PA, PBBP = P @ A, 2 * rho * P @ B @ B.T @ P
    residual = np.linalg.norm(PA + PA.T - PBBP + 2 * np.eye(n))
    return float(residual / (2 * np.linalg.norm(PA) + np.linalg.norm(PBBP) + 2 * np.sqrt(n)))


def _newton_step(A: Array, B: Array, rho: float, P: Array) -> Array:
    """One Newton (Kleinman) step on step 2's Riccati equation from P.

    With ``A_c = A − 2ρBBᵀP``, the next iterate X solves the Lyapunov equation
    ``A_cᵀX + XA_c = −(2I + 2ρPBBᵀP)`` (python-control's ``lyap``); from a stabilizing P the
    iteration converges quadratically to the stabilizing solution.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    rho : float
    P : ndarray, shape (n, n)
        Symmetric, stabilizing.

    Returns
    -------
    ndarray, shape (n, n)
        Symmetric.
    """
    n = A.shape[0]
    A_c = A - 2 * rho * B @ B.T @ P
    PB = P @ B
    Q = 2 * np.eye(n) + 2 * rho * PB @ PB.T
    Q = 0.5 * (Q + Q.T)  # lyap requires a symmetric Q to the last bit
    X = np.asarray(ct.lyap(A_c.T, Q), dtype=float)
    return np.asarray(0.5 * (X + X.T), dtype=float)


def _stabilizing(A: Array, B: Array, rho: float, P: Array) -> bool:
    """P positive definite and ``A − 2ρBBᵀP`` Hurwitz: what the design and its certificates use of P."""
    return bool(np.linalg.eigvalsh(P).min() > 0 and np.linalg.eigvals(A - 2 * rho * B @ B.T @ P).real.max() < 0)


def design(model: ModelLike, rho: float, eta: float) -> Design:
    """Design the PID gain from (ρ, η): procedure steps 2-3.

    Parameters
    ----------
    model : UncertainLTVModel or PolytopicModel
        Nominal A, shape (n, n), and B, shape (n, m) (a polytope's nominal: by default
        its vertex average).
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

    See Also
    --------
    certify : Theorem 1 for the design.
    design_surface : max λ(Z) over a (ρ, η) grid.
    synthesize : a gain from an LMI, with its certificate.

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
    model = as_model("model", model)
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
        n_joints=getattr(model, "n_joints", None),
    )


def design_or_none(value: Any) -> Design | None:
    """`value` if it is a :class:`Design`, else None (a plain gain matrix, a controller, anything else).

    Parameters
    ----------
    value : object

    Returns
    -------
    Design or None
    """
    return value if isinstance(value, Design) else None


def as_design(model: ModelLike, design: Design | ArrayLike) -> Design:
    """`design` itself, or :meth:`Design.from_gain` of `model` for a plain gain K (its P from the Lyapunov equation).

    Parameters
    ----------
    model : UncertainPlant, UncertainLTVModel or PolytopicModel
    design : Design or array_like, shape (m, n)

    Returns
    -------
    Design
    """
    found = design_or_none(design)
    if found is not None:
        return found
    if isinstance(design, (str, bytes)) or design is None:
        raise ArgumentTypeError("design", f"must be a Design or a gain matrix K, found {type(design).__name__}")
    return Design.from_gain(model, design)  # type: ignore[arg-type]
