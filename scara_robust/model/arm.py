"""Any serial robot arm from its URDF, carrying a payload of varying mass (Pinocchio).

:class:`RobotArm` reads a URDF with Pinocchio (``pin`` on PyPI, the extra ``robots``),
keeps the controlled revolute joints, locks every other joint at a given position, and
fixes a payload to a frame: a rigid body of mass ``m_p`` (kg) whose centre of mass sits at
``payload_com`` in that frame and whose inertia about it is ``m_p · diag(inertia_per_kg)``.
Its dynamics ``M(q, m_p) q̈ + C(q, q̇, m_p) q̇ + G(q, m_p) = τ`` come from Pinocchio's
algorithms (ABA, RNEA, CRBA) and their analytical derivatives.

:func:`arm_uncertain_plant` linearizes the tracking-error dynamics along a reference, as
the paper does for its SCARA (Section 3, Eq. 3): with ``e = r − q`` and the torque
``τ = τ_ff(t) + u``,

    ë = r̈ − q̈(r − e, ṙ − ė, τ_ff + u, m_p)  ⇒  ë ≈ A_q e + A_v ė − M⁻¹ u,
    A_q = ∂q̈/∂q,  A_v = ∂q̈/∂q̇  at (r, ṙ, τ_ff(t)),

from ``computeABADerivatives``. ``τ_ff`` is the loop's model feedforward with the nominal
payload (none, gravity compensation or computed torque), so the certified model is the
loop that is simulated and exported. As in the paper, the residual
``r̈ − q̈(r, ṙ, τ_ff, m_p)`` (zero for computed torque at the nominal payload) is left to
the integral action and the input matrix is frozen at ``e = 0``. The plant's parameters
are the reference time ``t_ref`` (s, over one period of the reference) and the payload
mass ``m_p`` (kg); its design form is the paper's PID state ``[∫e, e, ė]`` of 3n states.

Angles in rad, rates in rad/s, torques in N·m, masses in kg, lengths in m.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from fractions import Fraction
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..exceptions import ArgumentValueError
from .perturbation import NEGLIGIBLE_BOUND, IntegralDrift, PerturbedSamples
from .plant import Parameter, Signal, UncertainPlant
from .signals import SquareWave

__all__ = ["RobotArm", "JointSinusoids", "ArmSetup", "arm_uncertain_plant", "FEEDFORWARDS", "require_pinocchio",
           "effort_limited_payload", "EffortPayload", "holding_torque", "PayloadTerms", "arm_perturbed_samples",
           "integral_drift", "DRIFT_RATE_STEP"]

Array = NDArray[np.float64]

#: Model feedforward of an arm's loop, with the nominal payload: none, gravity
#: compensation ``G(r, m₀)``, or computed torque ``M(r, m₀) r̈ + C(r, ṙ, m₀) ṙ + G(r, m₀)``.
FEEDFORWARDS = ("none", "gravity", "computed-torque")

# Pinocchio's names of the one-degree-of-freedom revolute joints (the bounded ones hold the
# angle, the unbounded ones of a URDF `continuous` joint hold (cos, sin) of it).
_REVOLUTE = re.compile(r"JointModel(R[XYZ]|RUB[XYZ]|RevoluteUnaligned|RevoluteUnboundedUnaligned)$")
_PRISMATIC = re.compile(r"JointModel(P[XYZ]|PrismaticUnaligned)$")
_GRAVITY = 9.81


def require_pinocchio() -> Any:
    """Import Pinocchio, or say how to install it.

    Returns
    -------
    module
        ``pinocchio``.

    Raises
    ------
    ModuleNotFoundError
        Naming the extra ``robots`` (``pip install "scara_robust[robots]"``).
    """
    try:
        import pinocchio
    except ModuleNotFoundError as err:  # pragma: no cover - exercised where pin is absent
        raise ModuleNotFoundError(
            "a robot from a URDF needs Pinocchio: pip install \"scara_robust[robots]\" (the PyPI package `pin`)"
        ) from err
    return pinocchio


@dataclass(frozen=True)
class JointSinusoids:
    """A joint reference ``r_i(t) = center_i + amplitude_i sin(omega_i t + phase_i)``.

    Parameters
    ----------
    center, amplitude : sequence of float, length n
        rad.
    omega : sequence of float, length n
        rad/s (> 0).
    phase : sequence of float, length n
        rad.

    Examples
    --------
    >>> from scara_robust.model.arm import JointSinusoids
    >>> ref = JointSinusoids((0.0, 0.0), (1.0, 1.0), (1.0, 1.0), (0.0, 1.5707963267948966))
    >>> [round(float(v), 12) for v in ref.sample([0.0])[0][0]]
    [0.0, 1.0]
    """

    center: tuple[float, ...]
    amplitude: tuple[float, ...]
    omega: tuple[float, ...]
    phase: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.center)
        for name in ("center", "amplitude", "omega", "phase"):
            arr = check_array(f"reference.{name}", getattr(self, name), ndim=1)
            if arr.size != n or n == 0:
                raise ArgumentValueError(f"reference.{name}", f"must hold one value per joint ({n}), found {arr.size}")
            if name == "omega" and np.any(arr <= 0):
                raise ArgumentValueError("reference.omega", f"must be > 0 rad/s, found {arr.tolist()}")
            object.__setattr__(self, name, tuple(float(v) for v in arr))
        object.__setattr__(self, "_c", np.array(self.center))
        object.__setattr__(self, "_a", np.array(self.amplitude))
        object.__setattr__(self, "_w", np.array(self.omega))
        object.__setattr__(self, "_p", np.array(self.phase))

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return len(self.center)

    @property
    def period(self) -> float:
        """The reference's common period, s: the least common multiple of the joints' periods.

        Raises
        ------
        ArgumentValueError
            If the frequencies of the moving joints have no common period within 1000
            periods of the slowest one (their ratios are not rational to 1e-9).
        """
        moving = [w for w, a in zip(self.omega, self.amplitude) if a != 0.0] or [self.omega[0]]
        base = moving[0]
        multiple = Fraction(1)
        for w in moving[1:]:
            ratio = Fraction(base / w).limit_denominator(1000)
            if abs(float(ratio) - base / w) > 1e-9 * base / w:
                raise ArgumentValueError("reference.omega", f"must have rational ratios for a common period, found "
                                                            f"{base:g} and {w:g} rad/s")
            multiple = Fraction(math.lcm(multiple.numerator, ratio.numerator),
                                math.gcd(multiple.denominator, ratio.denominator))
        period = 2 * math.pi / base * float(multiple)
        if period > 1000 * 2 * math.pi / min(moving):
            raise ArgumentValueError("reference.omega", f"give a common period of {period:.4g} s, over 1000 periods of "
                                                        "the slowest joint: choose commensurate frequencies")
        return period

    def sample(self, times: ArrayLike) -> tuple[Array, Array, Array]:
        """``r, ṙ, r̈`` at `times`, each of shape (k, n) for `times` of shape (k,) (rad, rad/s, rad/s²)."""
        t = np.asarray(times, dtype=float).reshape(-1, 1)
        return self.at(t)  # type: ignore[arg-type]

    def at(self, t: float) -> tuple[Array, Array, Array]:
        """``r, ṙ, r̈`` at one time, each of shape (n,) (the lean path of the simulators)."""
        a, w = self._a, self._w  # type: ignore[attr-defined]
        angle = w * t + self._p  # type: ignore[attr-defined]
        s = np.sin(angle)
        return self._c + a * s, a * w * np.cos(angle), -a * w * w * s  # type: ignore[attr-defined]


def _check_inertials(path: str) -> None:
    """Refuse a link whose mass or inertia cannot be physical, naming the file, the link and the field.

    Each ``<inertial>``'s ``<mass value>`` must be a finite number >= 0 (kg), and its
    ``<inertia>`` (kg·m², about the centre of mass) positive semidefinite (to 1e-9 of its
    largest principal moment). Pinocchio reads such a link without complaint and the fault
    shows much later, as a rank-deficient input matrix. The triangle inequalities of the
    principal moments are not enforced: URDFs exported from CAD often miss them by a little.

    Parameters
    ----------
    path : str
        The URDF.

    Raises
    ------
    ArgumentValueError
        Naming `urdf`, with the file, the link, the field, its unit and the value found.
    """
    import xml.etree.ElementTree as ElementTree

    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError):
        return  # Pinocchio's own reading has already reported what is wrong with the file
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name", "?")
        where = f"{path!r}: link {name!r}"
        mass = inertial.find("mass")
        if mass is not None:
            try:
                value = float(mass.get("value", "nan"))
            except ValueError:
                value = math.nan
            if not math.isfinite(value) or value < 0:
                raise ArgumentValueError("urdf", f"{where} <inertial><mass value> must be a mass >= 0 kg, found "
                                                 f"{mass.get('value')!r}")
        inertia = inertial.find("inertia")
        if inertia is None:
            continue
        try:
            i = {k: float(inertia.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        except ValueError:
            raise ArgumentValueError("urdf", f"{where} <inertial><inertia> must hold numbers (kg·m²), found "
                                             f"{dict(inertia.attrib)}") from None
        matrix = np.array([[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]],
                           [i["ixz"], i["iyz"], i["izz"]]])
        if not np.all(np.isfinite(matrix)):
            raise ArgumentValueError("urdf", f"{where} <inertial><inertia> must be finite (kg·m²), found "
                                             f"{dict(inertia.attrib)}")
        moments = np.linalg.eigvalsh(matrix)
        if moments[0] < -1e-9 * max(float(np.abs(moments).max()), 1e-300):
            raise ArgumentValueError("urdf", f"{where} <inertial><inertia> (kg·m²) is not a rigid body's: its "
                                             f"principal moments {np.round(moments, 12).tolist()} must be >= 0")


@dataclass(frozen=True, eq=False)
class RigidBodies:
    """A fixed-base tree of rigid bodies joined by revolute joints: what the recursive algorithms read.

    Body ``i`` moves with joint ``i`` (the model's order, parents first). Joint ``i``'s
    frame sits at ``(rotations[i], translations[i])`` in its parent's frame when its angle
    is 0, and turns about ``axes[i]`` (a unit vector of its own frame). The conventions are
    Pinocchio's (spatial vectors linear part first; gravity ``g`` acts as a base
    acceleration ``−g``).

    Attributes
    ----------
    parents : ndarray of int, shape (n,)
        The parent body of each body, −1 for the fixed base.
    rotations : ndarray, shape (n, 3, 3)
    translations : ndarray, shape (n, 3)
        Joint placements in the parent's frame, m.
    axes : ndarray, shape (n, 3)
    masses : ndarray, shape (n,)
        kg.
    coms : ndarray, shape (n, 3)
        Centres of mass in each joint's frame, m.
    inertias : ndarray, shape (n, 3, 3)
        Rotational inertias about the centres of mass, kg·m².
    payload_body : int
        The body the payload is fixed to (its inertia above is without the payload).
    payload_com : ndarray, shape (3,)
        The payload's centre of mass in that body's frame, m.
    payload_inertia : ndarray, shape (3, 3)
        The payload's rotational inertia about its centre of mass per kg of payload, m².
    armature : ndarray, shape (n,)
        Added to the mass matrix's diagonal, kg·m².
    gravity : ndarray, shape (3,)
        m/s², in the base frame.
    joint_index : ndarray of int, shape (n,)
        The body of each controlled joint, in the arm's joint order (:attr:`RobotArm.joints`).
    """

    parents: NDArray[np.int64]
    rotations: Array
    translations: Array
    axes: Array
    masses: Array
    coms: Array
    inertias: Array
    payload_body: int
    payload_com: Array
    payload_inertia: Array
    armature: Array
    gravity: Array
    joint_index: NDArray[np.int64]


@dataclass(frozen=True, eq=False)
class PayloadTerms:
    """The inverse dynamics' derivatives at states of an arm, each affine in the payload mass.

    Every array holds ``(X₀, X₁)`` on its first axis, ``X(m_p) = X₀ + m_p X₁`` (m_p in kg),
    then optional leading axes over states (:meth:`stack`), then the joints in the file's
    order (n of them). From :meth:`RobotArm.payload_terms`.

    Attributes
    ----------
    mass : ndarray, shape (2, ..., n, n)
        ``M``, kg·m² (and kg·m² per kg).
    bias : ndarray, shape (2, ..., n)
        ``C(q, q̇) q̇ + G(q)``, N·m.
    dq : ndarray, shape (2, ..., n, n)
        ``∂τ/∂q`` at zero acceleration, N·m/rad.
    dv : ndarray, shape (2, ..., n, n)
        ``∂τ/∂q̇``, N·m·s/rad.
    dqa : ndarray, shape (2, ..., n, n, n)
        ``[j] = ∂(M e_j)/∂q``: how the acceleration's share of ``∂τ/∂q`` grows with ``q̈_j``,
        N·m·s²/rad² per rad.
    """

    mass: Array
    bias: Array
    dq: Array
    dv: Array
    dqa: Array

    @staticmethod
    def stack(terms: Sequence[PayloadTerms]) -> PayloadTerms:
        """One :class:`PayloadTerms` over several states (a new axis after the first)."""
        return PayloadTerms(*(np.stack([getattr(t, f) for t in terms], axis=1)
                              for f in ("mass", "bias", "dq", "dv", "dqa")))

    def error_jacobians(self, tau: ArrayLike, m_p: ArrayLike) -> tuple[Array, Array, Array]:
        """``∂q̈/∂q``, ``∂q̈/∂q̇`` and ``M⁻¹`` at each state, as :meth:`RobotArm.error_jacobians`.

        The forward dynamics' derivatives from the inverse dynamics': ``q̈ = M⁻¹(τ − C q̇ − G)``,
        ``∂q̈/∂q = −M⁻¹ ∂τ/∂q`` taken at that ``q̈``, ``∂q̈/∂q̇ = −M⁻¹ ∂τ/∂q̇``.

        Parameters
        ----------
        tau : array_like, shape (..., n)
            Joint torques, N·m (broadcast against the states).
        m_p : array_like, shape (...)
            Payload masses, kg.

        Returns
        -------
        dq : ndarray, shape (..., n, n)
            1/s².
        dv : ndarray, shape (..., n, n)
            1/s.
        Minv : ndarray, shape (..., n, n)
            1/(kg·m²).
        """
        m = np.asarray(m_p, dtype=float)
        mass = self.mass[0] + m[..., None, None] * self.mass[1]
        Minv = np.linalg.inv(mass)
        bias = self.bias[0] + m[..., None] * self.bias[1]
        acc = np.einsum("...ij,...j->...i", Minv, np.asarray(tau, dtype=float) - bias)
        dtau_dq = (self.dq[0] + m[..., None, None] * self.dq[1]
                   + np.einsum("...j,...jab->...ab", acc, self.dqa[0] + m[..., None, None, None] * self.dqa[1]))
        dtau_dv = self.dv[0] + m[..., None, None] * self.dv[1]
        return -Minv @ dtau_dq, -Minv @ dtau_dv, Minv


class RobotArm:
    """A serial arm from its URDF with a payload of variable mass fixed to one frame.

    Parameters
    ----------
    urdf : path-like
        The URDF file (read by Pinocchio, without meshes).
    joints : sequence of str
        The controlled joints, in the order of the controller's vectors; each must be
        revolute (``revolute`` or ``continuous`` in the URDF).
    locked : mapping of str to float, optional
        Positions (rad, or m for a prismatic joint) of joints held still; every joint not
        controlled is locked, at 0 where not given.
    payload_frame : str
        The URDF link (or joint frame) the payload is fixed to.
    payload_com : sequence of 3 float
        The payload's centre of mass in that frame, m.
    payload_inertia_per_kg : sequence of 3 float
        Diagonal of the payload's inertia about its centre of mass per kg of mass, m²,
        axes of the frame (``(0, 0, 0)``: a point mass).
    gravity : bool
        Gravity 9.81 m/s² along −z of the URDF's base frame, or none.
    armature : sequence of float, optional
        Rotor inertia reflected through the gearbox of each controlled joint, kg·m²
        (``J_rotor · N²``; >= 0, default 0): a URDF does not hold it, and on a geared arm
        it often dominates the wrist's inertia.
    name : str, optional
        Defaults to the URDF's robot name.
    position_limits : array_like, shape (n, 2), optional
        ``[lower, upper]`` of each controlled joint, rad, overriding the URDF's ``<limit>``
        (``±inf``: none). Default: the URDF's, none for a ``continuous`` joint.
    velocity_limits, effort_limits : array_like, shape (n,), optional
        ``|q̇|`` bound (rad/s) and torque bound (N·m) of each controlled joint, overriding
        the URDF's (> 0; ``inf``: none). Default: the URDF's ``velocity`` and ``effort``,
        none where it gives none or 0.

    Raises
    ------
    ArgumentValueError
        Naming the argument: a URDF that does not parse, a joint or frame it does not
        have, a controlled joint that is not revolute, a floating base or another
        multi-degree-of-freedom joint, a payload frame on the fixed base.

    See Also
    --------
    load_arm : an arm from a robot file.
    arm_uncertain_plant : its error dynamics as a plant.
    simulate_arm : its nonlinear closed loop.

    Examples
    --------
    >>> import scara_robust as sr
    >>> arm = sr.RobotArm("examples/scara.urdf", ["joint1", "joint2"], payload_frame="tool",
    ...                   payload_inertia_per_kg=(0, 0, 0.005), gravity=False)  # doctest: +SKIP
    >>> arm.mass_matrix([0.0, 0.0], 0.0).shape  # doctest: +SKIP
    (2, 2)
    """

    def __init__(
        self,
        urdf: str | os.PathLike[str],
        joints: Sequence[str],
        *,
        locked: Mapping[str, float] | None = None,
        payload_frame: str,
        payload_com: Sequence[float] = (0.0, 0.0, 0.0),
        payload_inertia_per_kg: Sequence[float] = (0.0, 0.0, 0.0),
        gravity: bool = True,
        armature: Sequence[float] | None = None,
        name: str | None = None,
        position_limits: ArrayLike | None = None,
        velocity_limits: ArrayLike | None = None,
        effort_limits: ArrayLike | None = None,
    ) -> None:
        pin = require_pinocchio()
        path = os.fspath(urdf)
        if not os.path.isfile(path):
            raise ArgumentValueError("urdf", f"must be a URDF file, found no file {path!r}")
        try:
            with _quiet_stderr():  # urdfdom prints its parse errors to the C stderr; the error below says it once
                full = pin.buildModelFromUrdf(path)
        except (RuntimeError, ValueError) as err:
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            raise ArgumentValueError("urdf", f"{path!r} is not a URDF Pinocchio can read: {first}") from None
        _check_inertials(path)
        joints = tuple(joints)
        if not joints or not all(isinstance(j, str) for j in joints):
            raise ArgumentValueError("joints", f"must name at least one joint, found {joints!r}")
        if len(set(joints)) != len(joints):
            raise ArgumentValueError("joints", f"must name each joint once, found {list(joints)}")
        locked = dict(locked or {})
        names = list(full.names)[1:]
        kinds = {n: full.joints[full.getJointId(n)].shortname() for n in names}
        for joint in joints:
            if joint not in kinds:
                raise ArgumentValueError("joints", f"names {joint!r}, which {path!r} does not have; its joints: "
                                                   f"{', '.join(names)}")
        for joint in names:
            model_joint = full.joints[full.getJointId(joint)]
            if model_joint.nv != 1:
                raise ArgumentValueError("urdf", f"{path!r}: joint {joint!r} is a {kinds[joint]} of {model_joint.nv} "
                                                 "degrees of freedom (a floating base or planar joint); only "
                                                 "fixed-base arms with one-axis joints are supported")
        for joint in joints:
            if not _REVOLUTE.match(kinds[joint]):
                kind = "prismatic" if _PRISMATIC.match(kinds[joint]) else "not revolute"
                raise ArgumentValueError("joints", f"{joint!r} is {kind} ({kinds[joint]}); only revolute joints can "
                                                   "be controlled (lock it with `locked`, position in m)")
        for joint, value in locked.items():
            if joint not in kinds:
                raise ArgumentValueError("locked", f"names {joint!r}, which {path!r} does not have")
            if joint in joints:
                raise ArgumentValueError("locked", f"names {joint!r}, which is also a controlled joint")
            check_real(f"locked[{joint!r}]", value)
        # the configuration holding the locked joints, then the reduced model of the controlled ones
        q_full = pin.neutral(full)
        to_lock = []
        for joint in names:
            if joint in joints:
                continue
            jid = full.getJointId(joint)
            _set_angle(q_full, full.joints[jid], float(locked.get(joint, 0.0)))
            to_lock.append(jid)
        model = pin.buildReducedModel(full, to_lock, q_full) if to_lock else full
        if not model.existFrame(payload_frame):
            frames = sorted({f.name for f in model.frames} - {"universe"})
            raise ArgumentValueError("payload_frame", f"{payload_frame!r} is not a frame of {path!r}; its frames: "
                                                      f"{', '.join(frames)}")
        frame = model.frames[model.getFrameId(payload_frame)]
        parent = int(frame.parentJoint)
        if parent == 0:
            raise ArgumentValueError("payload_frame", f"{payload_frame!r} is fixed to the base: the payload would not "
                                                      "move with any controlled joint")
        com = check_array("payload_com [m]", payload_com, shape=(3,))
        per_kg = check_array("payload_inertia_per_kg [m²]", payload_inertia_per_kg, shape=(3,))
        if np.any(per_kg < 0):
            raise ArgumentValueError("payload_inertia_per_kg [m²]", f"must be >= 0, found {per_kg.tolist()}")
        if not gravity:
            model.gravity = pin.Motion.Zero()
        else:
            model.gravity = pin.Motion(np.array([0.0, 0.0, -_GRAVITY]), np.zeros(3))
        self._pin = pin
        self._model = model
        self._data = model.createData()
        self._parent = parent
        self._base_inertia = model.inertias[parent].copy()
        # the payload of 1 kg in the parent joint's frame
        unit = frame.placement.act(pin.Inertia(1.0, com, np.diag(per_kg)))
        self._unit_lever = np.array(unit.lever, dtype=float)
        self._unit_rot = np.array(unit.inertia, dtype=float)  # about the centre of mass, as Pinocchio holds it
        self._mass = math.nan
        self.urdf = path
        self.joints = joints
        self.locked = {j: float(locked.get(j, 0.0)) for j in names if j not in joints}
        self.payload_frame = payload_frame
        self.payload_com = tuple(float(v) for v in com)
        self.payload_inertia_per_kg = tuple(float(v) for v in per_kg)
        self.gravity = bool(gravity)
        self.name = name or str(model.name)
        ids = [model.getJointId(j) for j in joints]
        self._joint_models = [model.joints[i] for i in ids]
        self._iv = np.array([jm.idx_v for jm in self._joint_models], dtype=int)
        # the file's joint order, where it differs from the model's (None: the same)
        self._order = None if np.array_equal(self._iv, np.arange(len(joints))) else np.ix_(self._iv, self._iv)
        self._upper = np.triu(np.ones((len(joints), len(joints)), dtype=bool))
        self._q0 = np.array(pin.neutral(model), dtype=float)
        nq = np.array([jm.nq for jm in self._joint_models])
        idx_q = np.array([jm.idx_q for jm in self._joint_models], dtype=int)
        self._bounded, self._unbounded = np.flatnonzero(nq == 1), np.flatnonzero(nq == 2)
        self._bounded_q, self._unbounded_q = idx_q[self._bounded], idx_q[self._unbounded]
        arm_inertia = np.zeros(len(joints)) if armature is None else check_array("armature [kg·m²]", armature,
                                                                                   shape=(len(joints),))
        if np.any(arm_inertia < 0):
            raise ArgumentValueError("armature [kg·m²]", f"must be >= 0, found {arm_inertia.tolist()}")
        model.armature[self._iv] = arm_inertia
        self.armature = tuple(float(v) for v in arm_inertia)
        if model.nv != len(joints):  # pragma: no cover - every other joint was locked above
            raise ArgumentValueError("joints", f"leave {model.nv} free degrees of freedom, expected {len(joints)}")
        self.position_limits, self.velocity_limits, self.effort_limits = _joint_limits(
            full, joints, position_limits, velocity_limits, effort_limits)

    def __repr__(self) -> str:
        return f"RobotArm({self.name!r}, joints={list(self.joints)}, payload_frame={self.payload_frame!r})"

    @property
    def n_joints(self) -> int:
        """Number of controlled joints n."""
        return len(self.joints)

    # --- one state ----------------------------------------------------------------------

    def _set_mass(self, m_p: float) -> None:
        if m_p == self._mass:
            return
        pin = self._pin
        payload = pin.Inertia(m_p, self._unit_lever, m_p * self._unit_rot)
        self._model.inertias[self._parent] = self._base_inertia + payload
        self._mass = m_p

    def configuration(self, q: ArrayLike) -> Array:
        """Pinocchio's configuration vector for joint angles `q` (n,), rad."""
        angles = np.asarray(q, dtype=float)
        qq: Array = self._q0.copy()
        qq[self._bounded_q] = angles[self._bounded]
        if self._unbounded.size:  # continuous joints hold (cos, sin) of the angle
            qq[self._unbounded_q] = np.cos(angles[self._unbounded])
            qq[self._unbounded_q + 1] = np.sin(angles[self._unbounded])
        return qq

    def _velocity(self, v: ArrayLike) -> Array:
        if self._order is None:
            return np.asarray(v, dtype=float)
        vv = np.zeros(self.n_joints)
        vv[self._iv] = np.asarray(v, dtype=float)
        return vv

    def _ours(self, vec: Any) -> Array:
        out = np.asarray(vec, dtype=float)
        return out.copy() if self._order is None else out[self._iv]

    def _ours2(self, mat: Any, symmetric: bool = False) -> Array:
        """A model-ordered matrix in the file's joint order (upper triangle mirrored if `symmetric`)."""
        out = np.asarray(mat, dtype=float)
        if symmetric:  # some Pinocchio versions fill only the upper triangle of M and M⁻¹
            out = np.where(self._upper, out, out.T)
        return out.copy() if self._order is None else out[self._order]

    def forward_dynamics(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, m_p: float) -> Array:
        """Joint accelerations ``q̈ = M⁻¹(τ − C q̇ − G)`` by ABA, rad/s², shape (n,).

        Parameters
        ----------
        q, v : array_like, shape (n,)
            Joint angles (rad) and rates (rad/s).
        tau : array_like, shape (n,)
            Joint torques, N·m.
        m_p : float
            Payload mass, kg.
        """
        self._set_mass(float(m_p))
        a = self._pin.aba(self._model, self._data, self.configuration(q), self._velocity(v), self._velocity(tau))
        return self._ours(a)

    def inverse_dynamics(self, q: ArrayLike, v: ArrayLike, a: ArrayLike, m_p: float) -> Array:
        """Joint torques ``τ = M q̈ + C q̇ + G`` by RNEA, N·m, shape (n,)."""
        self._set_mass(float(m_p))
        tau = self._pin.rnea(self._model, self._data, self.configuration(q), self._velocity(v), self._velocity(a))
        return self._ours(tau)

    def gravity_torque(self, q: ArrayLike, m_p: float) -> Array:
        """``G(q, m_p)``, N·m, shape (n,)."""
        self._set_mass(float(m_p))
        return self._ours(self._pin.computeGeneralizedGravity(self._model, self._data, self.configuration(q)))

    def mass_matrix(self, q: ArrayLike, m_p: float) -> Array:
        """``M(q, m_p)``, kg·m², shape (n, n) (CRBA, symmetrized)."""
        self._set_mass(float(m_p))
        return self._ours2(self._pin.crba(self._model, self._data, self.configuration(q)), symmetric=True)

    def kinetic_energy(self, q: ArrayLike, v: ArrayLike, m_p: float) -> float:
        """``q̇ᵀ M q̇ / 2``, J."""
        vv = np.asarray(v, dtype=float)
        return float(0.5 * vv @ self.mass_matrix(q, m_p) @ vv)

    def error_jacobians(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, m_p: float) -> tuple[Array, Array, Array]:
        """``∂q̈/∂q``, ``∂q̈/∂q̇`` and ``M⁻¹`` at one state, from ``computeABADerivatives``.

        Parameters
        ----------
        q, v : array_like, shape (n,)
            Joint angles (rad) and rates (rad/s).
        tau : array_like, shape (n,)
            Joint torque the accelerations are taken at, N·m.
        m_p : float
            Payload mass, kg.

        Returns
        -------
        dq : ndarray, shape (n, n)
            1/s².
        dv : ndarray, shape (n, n)
            1/s.
        Minv : ndarray, shape (n, n)
            1/(kg·m²).
        """
        self._set_mass(float(m_p))
        dq, dv, dtau = self._pin.computeABADerivatives(self._model, self._data, self.configuration(q),
                                                       self._velocity(v), self._velocity(tau))
        return self._ours2(dq), self._ours2(dv), self._ours2(dtau, symmetric=True)

    def payload_terms(self, q: ArrayLike, v: ArrayLike) -> PayloadTerms:
        """The inverse dynamics' derivatives at one state, affine in the payload mass.

        The payload's spatial inertia is its mass times a fixed unit inertia, so RNEA and its
        derivatives are affine in ``m_p``: ``X(m_p) = X₀ + m_p X₁``. Each term is read from
        Pinocchio's ``computeRNEADerivatives`` at ``m_p`` = 0 and 1 kg (``2(n + 1)`` calls),
        after which :meth:`PayloadTerms.error_jacobians` gives :meth:`error_jacobians` at any
        payload and torque by linear algebra alone.

        Parameters
        ----------
        q, v : array_like, shape (n,)
            Joint angles (rad) and rates (rad/s).

        Returns
        -------
        PayloadTerms
        """
        n = self.n_joints
        qq, vv = self.configuration(q), self._velocity(v)
        zero = np.zeros(self._model.nv)
        mass, bias, dq, dv, dqa = (np.empty((2, n, n)), np.empty((2, n)), np.empty((2, n, n)),
                                   np.empty((2, n, n)), np.empty((2, n, n, n)))
        for k, m_p in enumerate((0.0, 1.0)):
            self._set_mass(m_p)
            d_q, d_v, d_a = self._pin.computeRNEADerivatives(self._model, self._data, qq, vv, zero)
            dq[k], dv[k], mass[k] = self._ours2(d_q), self._ours2(d_v), self._ours2(d_a, symmetric=True)
            bias[k] = self._ours(self._pin.rnea(self._model, self._data, qq, vv, zero))
            for j in range(n):  # ∂(M e_j)/∂q: RNEA is affine in the acceleration
                unit = self._velocity(np.eye(n)[j])
                with_unit = self._pin.computeRNEADerivatives(self._model, self._data, qq, vv, unit)[0]
                dqa[k, j] = self._ours2(with_unit) - dq[k]
        for term in (mass, bias, dq, dv, dqa):  # (value at 0 kg, value at 1 kg) -> (X₀, X₁)
            term[1] -= term[0]
        return PayloadTerms(mass=mass, bias=bias, dq=dq, dv=dv, dqa=dqa)

    def feedforward(self, kind: str, r: ArrayLike, rd: ArrayLike, rdd: ArrayLike, m_p: float) -> Array:
        """The model feedforward ``τ_ff`` of :data:`FEEDFORWARDS` at the reference, N·m, shape (n,).

        Parameters
        ----------
        kind : {'none', 'gravity', 'computed-torque'}
        r, rd, rdd : array_like, shape (n,)
            The reference and its derivatives (rad, rad/s, rad/s²).
        m_p : float
            The payload the feedforward assumes, kg (the nominal).
        """
        check_choice("feedforward", kind, FEEDFORWARDS)
        if kind == "none":
            return np.zeros(self.n_joints)
        if kind == "gravity":
            return self.gravity_torque(r, m_p)
        return self.inverse_dynamics(r, rd, rdd, m_p)


    def rigid_bodies(self) -> RigidBodies:
        """The arm's bodies as plain arrays, for code that runs the recursive algorithms itself.

        Read once from the reduced Pinocchio model (locked joints folded into fixed
        transforms and into their parents' inertias), in the model's joint order, which
        lists every parent before its children. The payload is not in the inertias; it is
        given per kg (:class:`RigidBodies`).

        Returns
        -------
        RigidBodies
        """
        pin, model = self._pin, self._model
        n = self.n_joints
        data = model.createData()
        pin.computeJointJacobians(model, data, self._q0)
        parents = np.empty(n, dtype=np.int64)
        rotations, translations, axes = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3))
        masses, coms, inertias = np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3))
        for joint in range(1, model.njoints):
            i = int(model.joints[joint].idx_v)
            parent = int(model.parents[joint])
            parents[i] = -1 if parent == 0 else int(model.joints[parent].idx_v)
            placement = model.jointPlacements[joint]
            rotations[i], translations[i] = placement.rotation, placement.translation
            motion = np.asarray(data.joints[joint].S, dtype=float).ravel()  # (linear, angular): a revolute's axis
            axes[i] = motion[3:]
            body = self._base_inertia if joint == self._parent else model.inertias[joint]
            masses[i], coms[i], inertias[i] = body.mass, body.lever, body.inertia
        return RigidBodies(parents=parents, rotations=rotations, translations=translations, axes=axes,
                           masses=masses, coms=coms, inertias=inertias,
                           payload_body=int(model.joints[self._parent].idx_v),
                           payload_com=self._unit_lever.copy(), payload_inertia=self._unit_rot.copy(),
                           armature=np.array(model.armature, dtype=float),
                           gravity=np.array(model.gravity.linear, dtype=float),
                           joint_index=np.array(self._iv, dtype=np.int64))


