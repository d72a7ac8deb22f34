"""A gain certified at the sample time it will run at: LMI synthesis on the zero-order-hold plants.

The loop that runs is ``u(t) = −K x(t_k)`` held over ``[t_k, t_k + Ts)`` (a
:class:`~scara_robust.SampledStateFeedback`): with each plant held by a zero-order hold,
``x_{k+1} = (Φ_i − Γ_i K) x_k``, ``Φ_i = e^{A_i Ts}``, ``Γ_i = ∫_0^Ts e^{A_i s} ds B_i``. A common
``V = xᵀPx`` decreasing at every sample on every plant certifies it. With ``M_i = (Φ_i − I)/Ts``,
``N_i = Γ_i/Ts``, ``Q = P⁻¹``, ``Y = KQ`` and ``Z_i = M_i Q − N_i Y`` (linear in Q and Y), the
dual condition ``A_d Q A_dᵀ − Q ≺ 0`` divided by Ts is

    Z_i + Z_iᵀ + Ts Z_i Q⁻¹ Z_iᵀ ≺ 0   ⇔   [[Z_i + Z_iᵀ, √Ts Z_i], [√Ts Z_iᵀ, −Q]] ≺ 0

(Schur), without the cancellation of ``Φ_i − I`` at a small Ts. The gain is found on a subset
of the plants, every plant is checked with numpy (:func:`discrete_lyapunov_check`), the
violated ones are added and the LMI solved again (cutting planes); the answer is then
certified independently by :func:`sampled_certificate`, which finds its own P.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import check_int, check_real
from ..controller._hold import expm_stack
from ..controller.state_feedback import SampledStateFeedback
from ..results import AnalysisResult
from ..sdp import LMIProblem, LMIVariable, solve_lmi
from ..sdp.backends import resolve_lmi_solver
from .sampled import SampledCertificate, _plants, discrete_lyapunov_check, sampled_certificate

__all__ = ["synthesize_sampled", "SampledSynthesis"]

Array = NDArray[np.float64]

#: Plants of the first LMI (spread over the set); each round adds the violated ones.
FIRST_PLANTS = 24
#: Rounds of cutting planes before giving up.
MAX_ROUNDS = 8
#: The decay rates (1/s) asked of V in turn, while the answer is certified: the fastest certified is kept.
DECAYS = (0.05, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
#: Largest condition number of P (``I ⪯ Q ⪯ CONDITION·I``): a P numpy can verify to its digits.
CONDITION = 1e6


@dataclass(frozen=True)
class SampledSynthesis(AnalysisResult):
    """A gain synthesized for the sampled loop at Ts, and its certificates.

    Attributes
    ----------
    Ts : float
        s.
    K : ndarray, shape (m, n), or None
        ``u(t) = −K x(t_k)`` held; None when the LMI found none.
    P : ndarray, shape (n, n), or None
        The synthesis' Lyapunov matrix (``V_{k+1} < V_k`` on every plant).
    status : str
        The solver's last status.
    verified_rate : float
        α (1/s) of P on every plant and the check set, by numpy (``V_{k+1} <= (1 − 2αTs) V_k``);
        ``-inf`` when P does not verify.
    certificate : SampledCertificate or None
        :func:`sampled_certificate` of ``SampledStateFeedback(K, Ts)``: its own P, found and
        verified independently.
    n_plants, n_solved, rounds : int
        Plants checked, plants in the last LMI, cutting-plane rounds.
    gain_norm : float
        ``‖K‖₂``.
    decay : float
        The decay rate asked of V in the LMI, 1/s.
    seconds : float
    """

    Ts: float
    K: Array | None
    P: Array | None
    status: str
    verified_rate: float
    certificate: SampledCertificate | None
    n_plants: int
    n_solved: int
    rounds: int
    gain_norm: float
    decay: float
    seconds: float

    @property
    def verdict(self) -> str:
        """``'certified'`` or ``'not certified'``."""
        return "certified" if self.certified else "not certified"

    @property
    def certified(self) -> bool:
        """Both certificates hold: the synthesis' P verified by numpy, and the independent one."""
        return bool(self.K is not None and self.verified_rate > -math.inf and self.certificate is not None
                    and self.certificate.certified)

    @property
    def message(self) -> str:
        """One sentence."""
        if self.K is None:
            return (f"no gain found at Ts = {self.Ts:g} s (solver status {self.status!r} after {self.rounds} rounds "
                    f"on {self.n_solved} of {self.n_plants} plants): the LMI has no solution there")
        own = (f"its P verified by numpy on {self.n_plants} plants (decay α >= {self.verified_rate:.4g} 1/s)"
               if self.verified_rate > -math.inf else "its P does not verify on every plant")
        other = ("not checked" if self.certificate is None else
                 f"{self.certificate.verdict} by the sampled-data certificate's own P ({self.certificate.message})")
        return (f"u = -K x(t_k) held at Ts = {self.Ts:g} s, ||K||_2 = {self.gain_norm:.4g}: {own}; independently "
                f"{other}; {self.rounds} round(s) of cutting planes, {self.n_solved} plants in the last LMI")


