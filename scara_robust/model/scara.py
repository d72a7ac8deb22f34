"""The SCARA with its payload as an instance of the uncertain plant.

The robot's tracking-error dynamics linearized along its reference (paper Eq. 3) is a
second-order plant ``ë = A_q e + A_v ė + M⁻¹ u`` in two parameters: the reference time
``t_ref`` (s, over one period; it moves the linearization point, and the paper's interval
model lets it vary arbitrarily fast) and the payload mass ``m_p`` (kg). Its PID form is the
paper's Eq. (4): :func:`scara_uncertain_plant` gives it as an :class:`~scara_robust.UncertainPlant`, so
the derived interval model, the physical samples, the payload margin (a parameter margin in
kg) and the payload rate (kg/s) are the plant's general answers. With ``bounds='paper'`` the
interval view is the published Tables 1–2 (:func:`scara_robust.paper_model`) instead of the
hull computed from the robot.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from .._validation import check_choice, check_int
from .plant import Parameter, Signal, UncertainPlant
from .robot import PayloadProfile, ScaraParams, error_dynamics_jacobians, paper_payload, payload_range
from .signals import Reference, paper_reference
from .uncertain import UncertainLTVModel, paper_model

__all__ = ["scara_uncertain_plant", "SCARA_BOUNDS"]

Array = NDArray[np.float64]
#: Interval views of :func:`scara_uncertain_plant`.
SCARA_BOUNDS = ("derived", "paper")


def scara_uncertain_plant(
    params: ScaraParams | None = None,
    reference: Reference | None = None,
    payload: PayloadProfile | None = None,
    *,
    bounds: str = "derived",
    n_times: int = 721,
    n_masses: int = 21,
    payload_rate: float | None = None,
) -> UncertainPlant:
    """The SCARA's linearized error dynamics along its reference, over the payload range.

    Parameters
    ----------
    params : ScaraParams, optional
        Robot (default: the paper's).
    reference : Reference, optional
        Joint reference (default: the paper's ``sin t, cos t``).
    payload : callable, optional
        ``payload(t) -> m_p`` in kg (default: the paper's); its range over one period
        [0, 2π] s is the range of ``m_p`` (nominal: the lower end).
    bounds : {'derived', 'paper'}
        The interval view: the hull of the robot's samples (as
        :func:`scara_robust.derived_model`), or the published Tables 1–2.
    n_times, n_masses : int
        Grid of the samples: reference times over [0, 2π] s and masses over the range
        (the defaults are those of :func:`scara_robust.derived_model`).
    payload_rate : float, optional
        Bound on ``|ṁ_p|``, kg/s.

    Returns
    -------
    UncertainPlant
        Parameters ``t_ref`` (s) and ``m_p`` (kg), form 'pid', inputs the joint torques
        (N·m), outputs the joint angles (rad); 6 design-form states ``[∫e, e, ė]``.

    Examples
    --------
    >>> import scara_robust as sr
    >>> plant = sr.scara_uncertain_plant()
    >>> plant.interval_model().elements == sr.derived_model().elements
    True
    """
    check_choice("bounds", bounds, SCARA_BOUNDS)
    robot = params or ScaraParams()
    ref = reference or paper_reference()
    load = payload if payload is not None else paper_payload(robot)
    n_times = check_int("n_times", n_times, 1)
    n_masses = check_int("n_masses", n_masses, 1)
    lo, hi = payload_range(load, np.linspace(0.0, 2 * np.pi, n_times))
    parameters = (
        Parameter("t_ref", "s", (0.0, 2 * np.pi), samples=max(n_times, 2), coarse=37,
                  description="reference time over one period (the linearization point)"),
        Parameter("m_p", "kg", (lo, hi), rate=payload_rate if hi > lo else None, samples=max(n_masses, 2), coarse=5,
                  description="payload mass"),
    )
    if n_times == 1:
        parameters = (Parameter("t_ref", "s", (0.0, 0.0)), parameters[1])

    def matrices(values: Mapping[str, Array]) -> tuple[Array, Array]:
        t = np.asarray(values["t_ref"], dtype=float)
        m = np.asarray(values["m_p"], dtype=float)
        shape = np.broadcast_shapes(t.shape, m.shape)
        t, m = np.broadcast_to(t, shape), np.broadcast_to(m, shape)
        r, rd, _ = ref.sample(t.ravel())
        a_star, g_bar = error_dynamics_jacobians(robot, r, rd, m.ravel())
        A = np.zeros((t.size, 4, 4))
        A[:, :2, 2:] = np.eye(2)
        A[:, 2:, :] = a_star
        B = np.zeros((t.size, 4, 2))
        B[:, 2:, :] = -g_bar  # M⁻¹: the error model's input matrix is ḡ = −M⁻¹
        return A.reshape(shape + (4, 4)), B.reshape(shape + (4, 2))

    def published(theta: float) -> UncertainLTVModel:
        return paper_model().scaled(theta)

    return UncertainPlant(
        parameters, matrices, 4, 2, form="pid", name="derived (model-based)" if bounds == "derived" else
        "paper (Tables 1-2)",
        inputs=(Signal("T1", "N·m"), Signal("T2", "N·m")),
        outputs=(Signal("q1", "rad"), Signal("q2", "rad")),
        hull=published if bounds == "paper" else None,
        prefix="scara_pid",
    )
