"""The SCARA's payload: its certified range in kg, how fast it may change in kg/s, and the robot's own samples.

The general answers for any plant are :func:`scara_robust.parameter_margin` and
:func:`scara_robust.rate_bracket` on an :class:`~scara_robust.UncertainPlant`; the functions here
keep the robot's conventions (the payload ``m_p(t) = (M/2)(1 + sin t)`` of peak M, the
reference phase over one period, the sampling grids of the paper's study), so their numbers
are those the user guide and the reproduction page quote.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .._validation import check_instance, check_int, check_real
from ..exceptions import ArgumentValueError
from ..lyapunov.gain import Design, design_or_none
from ..model.plant import UncertainPlant
from ..model.robot import PayloadProfile, ScaraParams, SinusoidalPayload, payload_range
from ..model.scara import physical_samples, scara_uncertain_plant
from ..model.signals import Reference
from ..sdp.backends import resolve_lmi_solver
from ._spectra import StabilityScan
from .context import PayloadContext
from .lmi import NOT_INSTALLED, cvxpy_available, lmi_search
from .margins import MARGIN_TOL
from .parameters import parameter_switching_growth
from .pdl import RateMargin, max_certified_rate
from .polytope import PolytopeCertificate, fixed_p_certifies, polytope_certificate
from .registry import AnalysisMethod, analysis_methods, get_method, register_method
from .search import bisect

__all__ = [
    "PAYLOAD_METHODS",
    "payload_margin",
    "payload_rate_certificate",
    "payload_switching_growth",
    "physical_certificate",
]

Array = NDArray[np.float64]


def _design_p(context: PayloadContext) -> Callable[[float], bool]:
    def ok(mass: float) -> bool:
        return fixed_p_certifies(context.closed_loops(mass, context.n_times, context.n_masses), context.design.P)

    return ok


def _lmi(context: PayloadContext) -> Callable[[float], bool]:
    test = lmi_search()

    def ok(mass: float) -> bool:
        # a P verified on the coarse and the fine sampling (cutting planes grown from both); anything else
        # (infeasible, inaccurate, unknown) ends the bisection's lower side, which only claims what it verified
        return bool(test(context.closed_loops(mass, context.lmi_times, context.lmi_masses),
                         [context.closed_loops(mass, context.n_times, context.n_masses)]).certified)

    return ok


def _frozen(context: PayloadContext) -> Callable[[float], bool]:
    scan = StabilityScan()  # the bisection's nearby masses: most loops proven stable by the last mass's P

    def ok(mass: float) -> bool:
        return scan.all_stable(context.closed_loops(mass, context.n_times, context.n_masses))

    return ok


for _method in (
    AnalysisMethod("payload-design-P", "payload", "lower", _design_p, "the design's own P on the robot's samples",
                   frozenset({"P", "parameters"}), cheap=True),
    AnalysisMethod("payload-lmi", "payload", "lower", _lmi,
                   "a common P by LMI on the coarse samples, verified on the fine ones (cutting planes)",
                   frozenset({"parameters", "lmi"})),
    AnalysisMethod("payload-frozen", "payload", "upper", _frozen, "every frozen sample stable",
                   frozenset({"parameters"}), cheap=True),
):
    register_method(_method)

#: The built-in rows of :func:`payload_margin`: the design's own P, a common P by LMI (lower
#: bounds), the frozen samples' stability (upper bound); the registry holds them.
PAYLOAD_METHODS = analysis_methods("payload")


def payload_margin(
    design: Design,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    *,
    n_times: int = 181,
    n_masses: int = 11,
    lmi_times: int = 37,
    lmi_masses: int = 5,
    tol: float = MARGIN_TOL,
    mass_max: float = 1e3,
    methods: Sequence[str] | None = None,
) -> pd.DataFrame:
    """The largest payload peak mass (kg) for which the robot's own sampled set is certified.

    The payload is ``m_p(t) = (M/2)(1 + sin t)`` (the paper's shape, peak M); the set is
    the robot's linearized error dynamics along the reference for masses in [0, M]
    (:func:`scara_robust.physical_samples`).

    Parameters
    ----------
    design : Design
        A design for the SCARA's 6-state error model.
    params : ScaraParams, optional
    reference : Reference, optional
    n_times, n_masses : int
        Sampling of the set for the design-P test and the frozen test.
    lmi_times, lmi_masses : int
        Coarser sampling on which the LMI is solved; its P is verified with numpy on the
        finer one.
    tol : float
        Relative tolerance of the bisections on M.
    mass_max : float
        Largest peak mass searched, kg.
    methods : sequence of str, optional
        Rows to compute, by registered name (default: the registered defaults, the built-in
        :data:`PAYLOAD_METHODS`; the design-P row alone needs only numpy and takes milliseconds).

    Returns
    -------
    pandas.DataFrame
        Rows ``payload-design-P`` and ``payload-lmi`` (lower bounds) and
        ``payload-frozen`` (upper bound); columns ``method``, ``kind``, ``mass [kg]``,
        ``bracket [kg]``, ``seconds``, ``message``.

    See Also
    --------
    parameter_margin : the same question for any plant.
    payload_rate_certificate : how fast the payload may change.
    """
    check_instance("design", design, Design, "a Design")
    tol = check_real("tol", tol, positive=True)
    names = analysis_methods("payload", defaults=True) if methods is None else tuple(methods)
    chosen = {name: get_method("payload", name, argument="methods") for name in names}
    if design.K.shape != (2, 6):
        raise ArgumentValueError("design", f"must be for the SCARA's 6-state error model, found K of {design.K.shape}")

    plants: dict[tuple[int, int], UncertainPlant] = {}  # one per grid; a peak mass sets its payload range

    def closed(mass: float, nt: int, nm: int) -> Array:
        # the robot as a plant over (t_ref, m_p), its payload range [0, mass]: its frozen loops on the grid
        profile: PayloadProfile = SinusoidalPayload(0.5 * mass, 0.5 * mass)
        if (nt, nm) not in plants:
            plants[nt, nm] = plant = scara_uncertain_plant(params, reference, profile, n_times=nt, n_masses=nm)
        else:  # the range scara_uncertain_plant gives this profile, on the plant that keeps the reference's samples
            lo, hi = payload_range(profile, np.linspace(0.0, 2 * np.pi, nt))
            plant = plants[nt, nm].with_ranges({"m_p": (lo, hi)})
        return plant.samples({"t_ref": nt, "m_p": nm}).closed_loops(design.K)

    context = PayloadContext(design, closed, n_times, n_masses, lmi_times, lmi_masses)
    rows = []
    # peak masses at which a row's P was verified on the fine samples (a P ≻ 0 with AᵀP + PA ≺ 0 on a
    # sample makes it Hurwitz): there the frozen row's answer is known without its eigenvalues
    verified: set[float] = set()
    for name in (m for m in analysis_methods("payload") if m in chosen):
        entry = chosen[name]
        kind = entry.bound
        ok = entry.run(context)
        if name in _VERIFIED_ON_FINE_SAMPLES:
            ok = _recording(ok, verified)
        elif name == "payload-frozen":
            ok = _known(ok, verified)
        start = time.perf_counter()
        if "lmi" in entry.needs and not cvxpy_available():
            rows.append((name, kind, math.nan, "", 0.0, NOT_INSTALLED))
            continue
        if not ok(1e-9):
            rows.append((name, kind, 0.0, "[0, 0]", time.perf_counter() - start, "not even without payload"))
            continue
        lo, hi = 1e-9, 1.0
        while ok(hi) and hi < mass_max:
            lo, hi = hi, 2 * hi
        if hi >= mass_max and ok(hi):
            rows.append((name, kind, math.inf, f"[{hi:g}, inf]", time.perf_counter() - start,
                         f"holds up to the {mass_max:g} kg searched"))
            continue
        lo, hi = bisect(ok, lo, hi, tol, midpoint="near-zero", desc="payload")
        value = lo if kind == "lower" else hi
        message = ("certified up to lo, not at hi" if kind == "lower"
                   else f"the upper end: a frozen sample is unstable above a peak payload of {hi:.6g} kg (every "
                        f"frozen sample stable at lo; the payload's lower end is 0 kg, its physical limit)")
        rows.append((name, kind, value, f"[{lo:.6g}, {hi:.6g}]", time.perf_counter() - start, message))
    return pd.DataFrame(rows, columns=["method", "kind", "mass [kg]", "bracket [kg]", "seconds", "message"])


#: The rows whose True at a peak mass is a P verified on that mass's fine samples (the grid the
#: frozen row scans): the design's own P, and the LMI's P (verified on the coarse and the fine).
_VERIFIED_ON_FINE_SAMPLES = frozenset({"payload-design-P", "payload-lmi"})


def _recording(ok: Callable[[float], bool], verified: set[float]) -> Callable[[float], bool]:
    """`ok`, adding each peak mass it certifies to `verified`."""
    def test(mass: float) -> bool:
        answer = ok(mass)
        if answer:
            verified.add(mass)
        return answer

    return test


def _known(ok: Callable[[float], bool], verified: set[float]) -> Callable[[float], bool]:
    """The frozen row's `ok`: True without a scan at a peak mass whose fine samples a P has verified."""
    return lambda mass: mass in verified or ok(mass)


def physical_certificate(
    design: Design,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    n_times: int = 721,
    n_masses: int = 21,
) -> PolytopeCertificate:
    """Exact test of the design's P over the convex hull of the robot's own (A, B) samples.

    Parameters
    ----------
    design : Design
    params, reference, payload
        Robot, reference and payload (defaults: the paper's), see
        :func:`scara_robust.physical_samples`.
    n_times : int
        Reference samples over one period [0, 2π] s (>= 2).
    n_masses : int
        Payload masses across its range (>= 1).

    Returns
    -------
    PolytopeCertificate
        ``worst_point`` is ``(t, m_p)`` in s and kg. The polytope holds every convex
        combination of the samples, so a time-varying payload and any switching between
        them are covered; points of the robot between samples are not, so check that a
        finer sampling keeps the verdict (:func:`scara_robust.certificate_table` does).
    """
    if design_or_none(design) is None:
        raise TypeError(f"`design` must be a Design from scara_robust.design, found {type(design).__name__}")
    n_times = check_int("n_times", n_times, 2)
    samples = physical_samples(
        params, reference, payload, times=np.linspace(0.0, 2 * np.pi, int(n_times)), n_masses=n_masses
    )
    if samples.A.shape[1:] != design.A_cl.shape:
        raise ValueError(f"`design` must be for a {samples.A.shape[1]}-state model, found {design.A_cl.shape[0]}")
    closed = samples.A - samples.B @ design.K
    points = np.column_stack([samples.times, samples.masses])
    return polytope_certificate(closed, design.P, points, set_name="physical")


def payload_closed_loops(
    design: Design,
    mass_max: float,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    *,
    n_times: int = 37,
    n_masses: int = 9,
) -> tuple[Array, Array, Array]:
    """The robot's closed loops along the reference, indexed by payload mass.

    Parameters
    ----------
    design : Design
        A design for the SCARA's 6-state error model.
    mass_max : float
        Peak payload M, kg (> 0); masses span [0, M] (the payload ``(M/2)(1 + sin t)`` of
        :func:`scara_robust.payload_margin`).
    params : ScaraParams, optional
    reference : Reference, optional
    n_times : int
        Reference phases over [0, 2π] s (>= 1).
    n_masses : int
        Masses over [0, M] (>= 2).

    Returns
    -------
    closed_loops : ndarray, shape (n_times * n_masses, 6, 6)
        ``Ā = A − BK`` of :func:`scara_robust.physical_samples`, time-major.
    masses : ndarray, shape (n_times * n_masses,)
        Payload mass of each sample, kg.
    times : ndarray, shape (n_times * n_masses,)
        Reference time of each sample, s.
    """
    check_instance("design", design, Design, "a Design")
    if design.K.shape != (2, 6):
        raise ArgumentValueError("design", f"must be for the SCARA's 6-state error model, found K of {design.K.shape}")
    mass_max = check_real("mass_max", mass_max, positive=True)
    n_times = check_int("n_times", n_times, 1)
    n_masses = check_int("n_masses", n_masses, 2)
    plant = scara_uncertain_plant(params, reference, SinusoidalPayload(0.5 * mass_max, 0.5 * mass_max),
                                  n_times=n_times, n_masses=n_masses)
    samples = plant.samples({"t_ref": n_times, "m_p": n_masses})
    return samples.closed_loops(design.K), samples.column("m_p"), samples.column("t_ref")


def payload_rate_certificate(
    design: Design,
    mass_max: float,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    *,
    n_times: int = 37,
    n_masses: int = 9,
    check_times: int = 181,
    check_masses: int = 33,
    rate_max: float = 1e6,
    tol: float = 1e-2,
    solver: str | None = None,
) -> RateMargin:
    """The largest payload rate ``|ṁ_p|`` (kg/s) certified for payloads in [0, M].

    Scheduling parameter: the payload mass m_p ∈ [0, M] (kg), with ``|ṁ_p| <= ν``; the
    reference phase (times over [0, 2π] s) varies arbitrarily within the hull of the
    samples at each mass. The robot's linearized error dynamics (Eq. 3-4) depend on m_p
    through ``M(q, m_p)⁻¹``, not affinely, so this is the gridding condition, re-verified
    by numpy on a finer grid of phases and masses than the LMI used.

    Parameters
    ----------
    design : Design
        A design for the SCARA's 6-state error model.
    mass_max : float
        Peak payload M, kg (> 0).
    params : ScaraParams, optional
    reference : Reference, optional
    n_times, n_masses : int
        Grid on which the LMIs are solved.
    check_times, check_masses : int
        Finer grid of the numpy check, its points mostly new (``(k − 1)j + 1`` holds the
        LMI's points and j − 1 new ones between each pair).
    rate_max : float
        Largest rate tried, kg/s.
    tol : float
        Relative width of the final bracket.
    solver : {'IPM', 'CLARABEL', 'SCS'}, optional
        The LMI solver; None: :func:`~scara_robust.default_lmi_solver` ('IPM' unless changed).

    Returns
    -------
    RateMargin
        Its ``common`` field is the common-P test on the same samples.

    Examples
    --------
    >>> import scara_robust as sr
    >>> d = sr.design(sr.paper_model(), 3.0, 90.0)
    >>> sr.payload_rate_certificate(d, 180.0, n_times=13, n_masses=5).rate  # doctest: +SKIP
    """
    solver = resolve_lmi_solver(solver)
    closed, masses, _ = payload_closed_loops(design, mass_max, params, reference, n_times=n_times, n_masses=n_masses)
    closed_chk, masses_chk, _ = payload_closed_loops(design, mass_max, params, reference, n_times=check_times,
                                                     n_masses=check_masses)
    return max_certified_rate(closed, masses, check=(closed_chk, masses_chk), rate_max=rate_max, tol=tol,
                              solver=solver)


def payload_switching_growth(
    design: Design,
    mass_max: float,
    rate: float,
    *,
    phase: float,
    hold_high: float,
    hold_low: float,
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    n_ramp: int = 100,
) -> float:
    """Growth rate of the linearized closed loop under a periodic payload ramping at `rate`.

    The evidence from the other side of :func:`payload_rate_certificate`: one period holds
    m_p = M for `hold_high`, ramps down to 0 at ``−rate``, holds 0 for `hold_low`, and ramps
    back up at ``+rate``, with the reference phase held at `phase` (the certificates let the
    phase vary arbitrarily, so holding it is one admissible variation). The transition over
    a period is exact for a piecewise-constant mass (each ramp is `n_ramp` steps held at their
    midpoints), and the growth rate is ``log ρ(Φ(T)) / T`` (Floquet): positive means that
    ‖x‖ grows without bound, so no certificate of any kind exists for that rate.

    Parameters
    ----------
    design : Design
        A design for the SCARA's 6-state error model.
    mass_max : float
        Peak payload M, kg (> 0).
    rate : float
        |ṁ_p| on the ramps, kg/s (> 0).
    phase : float
        Reference time held, s.
    hold_high, hold_low : float
        Time at M and at 0 in each period, s (>= 0).
    params : ScaraParams, optional
    reference : Reference, optional
    n_ramp : int
        Steps of each ramp (>= 1).

    Returns
    -------
    float
        Floquet growth rate, 1/s.
    """
    check_instance("design", design, Design, "a Design")
    if design.K.shape != (2, 6):
        raise ArgumentValueError("design", f"must be for the SCARA's 6-state error model, found K of {design.K.shape}")
    mass_max = check_real("mass_max", mass_max, positive=True)
    rate = check_real("rate", rate, positive=True)
    phase = check_real("phase", phase)
    hold_high = check_real("hold_high", hold_high, nonnegative=True)
    hold_low = check_real("hold_low", hold_low, nonnegative=True)
    n_ramp = check_int("n_ramp", n_ramp, 1)
    # the robot as a plant over (t_ref, m_p), payload over [0, M]; the reference phase held
    plant = scara_uncertain_plant(params, reference, SinusoidalPayload(0.5 * mass_max, 0.5 * mass_max))
    return parameter_switching_growth(plant, design.K, "m_p", rate, hold_high=hold_high, hold_low=hold_low,
                                      at={"t_ref": phase}, n_ramp=n_ramp)
