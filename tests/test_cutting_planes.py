"""LMIs by cutting planes: the same answer as a solve on every loop at once, checked independently.

Every LMI over many closed loops is solved on an active set grown from the loops numpy finds
violated (``robustness._cutting.grow_active_set``). These tests compare it with the solve on all
loops at once (``DIRECT_LOOPS`` raised above the set's size), on what is unique: the objective
to the solver's tolerance and the constraints re-verified on every loop with numpy, never the
minimizer itself.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import scara_robust as sr
from scara_robust.robustness import lmi, synthesis
from scara_robust.robustness._cutting import grow_active_set
from scara_robust.robustness.polytope import box_closed_loops


@pytest.fixture
def fresh(monkeypatch):
    """No answer kept from another test."""
    monkeypatch.setattr(lmi, "_SOLVED", {})


def _objective(P):
    """λmax(P): the objective of the 'decay' form (P ⪰ I)."""
    return float(scipy.linalg.eigh(P, eigvals_only=True)[-1])


def _scaled_worst(loops, P):
    """λmax(Ā_iᵀP + PĀ_i) of each loop in the LMI's scaled units (Ā / max|Ā|): the constraint is ⪯ −I."""
    A = loops / np.abs(loops).max()
    return np.array([scipy.linalg.eigh(a.T @ P + P @ a, eigvals_only=True)[-1] for a in A])


#: Clarabel's feasibility tolerance, relative to the size of the data (here λmax(P), or trace(Q)).
SOLVER_RTOL = 1e-8


# ---------------------------------------------------------------- the driver


@pytest.mark.parametrize("seed", [0, 1, 2], ids=["seed0", "seed1", "seed2"])
def test_grow_active_set_reaches_the_largest_of_every_item(seed):
    """A toy LMI: the 'answer' on an active set is its largest value; an item is violated above it."""
    values = np.random.default_rng(seed).normal(size=500)
    solves = []

    def solve(active):
        solves.append(active.size)
        return "optimal", float(values[active].max())

    status, answer, active = grow_active_set(solve, lambda a: values - a, np.array([0]), batch=3)
    assert status == "optimal" and answer == values.max() and int(np.argmax(values)) in active
    assert np.all(np.diff(solves) > 0) and active.size < values.size  # it grew, and stayed small


def test_grow_active_set_stops_when_the_active_set_has_no_answer():
    status, answer, active = grow_active_set(lambda idx: ("infeasible", None), lambda a: np.ones(3), np.array([1]))
    assert (status, answer, active.tolist()) == ("infeasible", None, [1])


# ---------------------------------------------------------------- the common P


@pytest.mark.lmi
def test_cutting_planes_reach_the_optimum_of_the_solve_on_every_loop(paper, paper_design, fresh, monkeypatch):
    loops = box_closed_loops(paper.subset("A"), paper_design.K)  # 64 corners, stable, a common P exists
    cut = sr.lmi_certificate(loops)
    monkeypatch.setattr(lmi, "DIRECT_LOOPS", 10_000)
    monkeypatch.setattr(lmi, "_SOLVED", {})
    whole = sr.lmi_certificate(loops)
    assert cut.certified and whole.certified
    assert cut.active.size < len(loops) and whole.active.size == len(loops)
    # the objective λmax(P) to the solver's tolerance (the active set's optimum is never above the whole's)
    assert _objective(cut.P) <= _objective(whole.P) * (1 + 1e-6)
    assert _objective(cut.P) == pytest.approx(_objective(whole.P), rel=1e-4)
    # every loop's constraint holds for the cutting planes' P (scipy, not the package's check): a loop left
    # out of the active set to OPTIMUM_RTOL (the stopping rule), an active one to the solver's tolerance
    worst = _scaled_worst(loops, cut.P)
    inactive = np.setdiff1d(np.arange(len(loops)), cut.active)
    assert worst[inactive].max() <= -1 + lmi.OPTIMUM_RTOL
    assert worst[cut.active].max() <= -1 + 10 * SOLVER_RTOL * _objective(cut.P)
    # the rate λmax(ĀᵀP + PĀ)/(2λmax(P)) is fixed by the objective, so it is unique; the exact rate of each P
    # (a generalized eigenvalue, what decay_rate reports) is at least that, and the optimal P is not unique
    bound_cut, bound_whole = (sr.verify_lyapunov(loops, P)[1] for P in (cut.P, whole.P))
    assert bound_cut == pytest.approx(bound_whole, rel=1e-4)
    assert cut.decay_rate >= bound_cut and whole.decay_rate >= bound_whole


@pytest.mark.lmi
def test_an_unstable_loop_proves_infeasibility(paper, paper_design, fresh):
    loops = box_closed_loops(paper, paper_design.K)  # 320 of the 1024 corners are unstable
    result = sr.lmi_certificate(loops)
    assert result.verdict == "infeasible" and result.P is None
    # the solver's dual on the one active loop (rank one) fails the strict Farkas check; the proof is
    # the loop numpy finds unstable: an eigenvalue in the right half-plane (scipy, not the package's check)
    assert result.unstable_loop is not None and result.active.size == 1
    assert scipy.linalg.eigvals(loops[result.unstable_loop]).real.max() > 0
    assert f"closed loop {result.unstable_loop} is unstable" in result.message