def _closed_loops(Phi: Array, Gamma: Array, K: Array) -> Array:
    return np.asarray(Phi - Gamma @ K, dtype=float)


def sampled_synthesis_problem(M: Array, N: Array, Ts: float, gain_bound: float,
                              decay: float) -> tuple[LMIProblem, dict[str, LMIVariable]]:
    """The sampled-data synthesis LMI of :func:`synthesize_sampled` as an :class:`~scara_robust.LMIProblem`.

    ``minimize t`` over ``I ⪯ Q ⪯ CONDITION·I``, ``[[tI, Y], [Yᵀ, I]] ⪰ 0``, ``t <= gain_bound``
    and, at every plant, with ``Z_i = (M_iQ − N_iY)/s`` (s the largest entry of M)::

        −[[Z_i + Z_iᵀ + (2·decay/s) Q, √Ts Z_i], [√Ts Z_iᵀ, −Q/s]] ⪰ 0

    (V decays at `decay` over the hold: ``Z + Zᵀ + 2·decay·Q + Ts Z Q⁻¹ Zᵀ ⪯ 0``, scaled). With
    ``E₁ = [I 0]``, ``E₂ = [0 I]`` and ``W = E₁ + √Ts E₂``, the Z terms are
    ``−(E₁ᵀZ_iW + WᵀZ_iᵀE₁)``.

    Parameters
    ----------
    M : ndarray, shape (V, n, n)
    N : ndarray, shape (V, n, m)
    Ts : float
        s.
    gain_bound : float
    decay : float
        1/s.

    Returns
    -------
    problem : LMIProblem
    variables : dict
        ``'Q'``, ``'Y'``, ``'t'``.
    """
    n, m = M.shape[1], N.shape[2]
    scale = max(float(np.abs(M).max()), 1e-12)
    eye, one = np.eye(n), np.ones((1, 1))
    problem = LMIProblem()
    Q, Y, t = problem.symmetric("Q", n), problem.matrix("Y", m, n), problem.scalar("t")
    problem.add_lmi(terms=[(Q, 0.5 * eye, eye)], const=-eye, name="Q >= I")
    problem.add_lmi(terms=[(Q, -0.5 * eye, eye)], const=CONDITION * eye, name="Q <= CONDITION I")
    top, bottom = np.eye(m, m + n), np.eye(n, m + n, m)
    problem.add_lmi(terms=[(Y, top, bottom)], scalars=[(t, np.diag(np.r_[np.ones(m), np.zeros(n)]))],
                    const=np.diag(np.r_[np.zeros(m), np.ones(n)]), name="gain bound")
    problem.add_lmi(scalars=[(t, -one)], const=gain_bound * one, name="t <= gain bound")
    E1, E2 = np.eye(n, 2 * n), np.eye(n, 2 * n, n)
    W = E1 + math.sqrt(Ts) * E2
    problem.add_lmi(terms=[(Q, -np.swapaxes(M, 1, 2) @ E1 / scale, W), (Y, np.swapaxes(N, 1, 2) @ E1 / scale, W),
                           (Q, -(decay / scale) * E1, E1), (Q, (0.5 / scale) * E2, E2)],
                    name="decay over the hold")
    problem.minimize({t: 1.0})
    return problem, {"Q": Q, "Y": Y, "t": t}


def _solve(M: Array, N: Array, Ts: float, gain_bound: float, solver: str,
           decay: float) -> tuple[str, Array | None, Array | None]:
    problem, var = sampled_synthesis_problem(M, N, Ts, gain_bound, decay)
    result = solve_lmi(problem, solver)
    if result.y is None or result.status not in ("optimal", "optimal_inaccurate"):
        return result.status, None, None
    Qv = np.asarray(result.value(var["Q"]), dtype=float)
    Qv = 0.5 * (Qv + Qv.T)
    return result.status, np.linalg.solve(Qv.T, np.asarray(result.value(var["Y"]), dtype=float).T).T, np.linalg.inv(Qv)


