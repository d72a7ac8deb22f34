"""Sampled-data certificate of the discrete PID: exact zero-order hold, common discrete P.

The plant part of the paper's error model (Eq. 4) is ``ẋ_p = F x_p + G u`` with
``x_p = [e, ė]`` (the rows and columns of ``x = [∫e, e, ė]`` after the first p; the
integral is the controller's own). Held over one period Ts by a zero-order hold, it is
exactly ``x_p,k+1 = Φ x_p,k + Γ u_k`` with ``[[Φ, Γ], [0, I]] = expm([[F, G], [0, 0]] Ts)``.
With the linear part of the :class:`~scara_robust.DiscretePID` (``z_{k+1} = A_c z_k +
B_c y_k``, ``u_k = C_c z_k + D_c y_k``, ``y = x_p``, no active limit) the loop is::

    [x_p; z]_{k+1} = [[Φ + Γ D_c, Γ C_c], [B_c, A_c]] [x_p; z]_k = A_d [x_p; z]_k

for every plant ``(A_i, B_i)`` of the set (a box's vertices, a polytope's vertices, or the
robot's own sampled (A, B)). Two tests at each Ts:

- **frozen**: each A_d,i Schur stable (spectral radius < 1). One unstable frozen plant
  proves the sampled loop can be unstable at this Ts.
- **common P** (LMI, cvxpy + Clarabel, extra ``lmi``): ``A_d,iᵀ P A_d,i − P ≺ 0`` at every
  i, so ``V = xᵀPx`` decreases at every sample whichever plant acts during each period.
  Solved in the form ``M_iᵀP + PM_i + Ts M_iᵀPM_i ⪯ −I`` with ``M_i = (A_d,i − I)/Ts``
  (the same inequality divided by Ts, well scaled for small Ts), and re-verified with
  numpy on the same plants and on an independent set when given; an answer numpy cannot
  verify is not a certificate.

The map (A, B) ↦ (Φ, Γ) is not affine, so the discretized vertices of a box do not bound
the discretized box: the certificate covers the plants it is given (and any switching
among them at the samples); give a dense sampling, and a second one to verify on.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_real
from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller, controller_kind
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentTypeError, ArgumentValueError
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import as_box, as_model, is_model
from ..model.polytopic import PolytopicModel
from ..model.scara import PhysicalSamples
from ..model.uncertain import UncertainLTVModel
from ..results import AnalysisResult, VerdictFromCertified
from ..sdp.backends import resolve_lmi_solver
from .lmi import (
    LMI_STOPS,
    NOT_INSTALLED,
    _solve_common_p_ipm,
    cvxpy_available,
    decay_floor,
    lmi_certificate,
    lmi_verdict,
)
from .search import bisect

__all__ = [
    "MAX_SAMPLE_TIME_CAP",
    "sampled_closed_loops",
    "discrete_lyapunov_check",
    "sampled_certificate",
    "SampledCertificate",
    "max_sample_time",
    "SampleTimeLimit",
    "check_sample_time",
    "SampleTimeCheck",
]

Array = NDArray[np.float64]
SampledSet = UncertainLTVModel | PolytopicModel | PhysicalSamples

#: Relative margin below zero that numpy must see for a certificate (scaled by the data).
VERIFY_RTOL = 1e-9


def _plants(model: SampledSet | tuple[ArrayLike, ArrayLike]) -> tuple[Array, Array]:
    if is_model(model):
        return as_model("model", model).vertex_matrices()
    if not isinstance(model, tuple) and hasattr(model, "A") and hasattr(model, "B"):  # frozen plants on a grid
        return np.asarray(model.A, dtype=float), np.asarray(model.B, dtype=float)
    if isinstance(model, tuple):
        A = check_array("model[0]", model[0], ndim=3)
        B = check_array("model[1]", model[1], ndim=3)
        if A.shape[0] != B.shape[0] or A.shape[1] != A.shape[2] or B.shape[1] != A.shape[1]:
            raise ArgumentValueError(
                "model", f"must be (A, B) of shapes (V, n, n), (V, n, m), found {A.shape}, {B.shape}"
            )
        return A, B
    raise ArgumentTypeError("model", f"must be an UncertainPlant, an UncertainLTVModel, a PolytopicModel, "
                                     f"PhysicalSamples or a tuple (A, B), found {type(model).__name__}")


def sampled_closed_loops(A: ArrayLike, B: ArrayLike, pid: DiscretePID | SampledStateFeedback) -> Array:
    """The sampled loops ``A_d,i`` of a discrete controller with each plant held by a zero-order hold.

    Parameters
    ----------
    A : array_like, shape (V, 3p, 3p) or (V, n, n)
    B : array_like, shape (V, 3p, m) or (V, n, m)
        For a PID: plants in the PID form ``x = [∫e, e, ė]`` (continuous time; the ∫e
        columns of the e and ė rows must be zero, as in Eq. 4). For static state feedback:
        plants of any form, whose whole state is fed back.
    pid : DiscretePID or SampledStateFeedback

    Returns
    -------
    ndarray, shape (V, 2p + n_z, 2p + n_z) or (V, n, n)
        State ``[e, ė, z]`` for a PID; the plant's state ``x`` for static feedback
        (``A_d,i = Φ_i − Γ_i K``).

    Raises
    ------
    ArgumentValueError
        If the plants are not in the PID form of `pid`.
    """
    A = check_array("A", A, ndim=3)
    B = check_array("B", B, ndim=3)
    return pid.closed_loops(A, B)


def _structurally_marginal(Ad: Array) -> NDArray[np.bool_]:
    """States whose row of every ``A_d,i`` is a row of the identity: ``z_{k+1} = z_k``, fed by nothing.

    Such a state (the accumulator of a PID with ``K_I = 0``, a pure integrator with no input)
    keeps its value: its eigenvalue is exactly 1 whatever the rest of the loop does. With
    the states ordered [others, these], ``A_d`` is block upper triangular with an identity
    block, so the other eigenvalues are those of the loop without them.
    """
    n = Ad.shape[1]
    return np.array([bool(np.all(Ad[:, i, :] == np.eye(n)[i])) for i in range(n)], dtype=bool)


def _restrict(Ad: Array, keep: NDArray[np.bool_]) -> Array:
    """The loops on the states `keep` only."""
    return np.ascontiguousarray(Ad[:, keep][:, :, keep])


def _without_marginal(Ad: Array) -> tuple[Array, NDArray[np.bool_]]:
    """The loops without their structurally marginal states, and the states kept."""
    keep = ~_structurally_marginal(Ad)
    return _restrict(Ad, keep), keep


def discrete_lyapunov_check(closed_loops: ArrayLike, P: ArrayLike, Ts: float) -> tuple[float, float]:
    """numpy's check of ``A_iᵀPA_i − P ≺ 0`` at every i.

    Parameters
    ----------
    closed_loops : array_like, shape (V, n, n)
    P : array_like, shape (n, n)
    Ts : float
        Sample time, s: the check is done on ``(A_iᵀPA_i − P)/Ts`` computed as
        ``M_iᵀP + PM_i + Ts M_iᵀPM_i``, ``M_i = (A_i − I)/Ts`` (no cancellation).

    Returns
    -------
    max_eig : float
        ``max_i λmax((A_iᵀPA_i − P)/Ts)``.
    rate : float
        ``−max_eig / (2 λmax(P))`` (1/s): the state's decay rate α, the package's one
        convention; V decreases per sample at least by the factor ``1 − 2αTs``; ``-inf``
        if P is not symmetric positive definite or the margin
        is within rounding of zero.
    """
    Ad = check_array("closed_loops", closed_loops, ndim=3)
    n = Ad.shape[1]
    P = check_array("P", P, shape=(n, n))
    scale_p = max(float(np.abs(P).max()), 1e-300)
    if not np.allclose(P, P.T, rtol=0.0, atol=1e-9 * scale_p):
        return np.nan, -np.inf
    P = 0.5 * (P + P.T)
    M = (Ad - np.eye(n)) / Ts
    PM = P @ M
    S = PM + np.swapaxes(PM, -1, -2) + Ts * np.swapaxes(M, -1, -2) @ PM
    max_eig = float(np.linalg.eigvalsh(0.5 * (S + np.swapaxes(S, -1, -2)))[:, -1].max())
    eig_P = np.linalg.eigvalsh(P)
    size = float(np.abs(PM).max()) * (1.0 + Ts * float(np.abs(M).max()))
    if eig_P[0] <= 0 or max_eig >= -VERIFY_RTOL * size:
        return max_eig, -np.inf
    return max_eig, -max_eig / (2 * float(eig_P[-1]))


@dataclass(frozen=True)
class SampledCertificate(AnalysisResult):
    """The sampled-data tests at one sample time.

    Attributes
    ----------
    Ts : float
        Sample time, s.
    spectral_radius : float
        ``max_i ρ(A_d,i)`` of the frozen sampled loops (< 1: all Schur stable).
    status : str
        The LMI solver's status, ``'not installed'``, or ``'skipped'`` (a frozen loop is
        unstable, so no P can exist).
    P : ndarray, shape (n, n), or None
    rate : float
        Verified decay rate α of the state, 1/s (``V_{k+1} <= (1 − 2αTs) V_k``; see
        :func:`discrete_lyapunov_check`), the
        smallest over the plants and the check set; positive means certified.
    n_plants : int
    floor : float
        The smallest decay rate reported as certified, 1/s: ``scara_robust.robustness.lmi.DECAY_FLOOR_RTOL``
        times the largest ``‖(A_d,i − I)/Ts‖₂``.
    n_marginal : int
        Structurally marginal states left out of the test: states that keep their value
        and are fed by nothing (the accumulator of a PID with ``K_I = 0``). Their eigenvalue
        is exactly 1; the radius, P and rate are those of the loop without them.
    """

    Ts: float
    spectral_radius: float
    status: str
    P: Array | None
    rate: float
    n_plants: int
    floor: float = 0.0
    n_marginal: int = 0

    @property
    def frozen_stable(self) -> bool:
        """Every frozen sampled loop is Schur stable."""
        return bool(self.spectral_radius < 1.0)

    @property
    def certified(self) -> bool:
        """True only when numpy verified the common P, with a decay rate above the floor."""
        return bool(self.rate > 0 and self.rate >= self.floor)

    @property
    def verdict(self) -> str:
        """What the test proves: ``'certified'``, ``'infeasible'`` (a frozen loop is unstable,
        or the solver proved the LMI infeasible), ``'inaccurate'`` or ``'unknown'``."""
        if not self.frozen_stable:
            return "infeasible"
        if not self.certified and self.rate > 0:
            return "marginal"
        return lmi_verdict(self.status, self.certified)

    @property
    def message(self) -> str:
        """One sentence."""
        marginal = (f"; {self.n_marginal} state(s) fed by nothing (eigenvalue exactly 1, e.g. K_I = 0) "
                    "left out" if self.n_marginal else "")
        if self.certified:
            return (
                f"Ts = {self.Ts:.4g} s certified: common P verified on {self.n_plants} plants, "
                f"decay rate α >= {self.rate:.4g} 1/s (V_k+1 <= (1 - 2α Ts) V_k)" + marginal
            )
        if not self.frozen_stable:
            return (
                f"Ts = {self.Ts:.4g} s: a frozen sampled loop is unstable "
                f"(spectral radius {self.spectral_radius:.6g})"
            )
        if self.status == NOT_INSTALLED:
            return "cvxpy is not installed (pip install '.[lmi]'); frozen loops are Schur stable"
        if self.verdict == "marginal":
            return (f"Ts = {self.Ts:.4g} s not certified: marginal, the verified decay rate {self.rate:.3g} 1/s is "
                    f"below the floor {self.floor:.3g} 1/s")
        return f"Ts = {self.Ts:.4g} s not certified: no verified common P ({self.status})"


def _solve_lmi(Ad: Array, Ts: float, solver: str,
               accept: Callable[[Array], bool] | None = None) -> tuple[str, Array | None]:
    """The sampled-data common-P LMI on the loops `Ad`: (status, P or None).

    With the package's solver and `accept`, the first P it accepts is returned.
    """
    n = Ad.shape[1]
    M = (Ad - np.eye(n)) / Ts
    s = float(np.abs(M).max()) or 1.0
    Ms = M / s  # M_iᵀP + PM_i + Ts M_iᵀPM_i ⪯ −I/s ⇔ Ms_iᵀP + PMs_i + (Ts s) Ms_iᵀPMs_i ⪯ −I/s²
    if solver == "IPM":
        return _solve_common_p_ipm(Ms, accept, quadratic=Ts * s)
    import cvxpy as cp

    P = cp.Variable((n, n), symmetric=True)
    lam = cp.Variable()
    eye = np.eye(n)
    cons = [P >> eye, P << lam * eye]
    for Mi in Ms:
        lhs = Mi.T @ P + P @ Mi + (Ts * s) * (Mi.T @ P @ Mi)
        cons.append(0.5 * (lhs + lhs.T) << -eye)
    problem = cp.Problem(cp.Minimize(lam), cons)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=solver)  # type: ignore[no-untyped-call]
    except cp.SolverError as err:
        return f"solver error: {err}", None
    status = str(problem.status)
    if P.value is None or status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
        return status, None
    return status, np.array(P.value, dtype=float)


def sampled_certificate(
    model: SampledSet | tuple[ArrayLike, ArrayLike],
    pid: DiscretePID | SampledStateFeedback,
    *,
    check: SampledSet | tuple[ArrayLike, ArrayLike] | None = None,
    solver: str | None = None,
    candidate: ArrayLike | Callable[[], ArrayLike | None] | None = None,
    stop: str = "optimum",
) -> SampledCertificate:
    """The frozen and common-P sampled-data tests of `pid` on the plants of `model`.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel, PhysicalSamples or tuple (A, B)
        The plants, in the PID form for a PID (a box gives its 2^N vertices).
    pid : DiscretePID or SampledStateFeedback
        Its sample time is the Ts tested. States that keep their value and are fed by
        nothing (the accumulator of a PID with ``K_I = 0``) are left out and counted
        (:attr:`SampledCertificate.n_marginal`).
    check : same types as `model`, optional
        A second set of plants on which the P found must also verify (e.g. a finer
        sampling of the robot).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI's solver: the package's own (``scara_robust.sdp``, :func:`~scara_robust.solve_lmi`) or cvxpy's;
        None: :func:`~scara_robust.default_lmi_solver`.
    candidate : array_like, shape (3p, 3p) or (n, n), or callable, optional
        A common Lyapunov matrix of the continuous-time loops in the PID form
        ``[∫e, e, ė]`` (:func:`scara_robust.lmi_certificate` of ``A − BK``; for static
        feedback, in the plant's own state, used as it is). Where the
        discrete LMI finds no P whose verified decay clears the floor, this P, carried to
        the sampled loop's state ``[e, ė, w]`` (``w = K_I ∫e``, the measured-derivative
        PID's accumulator), is tried: for a small Ts the sampled loop is close to the
        continuous one and the continuous P often proves it where the LMI's numerics do
        not. Either way only what numpy verifies at this Ts counts. A function of no
        argument returning such a P (or None) is called only then, so a search computes it
        only if some Ts needs it.
    stop : {'optimum', 'verified'}
        ``'optimum'``: the LMI's optimal P (the largest decay rate of this form);
        ``'verified'``: with the package's solver, the first P numpy verifies above the floor
        (a bisection needs only the verdict; the rate may be smaller).

    Returns
    -------
    SampledCertificate

    See Also
    --------
    max_sample_time : bisects it over the sample time.

    Examples
    --------
    >>> import control as ct, scara_robust as sr
    >>> inertia = ct.ss([[0, 1], [0, 0]], [[0], [1.0]], [[1, 0]], 0)   # q̈ = b u, b in [1, 2]
    >>> plant = sr.pid_augment(inertia, [("B", 1, 0, 0.0, 1.0)])
    >>> pid = sr.design(plant, 1, 2).discretize(0.01)
    >>> sr.sampled_certificate(plant, pid).certified
    True
    """
    solver = resolve_lmi_solver(solver)
    check_controller("pid", pid, ("pid", "state feedback"),
                     "a DiscretePID (Design.discretize) or a SampledStateFeedback")
    check_choice("stop", stop, LMI_STOPS[:2])
    A, B = _plants(model)
    Ad, keep = _without_marginal(sampled_closed_loops(A, B, pid))
    n_marginal = int((~keep).sum())
    radius = float(np.abs(np.linalg.eigvals(Ad)).max())
    if radius >= 1.0:
        return SampledCertificate(pid.Ts, radius, "skipped", None, -np.inf, Ad.shape[0], n_marginal=n_marginal)
    if not cvxpy_available():
        return SampledCertificate(pid.Ts, radius, NOT_INSTALLED, None, np.nan, Ad.shape[0], n_marginal=n_marginal)
    extra = None
    if check is not None:
        Ac, Bc = _plants(check)
        extra = _restrict(sampled_closed_loops(Ac, Bc, pid), keep)
        radius = max(radius, float(np.abs(np.linalg.eigvals(extra)).max()))
    floor = decay_floor((Ad - np.eye(Ad.shape[1])) / pid.Ts)

    def verified(P: Array) -> float:
        rate = discrete_lyapunov_check(Ad, P, pid.Ts)[1]
        return rate if extra is None else min(rate, discrete_lyapunov_check(extra, P, pid.Ts)[1])

    status, P = _solve_lmi(Ad, pid.Ts, solver, (lambda P: verified(P) >= floor > 0) if stop == "verified" else None)
    rate = verified(P) if P is not None else -np.inf
    given = None
    if candidate is not None and not (rate > 0 and rate >= floor):  # asked for only where the LMI's P falls short
        given = candidate() if callable(candidate) else candidate
    mapped = None if given is None else pid.sampled_coordinates(given, Ad.shape[1])
    if mapped is not None:
        mapped_rate = verified(mapped)
        if mapped_rate > rate:
            status, P, rate = "continuous-time P, verified at this Ts", mapped, mapped_rate
    if P is None:
        return SampledCertificate(pid.Ts, radius, status, None, -np.inf, Ad.shape[0], n_marginal=n_marginal)
    return SampledCertificate(pid.Ts, radius, status, P, float(rate), Ad.shape[0], floor, n_marginal)


@dataclass(frozen=True)
class SampleTimeLimit(VerdictFromCertified, AnalysisResult):
    """Largest certified sample time and smallest sample time with an unstable frozen plant.

    Attributes
    ----------
    certified_ts : float
        Largest Ts (s) found certified by the common-P test (NaN if none, or cvxpy is
        missing); certified: its certificate is :attr:`certificate`.
    certified_bracket : tuple of float
        ``(certified, first failing)`` Ts of the bisection, s.
    unstable_ts : float
        Smallest Ts (s) found at which a frozen sampled loop is unstable (upper end of
        the bracket; inf if none up to `ts_max`).
    unstable_bracket : tuple of float
        ``(last stable, first unstable)`` Ts, s.
    certificate : SampledCertificate or None
        At `certified_ts`.
    n_plants : int
    message : str
    """

    certified_ts: float
    certified_bracket: tuple[float, float]
    unstable_ts: float
    unstable_bracket: tuple[float, float]
    certificate: SampledCertificate | None
    n_plants: int
    message: str

    @property
    def certified(self) -> bool | None:
        """True when some sample time is certified, else None."""
        return None if math.isnan(self.certified_ts) else True


#: The default cap of :func:`max_sample_time`'s search for a frozen instability, s.
MAX_SAMPLE_TIME_CAP = 100.0
#: The default start of :func:`max_sample_time`'s search, s.
TS_MIN = 1e-5


def max_sample_time(
    model: SampledSet | tuple[ArrayLike, ArrayLike],
    design: Design | DiscretePID | SampledStateFeedback | ArrayLike,
    *,
    check: SampledSet | tuple[ArrayLike, ArrayLike] | None = None,
    ts_min: float = TS_MIN,
    ts_max: float = MAX_SAMPLE_TIME_CAP,
    rtol: float = 1e-3,
    solver: str | None = None,
    **discretize: object,
) -> SampleTimeLimit:
    """Bisect the largest certified Ts and the smallest Ts at which a frozen plant is unstable.

    The frozen bound: Ts grows geometrically from `ts_min` (factor 1.25) until a frozen
    sampled loop is unstable or Ts reaches the cap `ts_max`, then the step is bisected
    (geometric mean) to `rtol`; it is the first instability the scan meets, and the
    message says whether one was bracketed or the cap was reached. States that keep
    their value and are fed by nothing (the accumulator of a PID with ``K_I = 0``) have
    an eigenvalue of exactly 1 at every Ts; they are left out of the test and named.
    The certified bound: bisection of the common-P test between `ts_min` and the frozen
    bound (a certificate at Ts does not imply one at every smaller Ts in theory; the
    reported Ts carries its own verified certificate).

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel, PhysicalSamples or tuple (A, B)
        Plants in the PID form of `design`, or of any form for static state feedback.
    design : Design, DiscretePID, SampledStateFeedback or array_like of shape (m, n)
        A design in the PID form (``design.discretize`` is applied at each Ts), a
        discrete PID (its gains, integrator, derivative and N at each Ts), or a static
        state-feedback gain K (``u_k = −K x(t_k)``, zero-order hold).
    check : optional
        Plants on which every certificate must also verify (see :func:`sampled_certificate`).
    ts_min, ts_max : float
        Search range, s (0 < ts_min < ts_max); `ts_max` is the cap of the search for a
        frozen instability (default :data:`MAX_SAMPLE_TIME_CAP`).
    rtol : float
        Relative width of the final brackets (> 0).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    **discretize
        Options of :meth:`~scara_robust.Design.discretize` (integrator, derivative, N);
        a torque limit does not change the linear loop tested.

    Returns
    -------
    SampleTimeLimit

    See Also
    --------
    check_sample_time : one sample time, as export checks it.
    sampled_certificate : the test behind both.

    Examples
    --------
    >>> import control as ct, scara_robust as sr
    >>> inertia = ct.ss([[0, 1], [0, 0]], [[0], [1.0]], [[1, 0]], 0)   # q̈ = b u, b in [1, 2]
    >>> plant = sr.pid_augment(inertia, [("B", 1, 0, 0.0, 1.0)])
    >>> lim = sr.max_sample_time(plant, sr.design(plant, 1, 2), rtol=1e-2)
    >>> bool(0.25 < lim.certified_ts <= lim.unstable_bracket[0] < lim.unstable_ts < 0.3)
    True
    >>> print(lim.message)  # doctest: +SKIP
    certified up to Ts = 0.281 s (decay rate α >= 0.01295 1/s); a frozen plant is unstable from Ts = 0.283 s
    """
    if design_or_none(design) is None and controller_kind(design) not in ("pid", "state feedback"):
        try:
            design = SampledStateFeedback(design, 1.0)  # type: ignore[arg-type]
        except (ArgumentValueError, ArgumentTypeError) as err:
            raise ArgumentTypeError("design", "must be a Design, a DiscretePID, a SampledStateFeedback or a gain "
                                    f"matrix K of shape (m, n): {err}") from err
    ts_min = check_real("ts_min", ts_min, positive=True)
    ts_max = check_real("ts_max", ts_max, positive=True)
    if ts_max <= ts_min:
        raise ArgumentValueError("ts_max", f"must be > ts_min = {ts_min:g} s, found {ts_max:g}")
    rtol = check_real("rtol", rtol, positive=True)
    A, B = _plants(model)
    opts = {k: v for k, v in discretize.items() if k in ("integrator", "derivative", "N")}
    unknown = sorted(set(discretize) - set(opts) - {"torque_limit", "tracking_time", "anti_windup"})
    if unknown:
        raise ArgumentValueError(unknown[0], "is not an option of Design.discretize")

    given: Any = design  # a Design, a DiscretePID or a SampledStateFeedback from here on

    def pid_at(ts: float) -> DiscretePID | SampledStateFeedback:
        if controller_kind(given) is not None:
            return given.linear_at(ts)  # type: ignore[no-any-return]
        return given.discretize(ts, **opts)  # type: ignore[no-any-return]

    def stable(ts: float, loops: Array | None = None) -> bool:
        if loops is None:
            loops = _without_marginal(sampled_closed_loops(A, B, pid_at(ts)))[0]
        return bool(np.abs(np.linalg.eigvals(loops)).max() < 1.0)

    first, keep = _without_marginal(sampled_closed_loops(A, B, pid_at(ts_min)))
    n_marginal = int((~keep).sum())
    left_out = (f" ({n_marginal} state(s) fed by nothing, eigenvalue exactly 1 at every Ts, e.g. K_I = 0, "
                "left out)" if n_marginal else "")
    if not stable(ts_min, first):
        return SampleTimeLimit(np.nan, (0.0, ts_min), ts_min, (0.0, ts_min), None, A.shape[0],
                               f"a frozen sampled loop is unstable already at ts_min = {ts_min:g} s" + left_out)
    lo = ts_min
    hi = math.inf
    ts = ts_min
    while ts < ts_max:
        ts = min(ts * 1.25, ts_max)
        if not stable(ts):
            hi = ts
            break
        lo = ts
    if math.isfinite(hi):
        lo, hi = bisect(stable, lo, hi, rtol, midpoint="geometric", desc="frozen Ts")
    unstable = (lo, hi)
    if not cvxpy_available():
        return SampleTimeLimit(np.nan, (np.nan, np.nan), hi, unstable, None, A.shape[0],
                               (f"frozen instability at Ts = {hi:.4g} s" if math.isfinite(hi) else
                                f"no frozen instability up to the cap ts_max = {ts_max:g} s")
                               + "; cvxpy not installed, no certificate" + left_out)
    certs: dict[float, SampledCertificate] = {}
    candidate = None
    if design_or_none(design) is not None or controller_kind(design) == "state feedback":
        gain = given.K

        @functools.cache
        def candidate() -> Array | None:
            # the continuous loops' common P, a second candidate: solved the first time a sampled LMI falls short
            continuous = lmi_certificate(A - B @ gain, solver=solver)
            return continuous.P if continuous.certified else None

    def certified(ts: float) -> bool:  # the bisection needs the verdict alone: the first P numpy verifies
        certs[ts] = sampled_certificate((A, B), pid_at(ts), check=check, solver=solver, candidate=candidate,
                                        stop="verified")
        return certs[ts].certified

    top = lo if math.isfinite(hi) else ts_max
    if certified(top):
        c_lo, c_hi = top, hi
    elif not certified(ts_min):
        return SampleTimeLimit(np.nan, (0.0, ts_min), hi, unstable, certs[ts_min], A.shape[0],
                               f"not certified at ts_min = {ts_min:g} s; "
                               + (f"frozen instability at Ts = {hi:.4g} s" if math.isfinite(hi) else
                                  f"no frozen instability up to the cap ts_max = {ts_max:g} s") + left_out)
    else:
        c_lo, c_hi = bisect(certified, ts_min, top, rtol, midpoint="geometric", desc="certified Ts")
    cert = _at_optimum(certs[c_lo], (A, B), pid_at(c_lo), check, resolve_lmi_solver(solver), candidate)
    message = (
        f"certified up to Ts = {c_lo:.4g} s (decay rate α >= {cert.rate:.4g} 1/s); "
        + (f"a frozen plant is unstable from Ts = {hi:.4g} s" if math.isfinite(hi) else
           f"no frozen instability up to the cap ts_max = {ts_max:g} s")
    ) + left_out
    return SampleTimeLimit(c_lo, (c_lo, c_hi), hi, unstable, cert, A.shape[0], message)


def _at_optimum(cert: SampledCertificate, plants: tuple[Array, Array], pid: DiscretePID | SampledStateFeedback,
                check: SampledSet | tuple[ArrayLike, ArrayLike] | None, solver: str,
                candidate: Callable[[], ArrayLike | None] | None) -> SampledCertificate:
    """The certificate a bisection stopped at (its first verified P), or the LMI's optimum there if it proves more.

    A bisection needs only the verdict; the rate reported is the optimal P's, as every other
    certificate's.
    """
    if solver != "IPM" or not cert.certified:
        return cert
    best = sampled_certificate(plants, pid, check=check, solver=solver, candidate=candidate)
    return best if best.certified and best.rate >= cert.rate else cert


def interior_grid(model: UncertainLTVModel, points: int = 5, max_plants: int = 4096) -> tuple[Array, Array]:
    """Plants on a regular grid of the box, corners included: `points` values per element.

    The ZOH map (A, B) ↦ (Φ, Γ) is not affine, so the sampled loops of a box's corners do
    not bound those of its inside; a grid checks the inside too. The number of values per
    element is lowered (to 2, the corners alone) until the grid has at most `max_plants`.

    Parameters
    ----------
    model : UncertainLTVModel
    points : int
        Values per element (>= 2).
    max_plants : int

    Returns
    -------
    A : ndarray, shape (k, n, n)
    B : ndarray, shape (k, n, m)
    """
    model = as_box("model", model)
    n = model.n_elements
    while points > 2 and points**n > max_plants:
        points -= 1
    axes = [np.linspace(lo, hi, points) for lo, hi in zip(model.lower_bounds(), model.upper_bounds())]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, n) if n else np.zeros((1, 0))
    A, B = model.matrices_at(grid)
    return np.asarray(A, dtype=float), np.asarray(B, dtype=float)


@dataclass(frozen=True)
class SampleTimeCheck(VerdictFromCertified, AnalysisResult):
    """Is a discrete PID safe to run at its sample time? The certificate at Ts, and the limits.

    Attributes
    ----------
    certificate : SampledCertificate
        The frozen and common-P tests at ``pid.Ts``.
    limit : SampleTimeLimit or None
        When Ts is not certified: the largest certified Ts and the smallest Ts with an
        unstable frozen plant (:func:`max_sample_time`), to say what Ts would be safe.
    set_name : str
        What plants were checked (shown in messages and records).
    """

    certificate: SampledCertificate
    limit: SampleTimeLimit | None
    set_name: str

    @property
    def certified(self) -> bool:
        """numpy verified a common P of the sampled loops at this Ts."""
        return self.certificate.certified

    @property
    def message(self) -> str:
        """One sentence: certified, or why not and which Ts would be."""
        cert = self.certificate
        if cert.certified:
            return (f"Ts = {cert.Ts:g} s is certified on {self.set_name}: a common P verified with numpy on "
                    f"{cert.n_plants} plants, decay rate α >= {cert.rate:.4g} 1/s (V_k+1 <= (1 - 2α Ts) V_k)")
        why = (f"a frozen sampled loop is unstable (spectral radius {cert.spectral_radius:.4g})"
               if not cert.frozen_stable else f"no verified common P ({cert.verdict}: {cert.status})")
        text = f"Ts = {cert.Ts:g} s is not certified on {self.set_name}: {why}"
        if self.limit is not None:
            lim = self.limit
            best = (f"the largest certified Ts is {lim.certified_ts:.4g} s" if math.isfinite(lim.certified_ts)
                    else "no Ts is certified")
            unstable = (f"a frozen plant is unstable from Ts = {lim.unstable_ts:.4g} s"
                        if math.isfinite(lim.unstable_ts) else "no frozen instability was found")
            text += f"; {best}, {unstable}"
        return text

    def record(self) -> dict[str, object]:
        """The certificate as JSON-ready data (for the exported files).

        Returns
        -------
        dict
            ``certified``, ``verdict``, ``Ts`` (s), ``set``, ``n_plants``,
            ``spectral_radius``, ``decay_rate`` (α, 1/s, ``V_k+1 <= (1 − 2αTs) V_k``),
            ``certified_ts`` and ``unstable_ts`` (s, None when not computed or infinite),
            ``message``.
        """
        cert, lim = self.certificate, self.limit

        def num(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {
            "certified": cert.certified, "verdict": cert.verdict, "Ts": cert.Ts, "set": self.set_name,
            "n_plants": cert.n_plants, "spectral_radius": num(cert.spectral_radius), "decay_rate": num(cert.rate),
            "certified_ts": cert.Ts if cert.certified else num(None if lim is None else lim.certified_ts),
            "unstable_ts": num(None if lim is None else lim.unstable_ts), "message": self.message,
        }


def check_sample_time(
    model: SampledSet | tuple[ArrayLike, ArrayLike],
    pid: DiscretePID | SampledStateFeedback,
    *,
    check: SampledSet | tuple[ArrayLike, ArrayLike] | None = None,
    set_name: str = "the given plants",
    rtol: float = 1e-3,
    solver: str | None = None,
) -> SampleTimeCheck:
    """The sampled-data certificate of `pid` at its own Ts and, if it fails, the safe limits.

    Run it before deploying a controller: a Ts that is not certified comes back with the
    largest certified Ts and the smallest Ts at which a frozen plant is unstable.

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel, PhysicalSamples or tuple (A, B)
        Plants in the PID form (see :func:`sampled_certificate`).
    pid : DiscretePID or SampledStateFeedback
        The controller at the sample time to check.
    check : optional
        Plants on which the P must also verify (e.g. :func:`interior_grid` of a box).
    set_name : str
        What the plants are, for messages.
    rtol : float
        Relative width of the limits' brackets (the default is :func:`max_sample_time`'s,
        and so is its search range unless `pid`'s Ts lies outside it: one design, one
        bracket, whichever command asks).
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    SampleTimeCheck

    See Also
    --------
    max_sample_time : the largest certified sample time.
    export_controller : writes the controller only where it is certified.

    Examples
    --------
    >>> import control as ct, scara_robust as sr
    >>> inertia = ct.ss([[0, 1], [0, 0]], [[0], [1.0]], [[1, 0]], 0)   # q̈ = b u, b in [1, 2]
    >>> plant = sr.pid_augment(inertia, [("B", 1, 0, 0.0, 1.0)])
    >>> pid = sr.design(plant, 1, 2).discretize(0.5)
    >>> sr.check_sample_time(plant, pid).certified
    False
    """
    solver = resolve_lmi_solver(solver)
    check_controller("pid", pid, ("pid", "state feedback"),
                     "a DiscretePID (Design.discretize) or a SampledStateFeedback")
    cert = sampled_certificate(model, pid, check=check, solver=solver)
    limit = None
    if not cert.certified:
        limit = max_sample_time(model, pid, check=check, ts_min=min(TS_MIN, pid.Ts / 10),
                                ts_max=max(10 * pid.Ts, MAX_SAMPLE_TIME_CAP), rtol=rtol, solver=solver)
    return SampleTimeCheck(cert, limit, set_name)
