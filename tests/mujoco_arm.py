"""An independent simulator for the arm tests: the URDF arm in MuJoCo under the same PID and payload.

Written without Pinocchio or the package's code: the URDF is read by MuJoCo (locked joints
rewritten as fixed joints at their positions, static links kept as bodies), the payload is
a body welded to its frame whose mass and inertia are written into the model at every
evaluation, the feedforward comes from ``mj_inverse`` at the nominal payload, and the
closed loop ``(q, q̇, ∫e)`` is integrated by scipy's Radau (the arms' PID loops are stiff)
or by RK4 with a fixed step.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Sequence

import mujoco
import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation


def _vec(el: ET.Element | None, attr: str, default: str) -> np.ndarray:
    return np.array((el.get(attr, default) if el is not None else default).split(), float)


def _build_model(urdf_path: str, joints: Sequence[str], locked: dict[str, float],
                 payload_frame: str, payload_com: Sequence[float]) -> mujoco.MjModel:
    """Load the URDF with every joint not in `joints` made fixed at its locked position,
    and a payload body welded to `payload_frame` (no static-body fusion)."""
    root = ET.parse(urdf_path).getroot()
    for jel in root.findall("joint"):
        name, jtype = jel.get("name"), jel.get("type")
        if name in joints or jtype == "fixed":
            continue
        if jtype not in ("revolute", "continuous", "prismatic"):
            raise ValueError(f"cannot lock joint {name} of type {jtype}")
        val = float(locked.get(name, 0.0))
        org = jel.find("origin")
        if org is None:
            org = ET.SubElement(jel, "origin")
        xyz, rpy = _vec(org, "xyz", "0 0 0"), _vec(org, "rpy", "0 0 0")
        axis = _vec(jel.find("axis"), "xyz", "1 0 0")
        axis = axis / np.linalg.norm(axis)
        R = Rotation.from_euler("xyz", rpy)  # URDF rpy: R = Rz(y) Ry(p) Rx(r)
        if jtype == "prismatic":  # child frame = origin * Trans(axis * val)
            xyz = xyz + R.apply(axis * val)
        else:  # child frame = origin * Rot(axis, val)
            rpy = (R * Rotation.from_rotvec(axis * val)).as_euler("xyz")
        org.set("xyz", " ".join(repr(float(v)) for v in xyz))
        org.set("rpy", " ".join(repr(float(v)) for v in rpy))
        jel.set("type", "fixed")
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.compiler.fusestatic = False  # keep fixed-jointed links (payload_frame) as bodies
    spec.body(payload_frame).add_body(
        name="payload", ipos=list(map(float, payload_com)), iquat=[1, 0, 0, 0],
        mass=1.0, inertia=[1.0, 1.0, 1.0], explicitinertial=True)  # values reset at run time
    model = spec.compile()
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)  # no contacts/limits
    assert not (model.dof_armature.any() or model.dof_damping.any()
                or model.dof_frictionloss.any() or model.jnt_stiffness.any())
    assert model.nq == model.nv == len(joints)
    return model


def simulate_mujoco(urdf_path: str, joints: Sequence[str], locked: dict[str, float],
                    payload_frame: str, payload_com: Sequence[float],
                    payload_inertia_per_kg: Sequence[float], gravity: bool, K: np.ndarray,
                    center: Sequence[float], amplitude: Sequence[float],
                    omega: Sequence[float], phase: Sequence[float],
                    payload_mass: Callable[[float], float], nominal_mass: float,
                    feedforward: str, t_final: float, dt: float,
                    e0: Sequence[float] | None = None, edot0: Sequence[float] | None = None,
                    method: str = "rk4", stride: int = 1, rtol: float = 1e-10,
                    armature: Sequence[float] | None = None) -> dict[str, np.ndarray]:
    """Simulate a URDF arm with MuJoCo under tau = tau_ff(t) - K [z; e; edot], z = int e dt.

    Parameters
    ----------
    urdf_path : str
        URDF file.
    joints : sequence of str
        Controlled joint names (n), in the order of all inputs/outputs.
    locked : dict of str to float
        Joints held rigid at the given position (rad or m); other uncontrolled joints at 0.
    payload_frame : str
        URDF link the payload is welded to.
    payload_com : sequence of 3 float
        Payload centre of mass in `payload_frame` (m).
    payload_inertia_per_kg : sequence of 3 float
        Diagonal of the inertia about the COM per kg of payload, frame axes (m^2).
    gravity : bool
        If true, g = 9.81 m/s^2 along -z of the base, else no gravity.
    K : ndarray, shape (n, 3n)
        PID gain acting on [z; e; edot].
    center, amplitude, omega, phase : sequence of n float
        Reference r_i(t) = center_i + amplitude_i sin(omega_i t + phase_i).
    payload_mass : callable
        Payload mass (kg) as a function of time t (s); may be 0.
    nominal_mass : float
        Payload mass used in the feedforward model (kg).
    feedforward : {'none', 'gravity', 'computed-torque'}
        tau_ff = 0, G(r), or M(r) rdd + C(r, rd) rd + G(r), all at `nominal_mass`.
    t_final, dt : float
        End time and integration step (s).
    e0, edot0 : sequence of n float, optional
        Initial errors: q(0) = r(0) - e0, qdot(0) = rdot(0) - edot0 (default zero).
    method : {'rk4', 'radau', 'mj_step'}, optional
        'rk4' (default): classical RK4 of the continuous closed loop (q, qdot, z); MuJoCo
        (mj_forward) gives the accelerations and the torque is re-evaluated at every stage.
        Explicit: stable only for dt below about 2.8 / (largest eigenvalue of M^-1 Kd).
        'radau': scipy's adaptive implicit Radau IIA (order 5) on the same closed loop, for
        stiff cases (large Kd on light links); tolerance `rtol`, absolute 1e-3 * rtol;
        `dt` is then only the output grid.
        'mj_step': MuJoCo's own RK4 integrator with the torque and payload mass held over
        each step (zero-order hold) and z integrated by the trapezoidal rule; first order.
    stride : int, optional
        Keep every `stride`-th sample in the output.
    rtol : float, optional
        Relative tolerance of the 'radau' method.
    armature : sequence of n float, optional
        Reflected rotor inertia of each controlled joint, kg·m² (MuJoCo's joint armature).

    Returns
    -------
    dict
        't' (k,), and 'q', 'e', 'tau' (n, k): positions, errors r - q, joint torques.
    """
    model = _build_model(urdf_path, joints, locked, payload_frame, payload_com)
    data, data_ff = mujoco.MjData(model), mujoco.MjData(model)
    model.opt.gravity[:] = [0.0, 0.0, -9.81 if gravity else 0.0]
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    model.opt.timestep = dt
    pid = model.body("payload").id
    ipk = np.asarray(payload_inertia_per_kg, float)
    qa = np.array([model.jnt_qposadr[model.joint(j).id] for j in joints])
    da = np.array([model.jnt_dofadr[model.joint(j).id] for j in joints])
    if armature is not None:
        model.dof_armature[da] = np.asarray(armature, float)
    K = np.asarray(K, float)
    c, a, w, ph = (np.asarray(v, float) for v in (center, amplitude, omega, phase))
    n = len(joints)

    def set_mass(mass: float) -> None:  # zero mass/inertia is accepted at run time
        model.body_mass[pid] = mass
        model.body_inertia[pid] = mass * ipk

    def ref(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, co = np.sin(w * t + ph), np.cos(w * t + ph)
        return c + a * s, a * w * co, -a * w * w * s

    def torque(t: float, q: np.ndarray, qd: np.ndarray, z: np.ndarray):
        r, rd, rdd = ref(t)
        e, ed = r - q, rd - qd
        tau = -K @ np.concatenate([z, e, ed])
        if feedforward != "none":
            ct = feedforward == "computed-torque"
            if not ct and feedforward != "gravity":
                raise ValueError(feedforward)
            set_mass(nominal_mass)
            data_ff.qpos[qa], data_ff.qvel[da], data_ff.qacc[da] = r, rd * ct, rdd * ct
            mujoco.mj_inverse(model, data_ff)
            tau = tau + data_ff.qfrc_inverse[da]
        set_mass(payload_mass(t))  # actual mass for the forward dynamics
        return tau, e

    def deriv(t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, z = x[:n], x[n:2 * n], x[2 * n:]
        tau, e = torque(t, q, qd, z)
        data.qpos[qa], data.qvel[da], data.qfrc_applied[da] = q, qd, tau
        mujoco.mj_forward(model, data)
        return np.concatenate([qd, data.qacc[da], e]), tau, e

    nsteps = int(round(t_final / dt))
    r0, rd0, _ = ref(0.0)
    x = np.concatenate([r0 - (np.zeros(n) if e0 is None else np.asarray(e0, float)),
                        rd0 - (np.zeros(n) if edot0 is None else np.asarray(edot0, float)),
                        np.zeros(n)])
    t_out = np.arange(0, nsteps + 1, stride) * dt
    if method == "radau":
        sol = solve_ivp(lambda t, y: deriv(t, y)[0], (0.0, t_out[-1]), x, method="Radau",
                        t_eval=t_out, rtol=rtol, atol=1e-3 * rtol)
        if not sol.success:
            raise RuntimeError(sol.message)
        states = iter(sol.y.T)
    elif method in ("rk4", "mj_step"):
        states = _fixed_step(x, deriv, ref, model, data, qa, da, dt, nsteps, stride, method)
    else:
        raise ValueError(method)
    out = {"t": t_out, **{k: np.empty((n, t_out.size)) for k in ("q", "e", "tau")}}
    for j, (t, y) in enumerate(zip(t_out, states)):
        _, tau, e = deriv(t, y)  # torque and error of the continuous law at the sample
        out["q"][:, j], out["e"][:, j], out["tau"][:, j] = y[:n], e, tau
    return out


def _fixed_step(x: np.ndarray, deriv: Callable, ref: Callable, model: mujoco.MjModel,
                data: mujoco.MjData, qa: np.ndarray, da: np.ndarray, dt: float, nsteps: int,
                stride: int, method: str) -> Iterator[np.ndarray]:
    """Yield the state (q, qdot, z) every `stride` steps of a fixed-step integration."""
    n = len(qa)
    for k in range(nsteps + 1):
        t = k * dt
        if k % stride == 0:
            yield x
        if k == nsteps:
            return
        k1, _, e = deriv(t, x)  # also loads state, torque and mass into `data`
        if method == "rk4":
            k2 = deriv(t + dt / 2, x + dt / 2 * k1)[0]
            k3 = deriv(t + dt / 2, x + dt / 2 * k2)[0]
            k4 = deriv(t + dt, x + dt * k3)[0]
            x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        else:  # mj_step: torque and mass from deriv(t, x) held over the step
            data.time = t
            mujoco.mj_step(model, data)
            q1, qd1 = data.qpos[qa].copy(), data.qvel[da].copy()
            x = np.concatenate([q1, qd1, x[2 * n:] + dt / 2 * (e + ref(t + dt)[0] - q1)])
