"""An arm's model feedforward as the controller computes it: RNEA on its rigid bodies, in plain arithmetic.

The loop a robot file certifies holds the model feedforward ``τ_ff`` at the nominal payload
(``feedforward = "gravity"``: ``G(r)``; ``"computed-torque"``: ``M(r) r̈ + C(r, ṙ) ṙ + G(r)``,
the recursive Newton–Euler algorithm at the reference). :class:`ArmFeedforward` is that term
as a deployed controller computes it: the arm's bodies read once from Pinocchio into tables
(the nominal payload folded into its body), and one RNEA pass written as scalar operations in a
fixed order. The C export writes the same tables and the same operations in the same order
(so its torque equals :meth:`ArmFeedforward.torque` to rounding), and :meth:`ArmFeedforward.check`
compares it with Pinocchio's on random states before anything is written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..exceptions import ArgumentValueError
from .arm import FEEDFORWARDS, ArmSetup, RobotArm

__all__ = ["ArmFeedforward", "arm_feedforward", "FEEDFORWARD_RTOL"]

Array = NDArray[np.float64]

#: Largest relative difference from Pinocchio's torque accepted by :meth:`ArmFeedforward.check`.
FEEDFORWARD_RTOL = 1e-9

Vec = tuple[float, float, float]


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@dataclass(frozen=True, eq=False)
class ArmFeedforward:
    """The model feedforward of an arm's loop, as tables and one RNEA pass (see the module docstring).

    Attributes
    ----------
    kind : {'gravity', 'computed-torque'}
    payload : float
        The payload the feedforward assumes (the robot file's nominal), kg.
    joints : tuple of str
        The arm's controlled joints, in the order of the controller's vectors.
    parents : tuple of int, length n
        Each body's parent body (−1: the base); bodies are in the model's order, parents first.
    joint_body : tuple of int, length n
        The body of each joint of `joints`.
    tree : ndarray, shape (n, 16)
        Per body: its joint's placement rotation (9, row-major) and translation (3, m) in the
        parent's frame, its axis (3), its armature (kg·m²).
    body : ndarray, shape (n, 13)
        Per body: mass (kg), first moment m·c (3, kg·m), inertia about the joint frame's
        origin (9, kg·m²), the payload included.
    gravity : ndarray, shape (3,)
        m/s², base frame.
    """

    kind: str
    payload: float
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    joint_body: tuple[int, ...]
    tree: Array
    body: Array
    gravity: Array
    _rows: tuple[tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...]] = field(repr=False, default=((), ()))

    def __post_init__(self) -> None:
        check_choice("kind", self.kind, ("gravity", "computed-torque"))
        object.__setattr__(self, "_rows", (tuple(tuple(float(v) for v in r) for r in self.tree),
                                           tuple(tuple(float(v) for v in r) for r in self.body)))

    @property
    def n_joints(self) -> int:
        """n."""
        return len(self.joints)

    def torque(self, r: Sequence[float], rd: Sequence[float], rdd: Sequence[float]) -> list[float]:
        """``τ_ff`` at the reference (rad, rad/s, rad/s², joint order), N·m: the C's operations in its order.

        Parameters
        ----------
        r, rd, rdd : sequence of float, length n
            For ``'gravity'`` only `r` is read.

        Returns
        -------
        list of float, length n
        """
        n = self.n_joints
        TREE, BODY = self._rows
        q, qd, qdd = [0.0] * n, [0.0] * n, [0.0] * n
        for k in range(n):
            b = self.joint_body[k]
            q[b] = float(r[k])
            if self.kind == "computed-torque":
                qd[b], qdd[b] = float(rd[k]), float(rdd[k])
        R: list[tuple[float, ...]] = []
        V: list[tuple[Vec, Vec]] = []
        A: list[tuple[Vec, Vec]] = []
        F: list[list[float]] = []
        g = (float(self.gravity[0]), float(self.gravity[1]), float(self.gravity[2]))
        for i in range(n):
            t = TREE[i]
            c, s = math.cos(q[i]), math.sin(q[i])
            ax, ay, az = t[12], t[13], t[14]
            k1 = 1.0 - c
            j = (c + k1 * ax * ax, k1 * ax * ay - s * az, k1 * ax * az + s * ay,
                 k1 * ay * ax + s * az, c + k1 * ay * ay, k1 * ay * az - s * ax,
                 k1 * az * ax - s * ay, k1 * az * ay + s * ax, c + k1 * az * az)
            rot = []
            for row in range(3):
                p0, p1, p2 = t[3 * row], t[3 * row + 1], t[3 * row + 2]
                rot += [p0 * j[0] + p1 * j[3] + p2 * j[6], p0 * j[1] + p1 * j[4] + p2 * j[7],
                        p0 * j[2] + p1 * j[5] + p2 * j[8]]
            R.append(tuple(rot))
            par = self.parents[i]
            if par < 0:
                vp, wp, alp, awp = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-g[0], -g[1], -g[2]), (0.0, 0.0, 0.0)
            else:
                (vp, wp), (alp, awp) = V[par], A[par]
            p = (t[9], t[10], t[11])
            sq = (ax * qd[i], ay * qd[i], az * qd[i])
            pw = _cross(p, wp)
            v = _back(R[i], (vp[0] - pw[0], vp[1] - pw[1], vp[2] - pw[2]))
            w0 = _back(R[i], wp)
            w = (w0[0] + sq[0], w0[1] + sq[1], w0[2] + sq[2])
            pa = _cross(p, awp)
            al0 = _back(R[i], (alp[0] - pa[0], alp[1] - pa[1], alp[2] - pa[2]))
            aw0 = _back(R[i], awp)
            vs, ws = _cross(v, sq), _cross(w, sq)
            al = (al0[0] + vs[0], al0[1] + vs[1], al0[2] + vs[2])
            aw = (aw0[0] + ax * qdd[i] + ws[0], aw0[1] + ay * qdd[i] + ws[1], aw0[2] + az * qdd[i] + ws[2])
            il, ia = _momentum(BODY[i], v, w)
            fl, fa = _momentum(BODY[i], al, aw)
            c1, c2, c3 = _cross(w, il), _cross(w, ia), _cross(v, il)
            V.append((v, w))
            A.append((al, aw))
            F.append([fl[0] + c1[0], fl[1] + c1[1], fl[2] + c1[2],
                      fa[0] + c2[0] + c3[0], fa[1] + c2[1] + c3[1], fa[2] + c2[2] + c3[2]])
        tau_b = [0.0] * n
        for i in range(n - 1, -1, -1):
            t = TREE[i]
            f = F[i]
            tau_b[i] = t[12] * f[3] + t[13] * f[4] + t[14] * f[5] + t[15] * qdd[i]
            par = self.parents[i]
            if par >= 0:
                fl = _forward(R[i], (f[0], f[1], f[2]))
                fa = _forward(R[i], (f[3], f[4], f[5]))
                pf = _cross((t[9], t[10], t[11]), fl)
                for k in range(3):
                    F[par][k] += fl[k]
                    F[par][3 + k] += fa[k] + pf[k]
        return [tau_b[self.joint_body[k]] for k in range(n)]

    def check(self, arm: RobotArm, n_states: int = 200, seed: int = 0, rtol: float = FEEDFORWARD_RTOL) -> float:
        """The largest relative difference from Pinocchio's feedforward on random states; refused above `rtol`.

        Angles uniform in ``[−π, π]`` rad, rates in ``[−3, 3]`` rad/s, accelerations in
        ``[−10, 10]`` rad/s²; the difference is measured in the largest entry, relative to
        ``max(1 N·m, max |τ|)`` of Pinocchio's torque at that state.

        Parameters
        ----------
        arm : RobotArm
            The arm the tables were read from.
        n_states, seed : int
        rtol : float

        Returns
        -------
        float

        Raises
        ------
        ArgumentValueError
            Naming ``feedforward`` when a difference exceeds `rtol`.
        """
        n_states = check_int("n_states", n_states, 1)
        rtol = check_real("rtol", rtol, positive=True)
        rng = np.random.default_rng(seed)
        n = self.n_joints
        worst = 0.0
        for _ in range(n_states):
            r, rd, rdd = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n), rng.uniform(-10, 10, n)
            ours = np.array(self.torque(r.tolist(), rd.tolist(), rdd.tolist()))
            theirs = arm.feedforward(self.kind, r, rd, rdd, self.payload)
            worst = max(worst, float(np.abs(ours - theirs).max() / max(1.0, float(np.abs(theirs).max()))))
        if not worst <= rtol:
            raise ArgumentValueError("feedforward", f"the exported {self.kind} feedforward differs from Pinocchio's "
                                                    f"by {worst:.3g} relative on random states (accepted: {rtol:g})")
        return worst

    def record(self) -> dict[str, Any]:
        """What a design or JSON file records of it."""
        return {"kind": self.kind, "payload [kg]": self.payload, "joints": list(self.joints),
                "computed": "RNEA on the arm's rigid bodies (Pinocchio's, read once), the payload on its body"}


def _back(rot: tuple[float, ...], v: Vec) -> Vec:
    """Rᵀ v, R row-major."""
    return (rot[0] * v[0] + rot[3] * v[1] + rot[6] * v[2], rot[1] * v[0] + rot[4] * v[1] + rot[7] * v[2],
            rot[2] * v[0] + rot[5] * v[1] + rot[8] * v[2])


def _forward(rot: tuple[float, ...], v: Vec) -> Vec:
    """R v, R row-major."""
    return (rot[0] * v[0] + rot[1] * v[1] + rot[2] * v[2], rot[3] * v[0] + rot[4] * v[1] + rot[5] * v[2],
            rot[6] * v[0] + rot[7] * v[1] + rot[8] * v[2])


def _momentum(b: tuple[float, ...], v: Vec, w: Vec) -> tuple[Vec, Vec]:
    """(linear, angular about the origin) momentum of a body's inertia (13 numbers) moving at (v, ω)."""
    m, h = b[0], (b[1], b[2], b[3])
    hw, hv = _cross(h, w), _cross(h, v)
    lin = (m * v[0] - hw[0], m * v[1] - hw[1], m * v[2] - hw[2])
    ang = (b[4] * w[0] + b[5] * w[1] + b[6] * w[2] + hv[0],
           b[7] * w[0] + b[8] * w[1] + b[9] * w[2] + hv[1],
           b[10] * w[0] + b[11] * w[1] + b[12] * w[2] + hv[2])
    return lin, ang


def arm_feedforward(setup: ArmSetup, payload: float | None = None) -> ArmFeedforward | None:
    """The feedforward of `setup`'s loop (None for ``feedforward = "none"``), its tables read from the arm.

    Parameters
    ----------
    setup : ArmSetup
    payload : float, optional
        The payload it assumes, kg (default the setup's nominal, which the certificate assumes).

    Returns
    -------
    ArmFeedforward or None
    """
    check_choice("feedforward", setup.feedforward, FEEDFORWARDS)
    if setup.feedforward == "none":
        return None
    mass = setup.payload_nominal if payload is None else check_real("payload", payload, nonnegative=True)
    bodies = setup.arm.rigid_bodies()
    n = bodies.parents.size
    if np.any(bodies.parents >= np.arange(n)):  # pragma: no cover - Pinocchio lists parents first
        raise ArgumentValueError("feedforward", "the arm's bodies must list parents first")
    tree = np.zeros((n, 16))
    tree[:, 0:9] = bodies.rotations.reshape(n, 9)
    tree[:, 9:12] = bodies.translations
    tree[:, 12:15] = bodies.axes
    tree[:, 15] = bodies.armature
    body = np.array([_origin_inertia(float(bodies.masses[i]), bodies.coms[i], bodies.inertias[i]) for i in range(n)])
    body[bodies.payload_body] += mass * _origin_inertia(1.0, bodies.payload_com, bodies.payload_inertia)
    return ArmFeedforward(setup.feedforward, float(mass), tuple(setup.arm.joints),
                          tuple(int(v) for v in bodies.parents), tuple(int(v) for v in bodies.joint_index),
                          tree, body, np.asarray(bodies.gravity, dtype=float).copy())


def _origin_inertia(mass: float, com: ArrayLike, inertia: ArrayLike) -> Array:
    """(m, m c, I about the frame's origin) of a body with its inertia about its centre of mass, shape (13,)."""
    c = check_array("com", com, shape=(3,))
    about_origin = np.asarray(inertia, dtype=float) + mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return np.concatenate([[mass], mass * c, about_origin.ravel()])
