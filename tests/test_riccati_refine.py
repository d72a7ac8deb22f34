"""Step 2's Riccati solution refined by Newton steps, and judged by what the design needs.

The SO-101 (example-robot-data's so101.urdf, examples/robot-so101.toml) at (ρ, η) = (3, 90)
is the case: python-control's `care` returns P with a relative residual of the size of the
1e-8 the design once required (1.1e-8 from ABA's derivatives, 5.7e-9 from the payload-affine
terms the plant is built from now: the rounding of the linearization decides which side), so
the design was refused on some machines although it is usable. Newton (Kleinman) steps bring
the residual down by two orders or more, and the refined P agrees with scipy's independent
`solve_continuous_are`.
"""

from __future__ import annotations

from pathlib import Path

import control as ct
import numpy as np
import pytest
import scipy.linalg as sl

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.lyapunov import gain as gain_module

ROOT = Path(__file__).resolve().parents[1]
SO101 = str(ROOT / "examples" / "robot-so101.toml")


@pytest.fixture(scope="module")
def so101():
    """The SO-101's nominal (A, B)."""
    model = sr.open_system("arm", command="design", robot=SO101).model
    return np.asarray(model.A), np.asarray(model.B), model


def _care(A, B, rho):
    n, m = A.shape[0], B.shape[1]
    P, _, _ = ct.care(A, B, 2.0 * np.eye(n), np.eye(m) / (2.0 * rho))
    return 0.5 * (P + P.T)


def test_the_so101_case_is_refined_far_below_the_plain_tolerance(so101):
    A, B, model = so101
    raw_P = _care(A, B, 3.0)
    raw = gain_module._care_error(A, B, 3.0, raw_P)
    assert raw > gain_module.CARE_RTOL / 100  # the tolerance's size: refused where rounding puts it above
    newton = gain_module._newton_step(A, B, 3.0, raw_P)
    assert gain_module._care_error(A, B, 3.0, newton) < min(raw, gain_module.CARE_RTOL) / 100
    P = sr.riccati_solution(model, 3.0)  # refined only where care's residual is above CARE_RTOL
    assert gain_module._care_error(A, B, 3.0, P) <= gain_module.CARE_RTOL
    # an independent solver (scipy's Schur method) gives the same stabilizing solution
    P_scipy = sl.solve_continuous_are(A, B, 2.0 * np.eye(A.shape[0]), np.eye(B.shape[1]) / 6.0)
    assert np.abs(newton - P_scipy).max() <= 1e-9 * np.abs(P_scipy).max()
    assert np.abs(P - P_scipy).max() <= 1e-6 * np.abs(P_scipy).max()  # unrefined where within CARE_RTOL
    d = sr.design(model, 3.0, 90.0)
    assert d.hurwitz and d.care_residual < gain_module.CARE_ACCEPT


def test_a_newton_step_converges_quadratically_from_a_perturbed_solution(so101):
    A, B, _ = so101
    P = sl.solve_continuous_are(A, B, 2.0 * np.eye(A.shape[0]), np.eye(B.shape[1]) / 6.0)
    errors = []
    for scale in (1e-4, 1e-5):
        start = (1 + scale) * P
        errors.append((gain_module._care_error(A, B, 3.0, start),
                       gain_module._care_error(A, B, 3.0, gain_module._newton_step(A, B, 3.0, start))))
    (e1, n1), (e2, n2) = errors
    assert n1 < e1 / 10 and n2 < e2 / 10
    assert n1 / n2 > 30  # a tenth of the perturbation: about a hundredth of the next error (quadratic)


def test_a_residual_newton_cannot_reduce_is_still_refused(so101, monkeypatch):
    A, B, model = so101
    P = _care(A, B, 3.0)
    monkeypatch.setattr(gain_module.ct, "care", lambda *a, **k: (P * (1 + 1e-3), None, None))
    monkeypatch.setattr(gain_module, "CARE_NEWTON_STEPS", 0)
    with pytest.raises(ValueError, match="inaccurate .relative residual .* > 1e-06"):
        sr.riccati_solution(model, 3.0)


def test_the_so101_designs_and_certifies_at_3_90_from_the_command_line(capsys):
    assert main(["design", "--rho", "3", "--eta", "90", "--robot", SO101]) == 0
    out = capsys.readouterr().out
    assert out.startswith("design (rho, eta) = (3, 90), model: SO-101 arm")