def _joint_limits(full: Any, joints: Sequence[str], position: ArrayLike | None, velocity: ArrayLike | None,
                  effort: ArrayLike | None) -> tuple[Array, Array, Array]:
    """The controlled joints' position (n, 2), velocity (n,) and effort (n,) limits: the URDF's, or those given.

    A ``continuous`` joint has no position limit; a velocity or effort of 0 (or none) in the
    URDF is no limit (inf).
    """
    n = len(joints)
    pos, vel, eff = np.empty((n, 2)), np.empty(n), np.empty(n)
    for k, joint in enumerate(joints):
        jm = full.joints[full.getJointId(joint)]
        bounded = jm.nq == 1
        pos[k] = ((full.lowerPositionLimit[jm.idx_q], full.upperPositionLimit[jm.idx_q]) if bounded
                  else (-math.inf, math.inf))
        vel[k], eff[k] = full.velocityLimit[jm.idx_v], full.effortLimit[jm.idx_v]
    vel[~(vel > 0)] = math.inf
    eff[~(eff > 0)] = math.inf
    if position is not None:
        pos = check_array("position_limits [rad]", position, shape=(n, 2), finite=False)
        if not np.all(pos[:, 0] < pos[:, 1]):
            raise ArgumentValueError("position_limits [rad]", f"must be [lower, upper] with lower < upper per joint, "
                                                              f"found {pos.tolist()}")
    for name, given, unit in (("velocity_limits", velocity, "rad/s"), ("effort_limits", effort, "N·m")):
        if given is None:
            continue
        values = check_array(f"{name} [{unit}]", given, shape=(n,), finite=False)
        if not np.all(values > 0):
            raise ArgumentValueError(f"{name} [{unit}]", f"must be > 0 (inf: none), found {values.tolist()}")
        if name == "velocity_limits":
            vel = values
        else:
            eff = values
    return pos, vel, eff


@contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence what C libraries write to file descriptor 2 (Python's own stderr is untouched)."""
    try:
        saved = os.dup(2)
    except OSError:  # pragma: no cover - no descriptor 2 to silence
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _set_angle(q: Array, joint: Any, angle: float) -> None:
    """Write one joint's position into a Pinocchio configuration (cos/sin for a continuous joint)."""
    if joint.nq == 2:
        q[joint.idx_q] = math.cos(angle)
        q[joint.idx_q + 1] = math.sin(angle)
    else:
        q[joint.idx_q] = angle


def arm_uncertain_plant(
    arm: RobotArm,
    reference: JointSinusoids,
    payload_mass: tuple[float, float],
    *,
    payload_rate: float | None = None,
    payload_nominal: float | None = None,
    feedforward: str = "none",
    n_times: int = 721,
    n_masses: int = 21,
    name: str | None = None,
    prefix: str = "arm_pid",
    design_plant: str = "center",
    payload_measurement_error: float | None = None,
    payload_measurement_delay: float = 0.0,
) -> UncertainPlant:
    """The arm's error dynamics linearized along its reference, over the payload range.

    Parameters
    ----------
    arm : RobotArm
    reference : JointSinusoids
        One sinusoid per controlled joint.
    payload_mass : (float, float)
        The payload's range, kg (>= 0).
    payload_rate : float, optional
        Bound on ``|ṁ_p|``, kg/s.
    payload_nominal : float, optional
        The payload the feedforward assumes and the margins scale about, kg (default the
        lower end, the paper's convention).
    feedforward : {'none', 'gravity', 'computed-torque'}
        The loop's model feedforward (:data:`FEEDFORWARDS`).
    n_times, n_masses : int
        Grid of the samples: reference times over one period and masses over the range.
    name : str, optional
    prefix : str
        Identifier prefix of exported code.
    design_plant : {'center', 'lower'}
        The nominal of the interval model, where the gain is designed: the centre of the
        box (default) or its lower corner (the paper's convention, which the SCARA's
        built-in model follows). See :class:`~scara_robust.UncertainPlant`.
    payload_measurement_error : float, optional
        The robot measures its payload within this, kg: ``m_p`` is then a measured
        parameter (:attr:`~scara_robust.Parameter.measured`); None: not measured.
    payload_measurement_delay : float
        Delay of that measurement, s.

    Returns
    -------
    UncertainPlant
        Parameters ``t_ref`` (s) and ``m_p`` (kg), form 'pid' (3n design states), inputs
        the joint torques (N·m), outputs the joint angles (rad).

    See Also
    --------
    RobotArm : the arm.
    certificate_table : certificates on its samples.
    """
    check_choice("feedforward", feedforward, FEEDFORWARDS)
    if reference.n_joints != arm.n_joints:
        raise ArgumentValueError("reference", f"must give {arm.n_joints} joints (those of the arm), found "
                                              f"{reference.n_joints}")
    lo = check_real("payload_mass[0] [kg]", payload_mass[0], nonnegative=True)
    hi = check_real("payload_mass[1] [kg]", payload_mass[1], nonnegative=True)
    n_times = check_int("n_times", n_times, 1)
    n_masses = check_int("n_masses", n_masses, 1)
    period = reference.period
    nominal = lo if payload_nominal is None else payload_nominal
    parameters = (
        Parameter("t_ref", "s", (0.0, period) if n_times > 1 else (0.0, 0.0), samples=max(n_times, 2),
                  coarse=min(19, max(n_times, 2)), scales=False,
                  description="reference time over one period (the linearization point; margins keep it whole)"),
        Parameter("m_p", "kg", (lo, hi), nominal=nominal, rate=payload_rate if hi > lo else None,
                  samples=max(n_masses, 2), coarse=min(5, max(n_masses, 2)), description="payload mass",
                  limits=(0.0, math.inf), measured=payload_measurement_error is not None,
                  measurement_error=payload_measurement_error or 0.0,
                  measurement_delay=payload_measurement_delay if payload_measurement_error is not None else 0.0),
    )
    n = arm.n_joints
    memo: dict[tuple[bytes, bytes], tuple[Array, Array]] = {}

    def matrices(values: Mapping[str, Array]) -> tuple[Array, Array]:
        t = np.asarray(values["t_ref"], dtype=float)
        m = np.asarray(values["m_p"], dtype=float)
        shape = np.broadcast_shapes(t.shape, m.shape)
        t_flat = np.ascontiguousarray(np.broadcast_to(t, shape).ravel())
        m_flat = np.ascontiguousarray(np.broadcast_to(m, shape).ravel())
        key = (t_flat.tobytes(), m_flat.tobytes())
        if key not in memo:  # the analyses ask for the same grids again: evaluate each once
            if len(memo) >= 8:
                memo.pop(next(iter(memo)))
            memo[key] = _linearize(t_flat, m_flat)
        A, B = memo[key]
        return A.reshape(shape + (2 * n, 2 * n)), B.reshape(shape + (2 * n, n))

    at_time: dict[float, tuple[PayloadTerms, Array]] = {}  # per reference time: the terms and τ_ff

    def _terms(times: Array) -> tuple[PayloadTerms, Array]:
        missing = [t for t in times.tolist() if t not in at_time]
        if missing:
            r, rd, rdd = reference.sample(np.asarray(missing))
            for i, t in enumerate(missing):  # Pinocchio once per time; every payload from these terms
                at_time[t] = (arm.payload_terms(r[i], rd[i]),
                              arm.feedforward(feedforward, r[i], rd[i], rdd[i], nominal))
        found = [at_time[t] for t in times.tolist()]
        return PayloadTerms.stack([f[0] for f in found]), np.array([f[1] for f in found])

    on_grid: dict[bytes, tuple[PayloadTerms, Array]] = {}  # per grid of reference times: its terms, τ_ff

    def _picked(t_flat: Array) -> tuple[PayloadTerms, Array]:
        key = t_flat.tobytes()
        if key not in on_grid:  # a payload search asks for one grid of times at many masses
            if len(on_grid) >= 4:
                on_grid.pop(next(iter(on_grid)))
            times, where = np.unique(t_flat, return_inverse=True)
            terms, tau_ff = _terms(times)
            on_grid[key] = (PayloadTerms(*(getattr(terms, f)[:, where] for f in ("mass", "bias", "dq", "dv", "dqa"))),
                            tau_ff[where])
        return on_grid[key]

    def _linearize(t_flat: Array, m_flat: Array) -> tuple[Array, Array]:
        picked, tau_ff = _picked(t_flat)
        dq, dv, Minv = picked.error_jacobians(tau_ff, m_flat)
        A = np.zeros((t_flat.size, 2 * n, 2 * n))
        A[:, :n, n:] = np.eye(n)
        A[:, n:, :n] = dq
        A[:, n:, n:] = dv
        B = np.zeros((t_flat.size, 2 * n, n))
        B[:, n:, :] = Minv
        A.setflags(write=False)
        B.setflags(write=False)
        return A, B

    return UncertainPlant(
        parameters, matrices, 2 * n, n, form="pid", name=name or f"{arm.name} (URDF)",
        inputs=tuple(Signal(f"tau_{j}", "N·m") for j in arm.joints),
        outputs=tuple(Signal(f"q_{j}", "rad") for j in arm.joints),
        prefix=prefix, design_plant=design_plant,
    )


@dataclass(frozen=True)
class EffortPayload:
    """The largest payload the effort limits can carry along the reference (:func:`effort_limited_payload`).

    Attributes
    ----------
    mass : float
        kg: every payload in ``[0, mass]`` needs at most each joint's effort limit; inf when no
        joint's limit binds; 0 when the arm alone needs more than a limit somewhere.
    joint : str or None
        The joint whose limit binds first (None when none binds).
    t : float
        s: where on the reference it binds (NaN when none binds).
    torque : ndarray, shape (n,)
        ``max_t |τ*(t, mass)|`` per joint, N·m (at the nominal payload when `mass` is inf).
    n_times : int
        Reference times of the check over one period.
    """

    mass: float
    joint: str | None
    t: float
    torque: Array
    n_times: int

    @property
    def message(self) -> str:
        """The answer in one line."""
        if self.joint is None:
            return f"no joint's effort limit binds for any payload along the reference ({self.n_times} times)"
        if self.mass == 0.0:
            return (f"the arm alone needs more than joint {self.joint!r}'s effort limit along the reference "
                    f"(at t = {self.t:.4g} s)")
        return (f"the effort limits carry a payload up to {self.mass:.6g} kg along the reference: joint "
                f"{self.joint!r} reaches its limit at t = {self.t:.4g} s ({self.n_times} times over a period)")


def _holding_terms(setup: ArmSetup, n_times: int) -> tuple[Array, Array, Array]:
    """Times (s) over one period and the terms of ``τ*(t, m) = a(t) + m b(t)``, shapes (k,), (k, n), (k, n)."""
    arm, ref = setup.arm, setup.reference
    times = np.linspace(0.0, ref.period, int(n_times), endpoint=False)
    r, rd, rdd = ref.sample(times)
    a = np.array([arm.inverse_dynamics(r[k], rd[k], rdd[k], 0.0) for k in range(times.size)])
    b = np.array([arm.inverse_dynamics(r[k], rd[k], rdd[k], 1.0) for k in range(times.size)]) - a
    return times, a, b


def holding_torque(setup: ArmSetup, n_times: int = 721) -> Array:
    """Each joint's largest torque that holds the reference, over one period and the payload range, N·m.

    ``τ*(t, m) = RNEA(r(t), ṙ(t), r̈(t), m)`` is affine in m, so its largest size over the
    range is at one of its ends.

    Parameters
    ----------
    setup : ArmSetup
    n_times : int
        Reference times over one period.

    Returns
    -------
    ndarray, shape (n,)
    """
    _, a, b = _holding_terms(setup, n_times)
    lo, hi = setup.payload_mass
    return np.asarray(np.maximum(np.abs(a + lo * b).max(axis=0), np.abs(a + hi * b).max(axis=0)), dtype=float)


def effort_limited_payload(setup: ArmSetup, n_times: int = 2881) -> EffortPayload:
    """The largest payload whose reference torque stays within every joint's effort limit.

    The torque that holds the reference, ``τ*(t, m) = RNEA(r(t), ṙ(t), r̈(t), m)`` (the arm's
    inverse dynamics with a payload of mass m, Pinocchio's RNEA), is affine in m:
    ``τ*(t, m) = a(t) + m b(t)``; each joint's ``|τ*_j| <= E_j`` is an interval of m at each
    time, and the answer is the largest m with ``[0, m]`` inside all of them, on `n_times`
    times over one period of the reference. It is what the motors must give at e = 0; the
    feedback's transients come on top.

    Parameters
    ----------
    setup : ArmSetup
    n_times : int
        Reference times over one period (>= 2).

    Returns
    -------
    EffortPayload
    """
    arm = setup.arm
    times, a, b = _holding_terms(setup, n_times)
    E = arm.effort_limits[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        # |a + m b| <= E for m in [0, M]: at m = 0 |a| <= E, then m <= (sign(b) E − a)/b where b != 0
        upper = np.where(b > 0, (E - a) / b, np.where(b < 0, (-E - a) / b, np.inf))
    upper = np.where(np.abs(a) > E, 0.0, upper)
    upper = np.where(np.isinf(E), np.inf, upper)
    k, j = np.unravel_index(int(np.argmin(upper)), upper.shape)
    mass = float(max(upper[k, j], 0.0))
    at = mass if math.isfinite(mass) else setup.payload_nominal
    torque = np.abs(a + at * b).max(axis=0)
    if math.isinf(mass):
        return EffortPayload(math.inf, None, math.nan, torque, times.size)
    return EffortPayload(mass, arm.joints[int(j)], float(times[k]), torque, times.size)


def _check_reference_limits(arm: RobotArm, reference: JointSinusoids) -> None:
    """Refuse a reference that leaves a joint's position or velocity limit, naming joint, limit and value.

    ``r_i(t) = c_i + a_i sin(ω_i t + φ_i)`` spans ``c_i ± |a_i|`` and its rate reaches
    ``|a_i| ω_i``: both exactly, over a period.

    Parameters
    ----------
    arm : RobotArm
    reference : JointSinusoids

    Raises
    ------
    ArgumentValueError
        Naming ``reference``.
    """
    if reference.n_joints != arm.n_joints:
        return  # the plant's own check names the size
    c, a, w = (np.asarray(v, dtype=float) for v in (reference.center, reference.amplitude, reference.omega))
    for k, joint in enumerate(arm.joints):
        lo, hi = arm.position_limits[k]
        low, high = c[k] - abs(a[k]), c[k] + abs(a[k])
        if low < lo or high > hi:
            value = low if low < lo else high
            raise ArgumentValueError("reference", f"leaves the position limit [{lo:g}, {hi:g}] rad of joint {joint!r}: "
                                                  f"center ± amplitude reaches {value:.6g} rad")
        rate = abs(a[k]) * w[k]
        if rate > arm.velocity_limits[k]:
            raise ArgumentValueError("reference", f"leaves the velocity limit {arm.velocity_limits[k]:g} rad/s of "
                                                  f"joint {joint!r}: amplitude × omega reaches "
                                                  f"{rate:.6g} rad/s")


@dataclass(frozen=True)
class ArmSetup:
    """An arm with its payload range, reference and feedforward: what a robot file holds.

    Attributes
    ----------
    arm : RobotArm
    reference : JointSinusoids
    payload_mass : (float, float)
        Range, kg.
    payload_rate : float or None
        Bound on ``|ṁ_p|``, kg/s.
    payload_nominal : float
        The payload the feedforward assumes and the margins scale about, kg.
    feedforward : str
        One of :data:`FEEDFORWARDS`.
    n_times, n_masses : int
        Sample grid of the linearization.
    name : str
    prefix : str
        Identifier prefix of exported code.
    design_plant : {'center', 'lower'}
        Nominal of the interval model (:func:`arm_uncertain_plant`).
    e0, edot0 : tuple of float, shape (n,), or None
        The runs' initial tracking error ``e(0) = r(0) − q(0)`` (rad) and its rate (rad/s),
        the file's ``[initial]``; None: zero.
    disturbance : SquareWave or None
        The runs' disturbance torque (one sign or scale per joint, N·m), the file's
        ``[disturbance]``; None: none.
    payload_measurement_error : float or None
        The robot measures its payload within this, kg (None: not measured).
    payload_measurement_delay : float
        s.
    """

    arm: RobotArm
    reference: JointSinusoids
    payload_mass: tuple[float, float]
    payload_rate: float | None
    payload_nominal: float
    feedforward: str = "none"
    n_times: int = 721
    n_masses: int = 21
    name: str = "arm"
    prefix: str = "arm_pid"
    design_plant: str = "center"
    e0: tuple[float, ...] | None = None
    edot0: tuple[float, ...] | None = None
    disturbance: SquareWave | None = None
    payload_measurement_error: float | None = None
    payload_measurement_delay: float = 0.0

    def __post_init__(self) -> None:
        _check_reference_limits(self.arm, self.reference)

    @property
    def torque_limit(self) -> Array | None:
        """Each joint's effort limit, N·m, shape (n,) (inf where the URDF gives none); None when it gives none."""
        limits = self.arm.effort_limits
        return None if np.all(np.isinf(limits)) else limits.copy()

    @cached_property
    def plant(self) -> UncertainPlant:
        """The linearized error dynamics (:func:`arm_uncertain_plant`), built once.

        Where every joint has an effort limit, each input's limit is the effort left to the
        feedback: the effort limit minus the largest torque that holds the reference over the
        payload range (:func:`holding_torque`), so that the input-limit certificate bounds
        the total torque by the effort limit; a joint with no effort left gets a limit of a
        millionth of its effort (the certificate then certifies next to nothing, as it should).
        """
        plant = self._plant()
        effort = self.arm.effort_limits
        if not np.all(np.isfinite(effort)):
            return plant
        # a joint with no effort left gets a limit of one millionth of its effort: nothing is certified there
        headroom = np.maximum(effort - holding_torque(self), 1e-6 * effort)
        inputs = tuple(replace(signal, limit=float(h)) for signal, h in zip(plant.inputs, headroom))
        return replace(plant, inputs=inputs)

    def _plant(self) -> UncertainPlant:
        return arm_uncertain_plant(self.arm, self.reference, self.payload_mass, payload_rate=self.payload_rate,
                                   payload_nominal=self.payload_nominal, feedforward=self.feedforward,
                                   n_times=self.n_times, n_masses=self.n_masses, name=self.name, prefix=self.prefix,
                                   design_plant=self.design_plant,
                                   payload_measurement_error=self.payload_measurement_error,
                                   payload_measurement_delay=self.payload_measurement_delay)

    def tau_ff(self, t: float) -> Array:
        """The loop's feedforward at time `t` (s), N·m, shape (n,)."""
        r, rd, rdd = self.reference.at(t)
        return self.arm.feedforward(self.feedforward, r, rd, rdd, self.payload_nominal)


#: (reference times over one period, payloads) on which an arm's drift is bounded.
ARM_DRIFT_GRID = (361, 9)


def arm_perturbed_samples(setup: ArmSetup, *, disturbance: float | None = None,
                          grid: tuple[int, int] = (19, 5)) -> PerturbedSamples:
    """The arm's sampled plants (design form) with the perturbation of Eq. (4) as bounded channels.

    Channels ``T_d,j`` (N·m, one per joint: the disturbance torque, through each sample's
    input matrix) and ``f̄_j`` (rad/s², into the rows of ``ė``): the drift
    ``f̄ = r̈ − q̈(r, ṙ, τ_ff, m_p)`` the model feedforward at the nominal payload leaves at
    ``e = ė = 0`` with no feedback (Pinocchio's ABA), bounded on :data:`ARM_DRIFT_GRID` of
    the reference's period and the payload range.

    Parameters
    ----------
    setup : ArmSetup
    disturbance : float, optional
        Bound on every joint's disturbance torque, N·m (>= 0; default the file's
        ``[disturbance]``, amplitude times each joint's scale; none: 0).
    grid : (int, int)
        (reference times, payloads) of the samples.

    Returns
    -------
    PerturbedSamples
        n = 3 × joints states, q = 2 × joints channels.
    """
    arm, reference = setup.arm, setup.reference
    n = arm.n_joints
    if disturbance is None:
        wave = setup.disturbance
        d_bound = np.zeros(n) if wave is None else wave.amplitude * np.abs(np.asarray(wave.signs, dtype=float))
    else:
        d_bound = np.full(n, check_real("disturbance", disturbance, nonnegative=True))
    samples = setup.plant.samples({"t_ref": check_int("grid[0]", grid[0], 1), "m_p": check_int("grid[1]", grid[1], 1)})
    lo, hi = setup.payload_mass
    times = np.linspace(0.0, reference.period, ARM_DRIFT_GRID[0])
    masses = np.linspace(lo, hi, ARM_DRIFT_GRID[1])
    r, rd, rdd = reference.sample(times)
    drift = np.zeros(n)
    for k in range(times.size):
        tau = arm.feedforward(setup.feedforward, r[k], rd[k], rdd[k], setup.payload_nominal)
        for m in masses:
            drift = np.maximum(drift, np.abs(rdd[k] - arm.forward_dynamics(r[k], rd[k], tau, float(m))))
    A, B = samples.A, samples.B
    Bw = np.zeros((A.shape[0], 3 * n, 2 * n))
    Bw[:, :, :n] = B
    Bw[:, 2 * n:, n:] = np.eye(n)
    w_bound = np.maximum(np.r_[d_bound, drift], NEGLIGIBLE_BOUND)
    joints = arm.joints
    return PerturbedSamples(A, B, Bw, w_bound, tuple(f"T_d,{j}" for j in joints) + tuple(f"fbar,{j}" for j in joints),
                            ("N·m",) * n + ("rad/s²",) * n,
                            f"{grid[0]} reference times x {grid[1]} payloads, |T_d| <= {np.array2string(d_bound)} N·m",
                            integral_drift(setup, times))


#: Step of the central difference of the drift torque along the reference, as a fraction of its period.
DRIFT_RATE_STEP = 1e-6


def integral_drift(setup: ArmSetup, times: Array) -> IntegralDrift | None:
    """The drift as the torque ``τ_r = M r̈ + C ṙ + G − τ_ff`` a PID's integral absorbs.

    ``τ_r`` is affine in the payload (RNEA is linear in the inertial parameters), so its
    rate ``τ̇_r = ∂τ_r/∂t + ṁ_p ∂τ_r/∂m_p`` is bounded by its time derivative (a central
    difference of :data:`DRIFT_RATE_STEP` periods) at the payload's two ends plus
    ``|ṁ_p|``'s bound times the per-kilogram term, at `times`.

    Parameters
    ----------
    setup : ArmSetup
    times : ndarray, shape (k,)
        Reference times of the bound, s.

    Returns
    -------
    IntegralDrift or None
        None when the payload may jump (the file gives no ``payload_rate`` and the range
        is not a single mass).
    """
    arm, reference = setup.arm, setup.reference
    lo, hi = setup.payload_mass
    if setup.payload_rate is None and hi > lo:
        return None
    rate_bound = 0.0 if hi == lo else float(setup.payload_rate or 0.0)
    h = DRIFT_RATE_STEP * reference.period

    def residual(t: Array, m: float) -> tuple[Array, Array]:
        r, rd, rdd = reference.sample(t)
        tau_id = np.array([arm.inverse_dynamics(r[k], rd[k], rdd[k], m) for k in range(t.size)])
        tau_ff = np.array([arm.feedforward(setup.feedforward, r[k], rd[k], rdd[k], setup.payload_nominal)
                           for k in range(t.size)])
        return tau_id - tau_ff, tau_id

    ends = {}
    for m in (lo, hi):
        now, tau_id = residual(times, m)
        slope = (residual(times + h, m)[0] - residual(times - h, m)[0]) / (2 * h)
        ends[m] = (now, tau_id, slope)
    per_kg = (ends[hi][0] - ends[lo][0]) / (hi - lo) if hi > lo else np.zeros_like(ends[lo][0])
    rate = np.max(np.maximum(np.abs(ends[lo][2]), np.abs(ends[hi][2])) + rate_bound * np.abs(per_kg), axis=0)
    torque = np.max(np.maximum(np.abs(ends[lo][1]), np.abs(ends[hi][1])), axis=0)
    initial = np.array([residual(np.array([0.0]), m)[0][0] for m in (lo, hi)])
    n = arm.n_joints
    return IntegralDrift(tuple(range(n, 2 * n)), rate, initial, torque,
                         f"{times.size} reference times x the payload's ends, |ṁ_p| <= {rate_bound:g} kg/s")
