"""The paper's error model for your own plant: PID form (Eq. 4) or integral action.

:func:`pid_augment` takes a mechanical plant in second-order form, state ``[q, q̇]`` with
outputs ``q`` (p joints), and returns the uncertain model on ``x = [∫e, e, ė]`` with
``e = r − q`` that the paper designs its PID on. With the reference's terms left out (they
are the exogenous part the paper also leaves out of Eq. 4)::

    ë = A_q e + A_v ė − B_u u      where  q̈ = A_q q + A_v q̇ + B_u u,

so an uncertain element of the plant's acceleration rows keeps its sign in A and an
element of B_u changes sign (``[l, u]`` becomes ``[−u, −l]``): the error model's input
matrix is ``−B_u``, as the SCARA's is ``−M⁻¹``. :func:`integral_augment` does the same for
any plant ``ẋ = Ax + Bu, y = Cx`` with ``x_aug = [∫(r − y), x]``. :func:`augment_table`
shows the mapping of every element, so it can be checked by hand.

Indices are 0-based (see :mod:`scara_robust.model.uncertain`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .._validation import check_choice
from ..exceptions import ArgumentValueError
from .uncertain import ElementLike, UncertainElement, UncertainLTVModel, as_element, state_space

__all__ = ["pid_augment", "integral_augment", "augment_table", "AUGMENT_FORMS"]

Array = NDArray[np.float64]
#: The augmentations of :func:`augment_table`.
AUGMENT_FORMS = ("pid", "integral")


def _elements(elements: Sequence[ElementLike]) -> tuple[UncertainElement, ...]:
    return tuple(as_element(el, f"elements[{k}]") for k, el in enumerate(elements))


def _second_order(sys: Any) -> tuple[Any, int]:
    ss = state_space(sys, "sys")
    n = ss.A.shape[0]
    if n % 2:
        raise ArgumentValueError("sys", f"must have the state [q, q̇] of 2p states, found n = {n}")
    p = n // 2
    kinematic = np.hstack([np.zeros((p, p)), np.eye(p)])
    if not np.allclose(ss.A[:p], kinematic) or not np.allclose(ss.B[:p], 0.0):
        raise ArgumentValueError(
            "sys", "must be in second-order form: A = [[0, I], [A_q, A_v]], B = [[0], [B_u]] (state [q, q̇])"
        )
    positions = np.hstack([np.eye(p), np.zeros((p, p))])
    if ss.C.shape != positions.shape or not np.allclose(ss.C, positions) or not np.allclose(ss.D, 0):
        raise ArgumentValueError("sys", f"must output the positions q: C = [I, 0] ({p} x {n}) and D = 0")
    return ss, p


def _map_pid(el: UncertainElement, p: int) -> UncertainElement:
    if el.row < p:
        raise ArgumentValueError(
            "elements", f"{el.label} lies in a kinematic row (q̇ = q̇ is exact); only rows {p}..{2 * p - 1} may vary"
        )
    if el.matrix == "A":
        return UncertainElement("A", p + el.row, p + el.col, el.lower, el.upper)
    return UncertainElement("B", p + el.row, el.col, -el.upper, -el.lower)


def _map_integral(el: UncertainElement, q: int) -> UncertainElement:
    if el.matrix == "A":
        return UncertainElement("A", q + el.row, q + el.col, el.lower, el.upper)
    return UncertainElement("B", q + el.row, el.col, el.lower, el.upper)


def pid_augment(sys: Any, elements: Sequence[ElementLike] = (), *, name: str | None = None) -> UncertainLTVModel:
    """The uncertain PID error model ``x = [∫e, e, ė]`` (paper Eq. 4) of a second-order plant.

    Parameters
    ----------
    sys : control.StateSpace or what ``control.ss`` converts
        Continuous-time plant with state ``[q, q̇]`` (p positions then p rates),
        ``A = [[0, I], [A_q, A_v]]``, ``B = [[0], [B_u]]``, outputs ``q``.
    elements : sequence of UncertainElement or (matrix, row, col, lower, upper)
        Uncertain elements of the plant's own A and B, 0-based, in its acceleration rows
        ``p..2p-1``.
    name : str, optional

    Returns
    -------
    UncertainLTVModel
        n = 3p states, m inputs, ``n_joints = p``; A = [[0, I, 0], [0, 0, I], [0, A_q, A_v]],
        B = [[0], [0], [−B_u]]; each element mapped as :func:`augment_table` shows.

    Examples
    --------
    >>> import control as ct, scara_robust as sr
    >>> motor = ct.ss([[0, 1], [0, -2]], [[0], [5]], [[1, 0]], 0)   # θ̈ = −2θ̇ + 5u
    >>> sr.pid_augment(motor, [("B", 1, 0, -1.0, 1.0)]).elements[0]
    UncertainElement(matrix='B', row=2, col=0, lower=-1.0, upper=1.0)
    """
    ss, p = _second_order(sys)
    m = ss.B.shape[1]
    A = np.zeros((3 * p, 3 * p))
    A[:p, p : 2 * p] = np.eye(p)
    A[p : 2 * p, 2 * p :] = np.eye(p)
    A[2 * p :, p:] = ss.A[p:]
    B = np.zeros((3 * p, m))
    B[2 * p :] = -ss.B[p:]
    mapped = tuple(_map_pid(el, p) for el in _elements(elements))
    return UncertainLTVModel(A, B, mapped, name=name or f"PID form of {ss.name}", n_joints=p)


def integral_augment(sys: Any, elements: Sequence[ElementLike] = (), *, name: str | None = None) -> UncertainLTVModel:
    """The uncertain model on ``[∫(r − y), x]`` of a plant ``ẋ = Ax + Bu``, ``y = Cx``.

    Parameters
    ----------
    sys : control.StateSpace or what ``control.ss`` converts
        Continuous-time plant with ``D = 0``.
    elements : sequence of UncertainElement or (matrix, row, col, lower, upper)
        Uncertain elements of the plant's A and B, 0-based.
    name : str, optional

    Returns
    -------
    UncertainLTVModel
        n = q + n_x states (q outputs): ``A = [[0, −C], [0, A]]``, ``B = [[0], [B]]``;
        elements keep their sign, shifted by q rows and (for A) q columns. The gain of
        ``u = −Kx`` is integral action on the error plus state feedback.
    """
    ss = state_space(sys, "sys")
    if not np.allclose(ss.D, 0):
        raise ArgumentValueError("sys", "must have D = 0 (no direct feedthrough) for integral action on y")
    q, n = ss.C.shape
    A = np.zeros((q + n, q + n))
    A[:q, q:] = -ss.C
    A[q:, q:] = ss.A
    B = np.vstack([np.zeros((q, ss.B.shape[1])), ss.B])
    mapped = tuple(_map_integral(el, q) for el in _elements(elements))
    return UncertainLTVModel(A, B, mapped, name=name or f"integral form of {ss.name}")


def augment_table(sys: Any, elements: Sequence[ElementLike], form: str = "pid") -> pd.DataFrame:
    """How each plant element appears in the augmented model, to check by hand.

    Parameters
    ----------
    sys : control.StateSpace or what ``control.ss`` converts
    elements : sequence of UncertainElement or (matrix, row, col, lower, upper)
    form : {'pid', 'integral'}

    Returns
    -------
    pandas.DataFrame
        One row per element: ``plant`` (label), ``plant bounds``, ``model`` (label in the
        augmented model), ``model bounds`` and ``sign`` (+1, or −1 for an input element
        of the PID form).
    """
    check_choice("form", form, AUGMENT_FORMS)
    plant = _elements(elements)
    model = pid_augment(sys, plant) if form == "pid" else integral_augment(sys, plant)
    rows = [
        (a.label, f"[{a.lower:g}, {a.upper:g}]", b.label, f"[{b.lower:g}, {b.upper:g}]",
         -1 if form == "pid" and a.matrix == "B" else 1)
        for a, b in zip(plant, model.elements)
    ]
    return pd.DataFrame(rows, columns=["plant", "plant bounds", "model", "model bounds", "sign"])
