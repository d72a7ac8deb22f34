"""The paper's published numbers and the package's choices for what it leaves open.

Every constant of the paper that more than one module needs lives here, with the
section it comes from; anything in the package may import this module, and it imports
nothing from the package. SI units: s, rad, N·m, kg, m.

References
----------
"A Graphical Robust PID Controller Design for Time-Varying Uncertain Systems with
Applications to Trajectory Tracking of a Load-Varying Rigid SCARA" (the paper).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "PAPER_DESIGN_POINT",
    "PAPER_GAIN",
    "PAPER_GAIN_DECIMALS",
    "PAPER_A_STAR",
    "PAPER_B_STAR",
    "PAPER_TABLE1",
    "PAPER_TABLE2",
    "PAPER_TRANSIENT",
    "PAPER_T_FINAL",
    "PAPER_PAYLOAD_FRACTION",
    "PAPER_CP",
    "PAPER_DISTURBANCE_AMPLITUDE",
    "PAPER_DISTURBANCE_PERIOD",
    "PAPER_INITIAL_ERRORS",
]

#: The selected design parameters (ρ*, η*) (Section 4, Figure 2).
PAPER_DESIGN_POINT: tuple[float, float] = (3.0, 90.0)

#: The gain K at (ρ, η) = (3, 90) as printed in Section 4, shape (2, 6).
PAPER_GAIN = np.array([[-156.0, -10.9, -294.0, -5.5, -173.0, 2.4], [10.9, -156.0, 14.9, -260.0, 28.0, -150.0]])
#: Decimal places printed for each entry of :data:`PAPER_GAIN`, shape (2, 6).
PAPER_GAIN_DECIMALS = np.array([[0, 1, 0, 1, 0, 1], [1, 0, 1, 0, 0, 0]])

#: Published A* (rows 5-6, columns 4-6 of A), 1/s² and 1/s (Section 4).
PAPER_A_STAR = np.array([[-0.30, -0.28, -0.42], [-2.56, -4.26, -2.49]])
#: Published B* (rows 5-6 of B), rad/(N·m·s²) (Section 4).
PAPER_B_STAR = np.array([[-2.18, 1.74], [1.74, -8.98]])
#: Upper bounds of Table 1 (ΔA*), shape (2, 3); every lower bound is 0.
PAPER_TABLE1 = np.array([[1.75, 2.38, 2.00], [3.18, 4.70, 3.23]])
#: Upper bounds of Table 2 (ΔB*), shape (2, 2); every lower bound is 0.
PAPER_TABLE2 = np.array([[0.97, 1.92], [1.92, 5.08]])

#: End of the transient after which Figures 3 and 6 bound |e| and |Tc|, s.
PAPER_TRANSIENT = 6.0
#: Horizon of the paper's simulations, s (Figures 3-6).
PAPER_T_FINAL = 20.0

#: The payload is ``m_p(t) = PAPER_PAYLOAD_FRACTION · m2 · (sin t + 1)`` (Section 4), so
#: it ranges over ``[0, 2 · PAPER_PAYLOAD_FRACTION · m2]``.
PAPER_PAYLOAD_FRACTION = 0.3
#: Payload inertia coefficient, ``I_p = c_p m_p``, m² (Section 4).
PAPER_CP = 0.005

#: Square-wave disturbance on both joints: amplitude, N·m, and period, s (Section 4).
PAPER_DISTURBANCE_AMPLITUDE = 5.0
#: Period of the square-wave disturbance, s (π/5, Section 4).
PAPER_DISTURBANCE_PERIOD = math.pi / 5

#: The two initial conditions as ``(e(0) [rad], ė(0) [rad/s])``: ``large`` is Figure 3's
#: q(0) = (1.5, -1.5) rad, q̇(0) = 0 for the reference (sin t, cos t); ``small`` is Figure 6's.
PAPER_INITIAL_ERRORS: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "large": ((-1.5, 2.5), (1.0, 0.0)),
    "small": ((0.05, 0.05), (0.0, 0.0)),
}