@pytest.mark.lmi
def test_a_check_loop_the_solve_misses_joins_the_active_set(fresh):
    """Two loops a diagonal P handles, and a check loop that needs an off-diagonal term."""
    main = np.array([[[-1.0, 0.0], [0.0, -1.0]], [[-1.0, 0.0], [0.0, -2.0]]])
    check = np.array([[[-1.0, 3.0], [0.0, -1.0]]])
    alone = sr.lmi_certificate(main)
    assert sr.verify_lyapunov(check, alone.P)[1] <= 0  # the P of the main loops fails the check loop
    both = sr.lmi_certificate(main, check=[check])
    assert both.certified and 2 in both.active
    every = np.concatenate([main, check])
    assert both.decay_rate == sr.decay_rate(every, both.P)  # the exact rate of this P on every loop
    assert 0 < sr.verify_lyapunov(every, both.P)[1] <= both.decay_rate  # above the cruder bound λmax/(2λmax(P))


@pytest.mark.lmi
def test_a_round_cut_early_gives_the_verdict_of_the_solve_on_every_loop(paper, paper_design, fresh, monkeypatch):
    """On small states a round stops at the first strictly feasible P a loop outside rejects; the verdicts hold."""
    from scara_robust.sdp import backends

    cut_early = False
    for theta, expected in ((0.55, True), (0.6395, True), (0.6405, False)):  # the common P ends in 0.6401-0.6405
        loops = box_closed_loops(paper.scaled(theta), paper_design.K)
        solves: list = []
        with monkeypatch.context() as m:
            m.setattr(lmi, "solve_lmi", lambda *a, _s=solves, **k: _s.append(backends.solve_lmi(*a, **k)) or _s[-1])
            rounds = sr.lmi_certificate(loops, stop="verified", solver="IPM")
        # a solve the IPM stopped early (accepted) that another round followed: its P was a cut
        cut_early |= any(r.accepted for r in solves[:-1])
        with monkeypatch.context() as m:  # every loop at once, to the optimum
            m.setattr(lmi, "_SOLVED", {})
            m.setattr(lmi, "DIRECT_LOOPS", 4096)
            m.setattr(lmi, "IPM_DIRECT_LOOPS", 4096)
            m.setattr(lmi, "SMALL_STATES", 0)
            whole = sr.lmi_certificate(loops, stop="optimum", solver="IPM")
        assert rounds.certified is whole.certified is expected, theta
        if rounds.certified:  # numpy's own check of the P the rounds found, on every corner
            assert sr.decay_rate(loops, rounds.P) >= rounds.floor > 0
    assert cut_early


@pytest.mark.lmi
def test_a_search_starts_from_the_last_active_set(paper, paper_design, fresh):
    test = sr.lmi_search()
    A = paper.subset("A")
    first = test(box_closed_loops(A.scaled(0.5), paper_design.K))
    again = test(box_closed_loops(A.scaled(0.6), paper_design.K))
    assert first.certified and again.certified
    assert set(first.active) <= set(again.active)  # it started where the last solve ended


@pytest.mark.parametrize("start, match", [([64], r"`start` must hold indices"), ([-1], r"`start` must hold"),
                                          ([0.5], r"`start` must hold")], ids=["too-large", "negative", "fraction"])
def test_bad_start_is_refused_naming_the_argument(paper, paper_design, start, match):
    with pytest.raises(ValueError, match=match):
        sr.lmi_certificate(box_closed_loops(paper.subset("A"), paper_design.K), start=start)


@pytest.mark.parametrize("kwargs, match", [({"stop": "best"}, r"`stop`"), ({"solver": "MOSEK"}, r"`solver`")],
                         ids=["stop", "solver"])
def test_bad_search_options_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        sr.lmi_search(**kwargs)


# ---------------------------------------------------------------- synthesis


@pytest.mark.lmi
def test_synthesis_by_cutting_planes_holds_every_plant_and_matches_the_whole_solve():
    """The robot's own samples: the decay LMI at α = 1 1/s, on 185 plants."""
    samples = sr.physical_samples(times=np.linspace(0.0, 2 * np.pi, 37), n_masses=5)
    A, B = samples.A, samples.B
    active: list[np.ndarray] = []
    status, Q, Y, _ = synthesis._solve_by_cuts(A, B, 1.0, 1000.0, "CLARABEL", active)
    whole_status, Q_w, Y_w, _ = synthesis._solve(A, B, 1.0, 1000.0, "CLARABEL")
    assert Q is not None and Q_w is not None and active[0].size < len(A)
    # the objective trace(Q) to the solver's tolerance
    assert np.trace(Q) <= np.trace(Q_w) * (1 + 1e-6) and np.trace(Q) == pytest.approx(np.trace(Q_w), rel=1e-4)
    # every plant's constraint A_iQ − B_iY + (·)ᵀ + 2αQ ⪯ −10⁻⁶I, re-verified with scipy: a plant left out of
    # the active set exactly (the stopping rule), an active one to the solver's tolerance
    worst = np.array([scipy.linalg.eigh(a @ Q - b @ Y + (a @ Q - b @ Y).T + 2.0 * Q, eigvals_only=True)[-1]
                      for a, b in zip(A, B)])
    inactive = np.setdiff1d(np.arange(len(A)), active[0])
    assert worst[inactive].max() <= -1e-6
    assert worst[active[0]].max() <= -1e-6 + 10 * SOLVER_RTOL * np.trace(Q)