def synthesize_sampled(
    model: Any,
    Ts: float,
    *,
    check: Any = None,
    gain_bound: float = 1e4,
    solver: str | None = None,
    first: int = FIRST_PLANTS,
    decay: float | None = None,
) -> SampledSynthesis:
    """A static gain certified for the loop held at `Ts` (see the module docstring).

    Parameters
    ----------
    model : UncertainLTVModel, PolytopicModel, PhysicalSamples or tuple (A, B)
        The plants (continuous time), whole state fed back; for the PID form ``x = [∫e, e, ė]``
        the integral is the plant's, exact between samples.
    Ts : float
        s (> 0).
    check : optional
        Plants on which the gain must also verify (a finer grid).
    gain_bound : float
        ``‖K Q‖₂`` bound (with ``Q ⪰ I``), the objective minimized: a small gain that holds.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).
    first : int
        Plants of the first LMI.
    decay : float, optional
        The decay rate (1/s) asked of V on every plant; default: :data:`DECAYS` in turn, the
        fastest whose answer is certified kept.

    Returns
    -------
    SampledSynthesis
        Certified when its own P verifies with numpy on every plant and `check`, and
        :func:`sampled_certificate` certifies ``SampledStateFeedback(K, Ts)`` on its own.
    """
    solver = resolve_lmi_solver(solver)
    start = time.perf_counter()
    Ts = check_real("Ts", Ts, positive=True)
    gain_bound = check_real("gain_bound", gain_bound, positive=True)
    first = check_int("first", first, 1)
    A, B = _plants(model)
    if check is not None:
        Ac, Bc = _plants(check)
        A, B = np.concatenate([A, Ac]), np.concatenate([B, Bc])
    n = A.shape[1]
    Phi, Gamma = _hold(A, B, Ts)
    M, N = (Phi - np.eye(n)) / Ts, Gamma / Ts
    best: SampledSynthesis | None = None
    asked = DECAYS if decay is None else (check_real("decay", decay, positive=True),)
    for rate in asked:
        result = _synthesize_at(model, check, Ts, Phi, Gamma, M, N, gain_bound, solver, first, rate, start)
        if not result.certified:
            return best or result
        best = result
    assert best is not None
    return best


def _synthesize_at(model: Any, check: Any, Ts: float, Phi: Array, Gamma: Array, M: Array, N: Array,
                   gain_bound: float, solver: str, first: int, decay: float, start: float) -> SampledSynthesis:
    """One synthesis asking `decay` (1/s) of V, by cutting planes, and its two verifications."""
    V = Phi.shape[0]
    active = list(np.unique(np.linspace(0, V - 1, min(first, V)).astype(int)))
    status, K, P, rounds, rate = "not solved", None, None, 0, -math.inf
    while rounds < MAX_ROUNDS:
        rounds += 1
        status, K, P = _solve(M[active], N[active], Ts, gain_bound, solver, decay)
        if K is None or P is None:
            break
        loops = _closed_loops(Phi, Gamma, K)
        worst = np.array([discrete_lyapunov_check(loops[i:i + 1], P, Ts)[0] for i in range(V)])
        bad = [int(i) for i in np.argsort(-worst) if worst[i] >= 0 and int(i) not in active][:first]
        if not bad:
            rate = discrete_lyapunov_check(loops, P, Ts)[1]
            break
        active += bad
    certificate = None if K is None else sampled_certificate(model, SampledStateFeedback(K, Ts), check=check)
    norm = math.nan if K is None else float(np.linalg.norm(K, 2))
    return SampledSynthesis(Ts, K, P, status, rate, certificate, V, len(active), rounds, norm, decay,
                            time.perf_counter() - start)


def _hold(A: Array, B: Array, Ts: float) -> tuple[Array, Array]:
    """``(Φ_i, Γ_i)`` of each plant held by a zero-order hold over Ts: shapes (V, n, n) and (V, n, m)."""
    V, n, m = B.shape
    held = np.zeros((V, n + m, n + m))
    held[:, :n, :n], held[:, :n, n:] = A * Ts, B * Ts
    E = expm_stack(held)
    return np.asarray(E[:, :n, :n], dtype=float), np.asarray(E[:, :n, n:], dtype=float)
