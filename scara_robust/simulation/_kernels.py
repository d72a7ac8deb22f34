"""Machine-code kernels of the compiled engines (numba); imported only when such an engine runs.

Two models, one set of integrators. The SCARA's closed loop (see
:mod:`scara_robust.simulation.compiled`) is a packed parameter vector θ, whose layout is
defined there and repeated here as constants; a URDF arm's (see
:mod:`scara_robust.simulation.compiled_arm`) is a tuple of arrays read from its rigid bodies,
run by the recursive algorithms below (RNEA, CRBA and a Cholesky solve). The integrators
(Dormand–Prince 5(4), scipy's BDF, RK4 of a sampled law) see a model only through the
hooks ``model_*``: numba picks each hook's implementation from the model's type (an array:
the SCARA; a tuple: an arm) when it compiles an integrator for that type, so each model's
integrators are compiled and cached on disk for it alone. The hooks and the arm's recursive
algorithms are calls, which LLVM inlines where it pays; numba's own inlining (``inline='always'``,
for the small SCARA kernels) copies a callee's IR into each call site before typing it: on the
hooks it makes a first compilation three times longer (the SCARA's kernels 150 s against 48 s on
one core, the runs equal bit for bit, their speed the same within the benchmarks' noise).

All kernels sit in this one file on purpose: numba's disk cache notices a change of the
file that defines a function, not of the files its callees come from.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np
from numba import types
from numba.extending import overload
from numpy.typing import NDArray

from .loop import STATE_LIMIT

__all__ = ["run", "refine", "batch", "torque", "rhs", "segment", "arm_mass_matrix", "arm_inverse_dynamics",
           "arm_forward_dynamics", "arm_torque", "arm_rhs"]

Array = NDArray[np.float64]

_ROBOT, _PAYLOAD, _REF, _DIST, _KIND, _K, _SMC, _SMC_ROBOT, _LIMIT, _TS = 0, 9, 13, 15, 20, 21, 33, 37, 46, 48
_COMPLETED, _DIVERGED, _FAILED = 0, 1, 2

jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: Small kernels are inlined into the integrator's stages.
inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@inline
def mass_terms(rb: Array, off: int, c2: float, s2: float, w1: float, w2: float,
               mp: float) -> tuple[float, float, float, float, float]:
    """M11, M12, M22 (kg·m²) and C1, C2 (N·m) of robot parameters rb[off:off+9], from cos q2 and sin q2."""
    m1, m2, L1, L2, Lc1, Lc2, I1, I2, cp = (rb[off], rb[off + 1], rb[off + 2], rb[off + 3], rb[off + 4],
                                            rb[off + 5], rb[off + 6], rb[off + 7], rb[off + 8])
    a1 = m1 * Lc1**2 + (m2 + mp) * L1**2 + I1
    a2 = m2 * Lc2**2 + mp * L2**2 + I2 + cp * mp
    a3 = L1 * (m2 * Lc2 + mp * L2)
    return a1 + a2 + 2 * a3 * c2, a2 + a3 * c2, a2, -a3 * (2 * w1 * w2 + w2 * w2) * s2, a3 * w1 * w1 * s2


@inline
def payload(th: Array, t: float) -> float:
    if th[_PAYLOAD + 1] == 0.0:  # a constant payload: the same number without the sine
        return float(th[_PAYLOAD])
    return float(th[_PAYLOAD] + th[_PAYLOAD + 1] * math.sin(th[_PAYLOAD + 2] * t + th[_PAYLOAD + 3]))


@inline
def disturbance_level(th: Array, t: float) -> float:
    frac = t / th[_DIST + 1] + th[_DIST + 2] / (2 * math.pi)
    frac = frac - math.floor(frac)
    return 1.0 if frac < 0.5 else -1.0


# The kernels below take sin ωt, cos ωt (reference) and cos q2, sin q2 from their caller, so
# one right-hand side evaluates each sine once: these calls are most of its cost.
@inline
def torque_sc(th: Array, sw: float, cw: float, c2: float, s2: float, x: Array, out: Array) -> None:
    a, w = th[_REF], th[_REF + 1]
    r1, r2 = a * sw, a * cw
    v1, v2 = a * w * cw, -a * w * sw
    e1, e2 = r1 - x[0], r2 - x[1]
    d1, d2 = v1 - x[2], v2 - x[3]
    kind = th[_KIND]
    if kind == 0:
        k = th[_K:_K + 12]
        u1 = -(k[0] * x[4] + k[1] * x[5] + k[2] * e1 + k[3] * e2 + k[4] * d1 + k[5] * d2)
        u2 = -(k[6] * x[4] + k[7] * x[5] + k[8] * e1 + k[9] * e2 + k[10] * d1 + k[11] * d2)
    else:
        lam, kd, ks, phi = th[_SMC], th[_SMC + 1], th[_SMC + 2], th[_SMC + 3]
        s1, s2_ = d1 + lam * e1, d2 + lam * e2
        acc1, acc2 = -w * w * r1 + lam * d1, -w * w * r2 + lam * d2
        m11, m12, m22, c1, c2_ = mass_terms(th, _SMC_ROBOT, c2, s2, x[2], x[3], 0.0)
        if kind == 1:
            g1 = min(max(s1 / phi, -1.0), 1.0)
            g2 = min(max(s2_ / phi, -1.0), 1.0)
        else:
            g1 = (s1 > 0) - (s1 < 0) * 1.0
            g2 = (s2_ > 0) - (s2_ < 0) * 1.0
        u1 = m11 * acc1 + m12 * acc2 + c1 + kd * s1 + ks * g1
        u2 = m12 * acc1 + m22 * acc2 + c2_ + kd * s2_ + ks * g2
    lim1, lim2 = th[_LIMIT], th[_LIMIT + 1]
    out[0] = min(max(u1, -lim1), lim1)
    out[1] = min(max(u2, -lim2), lim2)


@inline
def torque(th: Array, t: float, x: Array, out: Array) -> None:
    w = th[_REF + 1]
    torque_sc(th, math.sin(w * t), math.cos(w * t), math.cos(x[1]), math.sin(x[1]), x, out)


@inline
def rhs_sc(th: Array, t: float, sw: float, cw: float, c2: float, s2: float, x: Array, tc: Array, td: float,
           dx: Array) -> None:
    n = x.shape[0]
    big = 0.0
    for i in range(4):
        v = abs(x[i])
        if not v <= STATE_LIMIT:
            big = np.inf
    if big > 0:
        for i in range(n):
            dx[i] = 0.0
        return
    m11, m12, m22, c1, c2_ = mass_terms(th, _ROBOT, c2, s2, x[2], x[3], payload(th, t))
    b1 = tc[0] + td * th[_DIST + 3] - c1
    b2 = tc[1] + td * th[_DIST + 4] - c2_
    det = m11 * m22 - m12 * m12
    dx[0] = x[2]
    dx[1] = x[3]
    dx[2] = (m22 * b1 - m12 * b2) / det
    dx[3] = (m11 * b2 - m12 * b1) / det
    if n > 4:
        a = th[_REF]
        dx[4] = a * sw - x[0]
        dx[5] = a * cw - x[1]


@inline
def rhs(th: Array, t: float, x: Array, tc: Array, td: float, dx: Array) -> None:
    sw = cw = 0.0
    if x.shape[0] > 4:
        w = th[_REF + 1]
        sw, cw = math.sin(w * t), math.cos(w * t)
    rhs_sc(th, t, sw, cw, math.cos(x[1]), math.sin(x[1]), x, tc, td, dx)


@inline
def closed_rhs(th: Array, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    w = th[_REF + 1]
    sw, cw = math.sin(w * t), math.cos(w * t)
    c2, s2 = math.cos(x[1]), math.sin(x[1])
    torque_sc(th, sw, cw, c2, s2, x, tc)
    rhs_sc(th, t, sw, cw, c2, s2, x, tc, td, dx)

@inline
def disturbance(th: Array, t: float) -> float:
    """The square wave's torque before the joint signs at `t`, N·m."""
    return float(th[_DIST] * disturbance_level(th, t))


@inline
def output(th: Array, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> None:
    """Sample j: torque TC[:, j] (N·m) and errors ER[:, j] = (r - q, ṙ - q̇) (rad, rad/s) at state x."""
    a, w = th[_REF], th[_REF + 1]
    sw, cw = math.sin(w * t), math.cos(w * t)
    torque_sc(th, sw, cw, math.cos(x[1]), math.sin(x[1]), x, tc)
    TC[0, j], TC[1, j] = tc[0], tc[1]
    ER[0, j] = a * sw - x[0]
    ER[1, j] = a * cw - x[1]
    ER[2, j] = a * w * cw - x[2]
    ER[3, j] = -a * w * sw - x[3]

# --- a URDF arm: the recursive algorithms over its rigid bodies ---------------------------------
# An arm's model is a tuple of arrays (built by compiled_arm.pack_arm_loop), bodies in the model's
# order (parents first), vectors of the arm's joints in its own (file) order:
#   0 P     float (18,): gravity (3, m/s²); payload kind and 4 numbers; disturbance amplitude
#           (N·m), period (s), phase (rad); feedforward kind (0 none, 1 gravity, 2 computed
#           torque); the nominal payload (kg); the sample time (s, 0: continuous); the
#           torque limit (N·m, inf: none); 1 when the angles are measured with noise; 1 when
#           the gain is scheduled (SCHED); the payload measurement's bias (kg)
#   1 IX    int (2 + 2n,): n; the payload's body; each body's parent (-1: the base); each
#           joint's body
#   2 TREE  float (n, 16): joint placement rotation (9, row-major) and translation (3, m) in
#           the parent's frame, axis (3), armature (kg·m²)
#   3 BODY  float (n + 1, 13): mass (kg), first moment m·c (3, kg·m) and inertia about the
#           joint frame's origin (9, kg·m²); the last row is the payload per kg
#   4 REF   float (6, n): the reference's centre, amplitude (rad), ω (rad/s), phase (rad);
#           the disturbance's sign per joint; each joint's torque limit (N·m, inf: none; the
#           smaller of it and P's limit applies)
#   5 GAIN  float (n, 3n): the PID gain on [∫e, e, ė]
#   6 TAB   float (2, k): times (s) and masses (kg) of a tabulated payload
#   7 WB    float (n, 40) scratch per body: rotation to the parent's frame (9), velocity (6),
#           acceleration (6), force (6), inertia (13); spatial vectors linear part first
#   8 WM    float (n, n) scratch: the mass matrix, then its Cholesky factor
#   9 WS    float (11, n) scratch: q, q̇, q̈, RNEA's τ, the applied τ (body order);
#           the feedforward, r, ṙ, r̈, the angle noise n and its rate ṅ (joint order)
#  10 WC    float (2,): the time the reference rows of WS hold, and its payload mass
#  11 NOISE float (n, 3M): the measurement noise's M amplitudes (rad), ω (rad/s) and
#           phases (rad) per joint, n_k(t) = Σ a cos(ω t + φ)
#  12 SCHED float (N + 1, 1 + 3n²): a gain scheduled on the measured payload, one row per
#           breakpoint: the breakpoint (kg), then K_j (n, 3n) row-major; GAIN holds K(m̂_p(t))
#           with m̂_p = m_p(t) + P[17], linear between breakpoints and clamped to them, when
#           P[16] is 1
_P, _IX, _TREE, _BODY, _REFS, _GAIN, _TAB, _WB, _WM, _WS, _WC, _NOISE, _SCHED = range(13)
_A_GRAVITY, _A_PAYLOAD, _A_DIST, _A_FF, _A_NOMINAL, _A_TS, _A_LIMIT, _A_NOISY = 0, 3, 8, 11, 12, 13, 14, 15
_A_SCHEDULED, _A_BIAS = 16, 17
_W_ROT, _W_V, _W_A, _W_F, _W_I = 0, 9, 15, 21, 27
_S_Q, _S_QD, _S_QDD, _S_TAU, _S_APPLIED, _S_FF, _S_R, _S_RD, _S_RDD, _S_N, _S_ND = range(11)


@inline
def cross(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@inline
def vec3(A: Array, i: int, o: int) -> tuple[float, float, float]:
    return (A[i, o], A[i, o + 1], A[i, o + 2])


@inline
def rotate(W: Array, i: int, v: tuple[float, float, float]) -> tuple[float, float, float]:
    """R v with R the row-major rotation W[i, 0:9]."""
    return (W[i, 0] * v[0] + W[i, 1] * v[1] + W[i, 2] * v[2], W[i, 3] * v[0] + W[i, 4] * v[1] + W[i, 5] * v[2],
            W[i, 6] * v[0] + W[i, 7] * v[1] + W[i, 8] * v[2])


@inline
def rotate_back(W: Array, i: int, v: tuple[float, float, float]) -> tuple[float, float, float]:
    """Rᵀ v with R the row-major rotation W[i, 0:9]."""
    return (W[i, 0] * v[0] + W[i, 3] * v[1] + W[i, 6] * v[2], W[i, 1] * v[0] + W[i, 4] * v[1] + W[i, 7] * v[2],
            W[i, 2] * v[0] + W[i, 5] * v[1] + W[i, 8] * v[2])


@inline
def inertia_times(W: Array, i: int, v: tuple[float, float, float],
                  w: tuple[float, float, float]) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The momentum (linear, angular about the origin) of body i's inertia W[i, 27:40] moving at (v, ω)."""
    o = _W_I
    m = W[i, o]
    h = (W[i, o + 1], W[i, o + 2], W[i, o + 3])
    hw = cross(h, w)
    hv = cross(h, v)
    lin = (m * v[0] - hw[0], m * v[1] - hw[1], m * v[2] - hw[2])
    ang = (W[i, o + 4] * w[0] + W[i, o + 5] * w[1] + W[i, o + 6] * w[2] + hv[0],
           W[i, o + 7] * w[0] + W[i, o + 8] * w[1] + W[i, o + 9] * w[2] + hv[1],
           W[i, o + 10] * w[0] + W[i, o + 11] * w[1] + W[i, o + 12] * w[2] + hv[2])
    return lin, ang


@inline
def arm_payload(P: Array, TAB: Array, t: float) -> float:
    """m_p(t), kg: constant a; a + b sin(c t + d); a − b cos(2π t / c); min(b, a + c max(t, 0)); the table."""
    kind = P[_A_PAYLOAD]
    a, b, c, d = P[_A_PAYLOAD + 1], P[_A_PAYLOAD + 2], P[_A_PAYLOAD + 3], P[_A_PAYLOAD + 4]
    if kind == 0:
        return float(a)
    if kind == 1:
        return float(a + b * math.sin(c * t + d))
    if kind == 2:
        return float(a - b * math.cos(2 * math.pi * t / c))
    if kind == 3:
        return float(min(b, a + c * max(t, 0.0)))
    return float(np.interp(t, TAB[0], TAB[1]))


@jit
def arm_positions(m: Any, q: Array) -> None:
    """Each body's rotation to its parent's frame at joint angles q (body order, rad), into WB[:, 0:9]."""
    IX, TREE, WB = m[_IX], m[_TREE], m[_WB]
    for i in range(IX[0]):
        c, s = math.cos(q[i]), math.sin(q[i])
        ax, ay, az = TREE[i, 12], TREE[i, 13], TREE[i, 14]
        k = 1.0 - c  # Rodrigues: c I + s [a]x + (1 - c) a aᵀ
        j00, j01, j02 = c + k * ax * ax, k * ax * ay - s * az, k * ax * az + s * ay
        j10, j11, j12 = k * ay * ax + s * az, c + k * ay * ay, k * ay * az - s * ax
        j20, j21, j22 = k * az * ax - s * ay, k * az * ay + s * ax, c + k * az * az
        for r in range(3):
            p0, p1, p2 = TREE[i, 3 * r], TREE[i, 3 * r + 1], TREE[i, 3 * r + 2]
            WB[i, 3 * r] = p0 * j00 + p1 * j10 + p2 * j20
            WB[i, 3 * r + 1] = p0 * j01 + p1 * j11 + p2 * j21
            WB[i, 3 * r + 2] = p0 * j02 + p1 * j12 + p2 * j22


@jit
def arm_inertias(m: Any, mp: float) -> None:
    """Each body's inertia into WB[:, 27:40], the payload of mp kg on its body."""
    IX, BODY, WB = m[_IX], m[_BODY], m[_WB]
    n, carrier = IX[0], IX[1]
    for i in range(n):
        for k in range(13):
            WB[i, _W_I + k] = BODY[i, k]
    for k in range(13):
        WB[carrier, _W_I + k] += mp * BODY[n, k]


@jit
def arm_rnea(m: Any) -> None:
    """RNEA: the torques τ = M(q) q̈ + C(q, q̇) q̇ + G(q) (WS row 3) of q, q̇, q̈ (WS rows 0-2), body order.

    The positions (:func:`arm_positions`) and inertias (:func:`arm_inertias`) must be set.
    """
    P, IX, TREE, WB, WS = m[_P], m[_IX], m[_TREE], m[_WB], m[_WS]
    n = IX[0]
    for i in range(n):
        par = IX[2 + i]
        if par < 0:
            vp, wp = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
            alp, awp = (-P[_A_GRAVITY], -P[_A_GRAVITY + 1], -P[_A_GRAVITY + 2]), (0.0, 0.0, 0.0)
        else:
            vp, wp = vec3(WB, par, _W_V), vec3(WB, par, _W_V + 3)
            alp, awp = vec3(WB, par, _W_A), vec3(WB, par, _W_A + 3)
        p = vec3(TREE, i, 9)
        qd, qdd = WS[_S_QD, i], WS[_S_QDD, i]
        sq = (TREE[i, 12] * qd, TREE[i, 13] * qd, TREE[i, 14] * qd)
        pw = cross(p, wp)
        v = rotate_back(WB, i, (vp[0] - pw[0], vp[1] - pw[1], vp[2] - pw[2]))
        w0 = rotate_back(WB, i, wp)
        w = (w0[0] + sq[0], w0[1] + sq[1], w0[2] + sq[2])
        pa = cross(p, awp)
        al0 = rotate_back(WB, i, (alp[0] - pa[0], alp[1] - pa[1], alp[2] - pa[2]))
        aw0 = rotate_back(WB, i, awp)
        vs, ws = cross(v, sq), cross(w, sq)
        al = (al0[0] + vs[0], al0[1] + vs[1], al0[2] + vs[2])
        aw = (aw0[0] + TREE[i, 12] * qdd + ws[0], aw0[1] + TREE[i, 13] * qdd + ws[1],
              aw0[2] + TREE[i, 14] * qdd + ws[2])
        il, ia = inertia_times(WB, i, v, w)
        fl, fa = inertia_times(WB, i, al, aw)
        c1, c2, c3 = cross(w, il), cross(w, ia), cross(v, il)
        for k in range(3):
            WB[i, _W_V + k], WB[i, _W_V + 3 + k] = v[k], w[k]
            WB[i, _W_A + k], WB[i, _W_A + 3 + k] = al[k], aw[k]
            WB[i, _W_F + k] = fl[k] + c1[k]
            WB[i, _W_F + 3 + k] = fa[k] + c2[k] + c3[k]
    for i in range(n - 1, -1, -1):
        WS[_S_TAU, i] = (TREE[i, 12] * WB[i, _W_F + 3] + TREE[i, 13] * WB[i, _W_F + 4] + TREE[i, 14] * WB[i, _W_F + 5]
                         + TREE[i, 15] * WS[_S_QDD, i])
        par = IX[2 + i]
        if par >= 0:
            fl = rotate(WB, i, vec3(WB, i, _W_F))
            fa = rotate(WB, i, vec3(WB, i, _W_F + 3))
            pf = cross(vec3(TREE, i, 9), fl)
            for k in range(3):
                WB[par, _W_F + k] += fl[k]
                WB[par, _W_F + 3 + k] += fa[k] + pf[k]


@jit
def arm_crba(m: Any) -> None:
    """CRBA: the mass matrix M(q) with the armature, body order, into WM (all of it).

    The positions and inertias must be set; the inertias are left as the composite ones.
    """
    IX, TREE, WB, WM = m[_IX], m[_TREE], m[_WB], m[_WM]
    n = IX[0]
    for i in range(n):
        for j in range(n):
            WM[i, j] = 0.0
    o = _W_I
    for i in range(n - 1, -1, -1):
        ax = vec3(TREE, i, 12)
        fl = cross(ax, vec3(WB, i, o + 1))  # the composite inertia times the joint's unit motion (0, a)
        fa = (WB[i, o + 4] * ax[0] + WB[i, o + 5] * ax[1] + WB[i, o + 6] * ax[2],
              WB[i, o + 7] * ax[0] + WB[i, o + 8] * ax[1] + WB[i, o + 9] * ax[2],
              WB[i, o + 10] * ax[0] + WB[i, o + 11] * ax[1] + WB[i, o + 12] * ax[2])
        WM[i, i] = ax[0] * fa[0] + ax[1] * fa[1] + ax[2] * fa[2] + TREE[i, 15]
        j = i
        while IX[2 + j] >= 0:
            fl = rotate(WB, j, fl)
            fa0 = rotate(WB, j, fa)
            pf = cross(vec3(TREE, j, 9), fl)
            fa = (fa0[0] + pf[0], fa0[1] + pf[1], fa0[2] + pf[2])
            j = IX[2 + j]
            value = TREE[j, 12] * fa[0] + TREE[j, 13] * fa[1] + TREE[j, 14] * fa[2]
            WM[j, i] = value
            WM[i, j] = value
        par = IX[2 + i]
        if par >= 0:
            # the inertia (m, h, I_o) seen from the parent's frame: h' = R h + m p,
            # I' = R I Rᵀ − (p yᵀ + y pᵀ) + 2 (y·p) 1 − m (p pᵀ − |p|² 1), y = R h
            mass = WB[i, o]
            p = vec3(TREE, i, 9)
            y = rotate(WB, i, vec3(WB, i, o + 1))
            yp = y[0] * p[0] + y[1] * p[1] + y[2] * p[2]
            pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
            WB[par, o] += mass
            for r in range(3):
                WB[par, o + 1 + r] += y[r] + mass * p[r]
            for s in range(3):
                # column s of I Rᵀ, then R times it
                t0 = WB[i, o + 4] * WB[i, 3 * s] + WB[i, o + 5] * WB[i, 3 * s + 1] + WB[i, o + 6] * WB[i, 3 * s + 2]
                t1 = WB[i, o + 7] * WB[i, 3 * s] + WB[i, o + 8] * WB[i, 3 * s + 1] + WB[i, o + 9] * WB[i, 3 * s + 2]
                t2 = WB[i, o + 10] * WB[i, 3 * s] + WB[i, o + 11] * WB[i, 3 * s + 1] + WB[i, o + 12] * WB[i, 3 * s + 2]
                for r in range(3):
                    acc = WB[i, 3 * r] * t0 + WB[i, 3 * r + 1] * t1 + WB[i, 3 * r + 2] * t2
                    acc -= p[r] * y[s] + y[r] * p[s] + mass * p[r] * p[s]
                    if r == s:
                        acc += 2.0 * yp + mass * pp
                    WB[par, o + 4 + 3 * r + s] += acc


@jit
def arm_forward(m: Any, mp: float) -> None:
    """q̈ = M⁻¹(τ − b) (WS row 2) of q, q̇ (rows 0, 1) and the applied τ (row 4), body order, payload mp kg.

    b is RNEA's with q̈ = 0 (Coriolis, centrifugal and gravity); M is CRBA's, solved by
    Cholesky.
    """
    IX, WM, WS = m[_IX], m[_WM], m[_WS]
    n = IX[0]
    arm_positions(m, WS[_S_Q])
    arm_inertias(m, mp)
    for i in range(n):
        WS[_S_QDD, i] = 0.0
    arm_rnea(m)
    arm_crba(m)
    for j in range(n):  # Cholesky: M = L Lᵀ, L in the lower triangle of WM
        acc = WM[j, j]
        for k in range(j):
            acc -= WM[j, k] * WM[j, k]
        d = math.sqrt(acc)
        WM[j, j] = d
        for i in range(j + 1, n):
            acc = WM[i, j]
            for k in range(j):
                acc -= WM[i, k] * WM[j, k]
            WM[i, j] = acc / d
    for i in range(n):
        acc = WS[_S_APPLIED, i] - WS[_S_TAU, i]
        for k in range(i):
            acc -= WM[i, k] * WS[_S_QDD, k]
        WS[_S_QDD, i] = acc / WM[i, i]
    for i in range(n - 1, -1, -1):
        acc = WS[_S_QDD, i]
        for k in range(i + 1, n):
            acc -= WM[k, i] * WS[_S_QDD, k]
        WS[_S_QDD, i] = acc / WM[i, i]


@jit
def arm_mass_matrix(m: Any, q: Array, mp: float, out: Array) -> None:
    """M(q, m_p) (kg·m², with the armature) into out (n, n); q (rad) and out in the arm's joint order."""
    IX, WM, WS = m[_IX], m[_WM], m[_WS]
    n = IX[0]
    for k in range(n):
        WS[_S_Q, IX[2 + n + k]] = q[k]
    arm_positions(m, WS[_S_Q])
    arm_inertias(m, mp)
    arm_crba(m)
    for k in range(n):
        for j in range(n):
            out[k, j] = WM[IX[2 + n + k], IX[2 + n + j]]


@jit
def arm_inverse_dynamics(m: Any, q: Array, v: Array, a: Array, mp: float, out: Array) -> None:
    """RNEA's τ = M q̈ + C q̇ + G (N·m) into out (n,); q, q̇, q̈ (rad, rad/s, rad/s²) in the joint order."""
    IX, WS = m[_IX], m[_WS]
    n = IX[0]
    for k in range(n):
        i = IX[2 + n + k]
        WS[_S_Q, i], WS[_S_QD, i], WS[_S_QDD, i] = q[k], v[k], a[k]
    arm_positions(m, WS[_S_Q])
    arm_inertias(m, mp)
    arm_rnea(m)
    for k in range(n):
        out[k] = WS[_S_TAU, IX[2 + n + k]]


@jit
def arm_forward_dynamics(m: Any, q: Array, v: Array, tau: Array, mp: float, out: Array) -> None:
    """q̈ (rad/s²) into out (n,) at q, q̇ and the joint torques τ (N·m), all in the joint order."""
    IX, WS = m[_IX], m[_WS]
    n = IX[0]
    for k in range(n):
        i = IX[2 + n + k]
        WS[_S_Q, i], WS[_S_QD, i], WS[_S_APPLIED, i] = q[k], v[k], tau[k]
    arm_forward(m, mp)
    for k in range(n):
        out[k] = WS[_S_QDD, IX[2 + n + k]]


@jit
def arm_reference(m: Any, t: float) -> None:
    """r, ṙ, r̈, the feedforward and the noise at t into WS rows 5-10 (joint order), m_p(t) into WC[1].

    They are kept for the next call at the same t (the integrators call the right-hand
    side at one time many times: Newton iterations, Jacobian columns).
    """
    P, IX, REF, WS, WC = m[_P], m[_IX], m[_REFS], m[_WS], m[_WC]
    if WC[0] == t:
        return
    n = IX[0]
    for k in range(n):
        a, w = REF[1, k], REF[2, k]
        angle = w * t + REF[3, k]
        s = math.sin(angle)
        WS[_S_R, k] = REF[0, k] + a * s
        WS[_S_RD, k] = a * w * math.cos(angle)
        WS[_S_RDD, k] = -a * w * w * s
    kind = P[_A_FF]
    if kind == 0:
        for k in range(n):
            WS[_S_FF, k] = 0.0
    else:  # gravity G(r, m₀), or computed torque RNEA(r, ṙ, r̈, m₀)
        full = kind == 2
        for k in range(n):
            i = IX[2 + n + k]
            WS[_S_Q, i] = WS[_S_R, k]
            WS[_S_QD, i] = WS[_S_RD, k] if full else 0.0
            WS[_S_QDD, i] = WS[_S_RDD, k] if full else 0.0
        arm_positions(m, WS[_S_Q])
        arm_inertias(m, P[_A_NOMINAL])
        arm_rnea(m)
        for k in range(n):
            WS[_S_FF, k] = WS[_S_TAU, IX[2 + n + k]]
    if P[_A_NOISY] > 0:
        NZ = m[_NOISE]
        terms = NZ.shape[1] // 3
        for k in range(n):
            v, dv = 0.0, 0.0
            for c in range(terms):
                a, w = NZ[k, c], NZ[k, terms + c]
                angle = w * t + NZ[k, 2 * terms + c]
                v += a * math.cos(angle)
                dv -= a * w * math.sin(angle)
            WS[_S_N, k], WS[_S_ND, k] = v, dv
    WC[1] = arm_payload(P, m[_TAB], t)
    WC[0] = t
    if P[_A_SCHEDULED] > 0:
        arm_schedule(m[_SCHED], WC[1] + P[_A_BIAS], m[_GAIN])


@inline
def arm_schedule(S: Array, p_hat: float, K: Array) -> None:
    """K(p̂) of the table S (see SCHED) into K (n, 3n), as ScheduledGain.gain computes it."""
    last = S.shape[0] - 1
    p = min(max(p_hat, S[0, 0]), S[last, 0])
    j = 0
    while j < last - 1 and S[j + 1, 0] <= p:  # searchsorted(..., side='right') - 1, clipped to 0..N-1
        j += 1
    s = (p - S[j, 0]) / (S[j + 1, 0] - S[j, 0])
    cols = K.shape[1]
    for i in range(K.shape[0]):
        for k in range(cols):
            K[i, k] = (1.0 - s) * S[j, 1 + i * cols + k] + s * S[j + 1, 1 + i * cols + k]


@inline
def arm_law(th: Any, t: float, x: Array, tc: Array) -> None:
    """The PID's torque τ_ff(t) − K [∫e, e, ė] (N·m) into tc (n,) at state x = [q, q̇, ∫e] (3n,).

    The errors are the measured ones (``q + n(t)``, ``q̇ + ṅ(t)``); the torque is clipped
    to ± the torque limit.
    """
    P, IX, K, WS, REF = th[_P], th[_IX], th[_GAIN], th[_WS], th[_REFS]
    n = IX[0]
    arm_reference(th, t)
    for i in range(n):
        limit = min(P[_A_LIMIT], REF[5, i])
        acc = 0.0
        for k in range(n):
            acc += K[i, k] * x[2 * n + k]
        for k in range(n):
            acc += K[i, n + k] * (WS[_S_R, k] - x[k] - WS[_S_N, k])
        for k in range(n):
            acc += K[i, 2 * n + k] * (WS[_S_RD, k] - x[n + k] - WS[_S_ND, k])
        tc[i] = min(max(WS[_S_FF, i] - acc, -limit), limit)


@inline
def arm_dynamics(th: Any, t: float, x: Array, tc: Array, td: float, dx: Array, fresh: bool) -> None:
    """ẋ of the arm under the torque tc (n,) and the disturbance td (N·m, before the signs).

    A state beyond :data:`STATE_LIMIT` is frozen (ẋ = 0), as the Python loop does. With
    `fresh`, the reference and payload of t are already in the scratch (:func:`arm_law`
    has just run at t).
    """
    IX, REF, WS, WC = th[_IX], th[_REFS], th[_WS], th[_WC]
    n = IX[0]
    for i in range(2 * n):
        if not abs(x[i]) <= STATE_LIMIT:
            for k in range(x.shape[0]):
                dx[k] = 0.0
            return
    if not fresh:
        arm_reference(th, t)
    for k in range(n):
        i = IX[2 + n + k]
        WS[_S_Q, i], WS[_S_QD, i] = x[k], x[n + k]
        WS[_S_APPLIED, i] = tc[k] + td * REF[4, k]
    arm_forward(th, WC[1])
    for k in range(n):
        dx[k] = x[n + k]
        dx[n + k] = WS[_S_QDD, IX[2 + n + k]]
        dx[2 * n + k] = WS[_S_R, k] - x[k] - WS[_S_N, k]


# The hooks call these compiled functions, with the law and the motion inlined; the reference
# (with the feedforward's RNEA) and the forward dynamics are one compiled function each, called
# (inlining them too saves about a tenth of a run and doubles the compile time).
@jit
def arm_torque(th: Any, t: float, x: Array, tc: Array) -> None:
    """:func:`arm_law` as a called function."""
    arm_law(th, t, x, tc)


@jit
def arm_rhs(th: Any, t: float, x: Array, tc: Array, td: float, dx: Array) -> None:
    """:func:`arm_dynamics` as a called function."""
    arm_dynamics(th, t, x, tc, td, dx, False)


@jit
def arm_closed_rhs(th: Any, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    """The closed loop's ẋ (dx) at (t, x): the PID's torque into tc, then the arm's dynamics."""
    arm_law(th, t, x, tc)
    arm_dynamics(th, t, x, tc, td, dx, True)


@jit
def arm_output(th: Any, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> None:
    """Sample j at state x: the torque TC[:, j] (N·m); its feedforward part ER[:n, j] (N·m), m_p ER[n, j] (kg),
    the errors e = r − q ER[n + 1:2n + 1, j] (rad) and ė = ṙ − q̇ ER[2n + 1:, j] (rad/s)."""
    arm_law(th, t, x, tc)
    WS = th[_WS]
    n = tc.shape[0]
    for i in range(n):
        TC[i, j] = tc[i]
        ER[i, j] = WS[_S_FF, i]
        ER[n + 1 + i, j] = WS[_S_R, i] - x[i]
        ER[2 * n + 1 + i, j] = WS[_S_RD, i] - x[n + i]
    ER[n, j] = th[_WC][1]


@jit
def arm_diverged(th: Any, t: float, x: Array, limit: float) -> bool:
    n = th[_IX][0]
    for i in range(2 * n):
        if not abs(x[i]) <= STATE_LIMIT:
            return True
    arm_reference(th, t)
    WS = th[_WS]
    for k in range(n):
        if not abs(WS[_S_R, k] - x[k]) <= limit:
            return True
    return False


@inline
def arm_disturbance(th: Array, t: float) -> float:
    P = th[_P]
    frac = t / P[_A_DIST + 1] + P[_A_DIST + 2] / (2 * math.pi)
    frac = frac - math.floor(frac)
    return float(P[_A_DIST] * (1.0 if frac < 0.5 else -1.0))


# --- what the integrators see of a model: hooks, implemented per model type ---------------------
# Each hook is a Python stub that numba replaces, when it compiles an integrator for a model's
# type, by that model's implementation: the SCARA's (θ, an array) or an arm's (a tuple).


def model_closed_rhs(th: Any, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    """ẋ (dx) of the closed loop at (t, x) with the disturbance td (N·m, before the joint signs); the torque in tc."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_torque(th: Any, t: float, x: Array, tc: Array) -> None:
    """The control law's torque at (t, x) into tc, N·m."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_rhs(th: Any, t: float, x: Array, tc: Array, td: float, dx: Array) -> None:
    """ẋ (dx) at (t, x) under the torque tc held and the disturbance td."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_output(th: Any, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> None:
    """The model's outputs of sample j at state x, into column j of TC and ER."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_diverged(th: Any, t: float, x: Array, limit: float) -> bool:
    """Whether the run left the limits at (t, x): a state beyond STATE_LIMIT or |e| > limit (rad)."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_disturbance(th: Any, t: float) -> float:
    """The disturbance's torque before the joint signs at t, N·m."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_sample_time(th: Any) -> float:
    """The law's sample time, s (0: continuous)."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


def model_inputs(th: Any) -> int:
    """The number of control torques."""
    raise NotImplementedError("compiled by numba only")  # pragma: no cover


_HOOK_OPTIONS: Any = {"nogil": True, "error_model": "numpy"}


def _scara(th: Any) -> bool:
    return isinstance(th, types.Array)


def _arm(th: Any) -> bool:
    return isinstance(th, types.BaseTuple)


# numba asks a hook's typing function and each implementation for the same signature, annotations
# included: they all repeat the SCARA kernel's (an arm's model is a tuple, not an Array).
@overload(model_closed_rhs, jit_options=_HOOK_OPTIONS)
def _closed_rhs_hook(th: Array, t: float, x: Array, td: float, tc: Array, dx: Array) -> Any:
    if _scara(th):
        return closed_rhs.py_func
    if _arm(th):
        def impl(th: Array, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
            arm_closed_rhs(th, t, x, td, tc, dx)
        return impl
    return None


@overload(model_torque, jit_options=_HOOK_OPTIONS)
def _torque_hook(th: Array, t: float, x: Array, out: Array) -> Any:
    if _scara(th):
        return torque.py_func
    if _arm(th):
        def impl(th: Array, t: float, x: Array, out: Array) -> None:
            arm_torque(th, t, x, out)
        return impl
    return None


@overload(model_rhs, jit_options=_HOOK_OPTIONS)
def _rhs_hook(th: Array, t: float, x: Array, tc: Array, td: float, dx: Array) -> Any:
    if _scara(th):
        return rhs.py_func
    if _arm(th):
        def impl(th: Array, t: float, x: Array, tc: Array, td: float, dx: Array) -> None:
            arm_rhs(th, t, x, tc, td, dx)
        return impl
    return None


@overload(model_output, jit_options=_HOOK_OPTIONS)
def _output_hook(th: Array, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> Any:
    if _scara(th):
        return output.py_func
    if _arm(th):
        def impl(th: Array, t: float, x: Array, tc: Array, TC: Array, ER: Array, j: int) -> None:
            arm_output(th, t, x, tc, TC, ER, j)
        return impl
    return None


@overload(model_diverged, jit_options=_HOOK_OPTIONS)
def _diverged_hook(th: Array, t: float, x: Array, limit: float) -> Any:
    if _scara(th):
        def impl(th: Array, t: float, x: Array, limit: float) -> bool:
            return bool(diverged(th, t, x, limit))
        return impl
    if _arm(th):
        def impl_arm(th: Array, t: float, x: Array, limit: float) -> bool:
            return bool(arm_diverged(th, t, x, limit))
        return impl_arm
    return None


@overload(model_disturbance, jit_options=_HOOK_OPTIONS)
def _disturbance_hook(th: Array, t: float) -> Any:
    if _scara(th):
        return disturbance.py_func
    if _arm(th):
        return arm_disturbance.py_func
    return None


@overload(model_sample_time, jit_options=_HOOK_OPTIONS)
def _sample_time_hook(th: Array) -> Any:
    if _scara(th):
        def impl(th: Array) -> float:
            return float(th[_TS])
        return impl
    if _arm(th):
        def impl_arm(th: Array) -> float:
            return float(th[_P][_A_TS])
        return impl_arm
    return None


@overload(model_inputs, jit_options=_HOOK_OPTIONS)
def _inputs_hook(th: Array) -> Any:
    if _scara(th):
        def impl(th: Array) -> int:
            return 2
        return impl
    if _arm(th):
        def impl_arm(th: Array) -> int:
            return int(th[_IX][0])
        return impl_arm
    return None


@jit
def closed_rhs_call(th: Any, t: float, x: Array, td: float, tc: Array, dx: Array) -> None:
    """:func:`model_closed_rhs` as a called function, where a call costs little: it bounds the compile time."""
    model_closed_rhs(th, t, x, td, tc, dx)

# Dormand–Prince 5(4) tableau
c = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
A = np.zeros((7, 6))
A[1, 0] = 1 / 5
A[2, :2] = (3 / 40, 9 / 40)
A[3, :3] = (44 / 45, -56 / 15, 32 / 9)
A[4, :4] = (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729)
A[5, :5] = (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656)
A[6, :6] = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84)
# scipy's RK45 dense output (Shampine's quartic): y(t + θh) = y + h Σ_s K_s (P_s · [θ, θ², θ³, θ⁴])
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])
E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])

@jit
def dopri_interval(th: Array, x: Array, t0: float, t1: float, td: float, h0: float, rtol: float,
                   atol: float, K: Array, y: Array, tc: Array) -> tuple[float, bool, int]:
    """Advance x in place from t0 to t1 exactly; returns (last accepted step, ok, rhs calls)."""
    n = x.shape[0]
    t = t0
    h = min(h0, t1 - t0)
    calls = 0
    closed_rhs_call(th, t, x, td, tc, K[0])
    calls += 1
    while t < t1:
        if t + h >= t1 or t1 - (t + h) < 1e-12 * max(1.0, abs(t1)):
            h = t1 - t
        for s in range(1, 7):
            for i in range(n):
                acc = x[i]
                for j in range(s):
                    acc += h * A[s, j] * K[j, i]
                y[i] = acc
            closed_rhs_call(th, t + c[s] * h, y, td, tc, K[s])
            calls += 1
        err = 0.0
        for i in range(n):
            sc = atol + rtol * max(abs(x[i]), abs(y[i]))
            ei = 0.0
            for j in range(7):
                ei += E[j] * K[j, i]
            ei *= h / sc
            err += ei * ei
        err = math.sqrt(err / n)
        if err <= 1.0 or not err == err:
            if not err == err:
                return h, False, calls
            t_new = t + h
            for i in range(n):
                x[i] = y[i]
                K[0, i] = K[6, i]  # first same as last
            t = t1 if h == t1 - t else t_new
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2))
            h_next = h * fac
            if t < t1:
                h = h_next
            else:
                return h_next, True, calls
        else:
            h = h * max(0.2, 0.9 * err ** -0.2)
            if h < 1e-14 * max(1.0, abs(t)):
                return h, False, calls
    return h, True, calls

@jit
def dopri_dense(th: Array, x: Array, a: float, b: float, td: float, h: float, rtol: float, atol: float,
                K: Array, y: Array, tc: Array, t_out: Array, j: int, X: Array,
                TC: Array, ER: Array) -> tuple[int, float, float, bool, int]:
    """Advance x in place from a to b with natural steps, writing outputs t_out[j:] in (a, b] by dense output.

    Returns (next output index, time reached, next step, ok, rhs calls).
    """
    n = x.shape[0]
    t = a
    calls = 1
    model_closed_rhs(th, t, x, td, tc, K[0])
    while t < b:
        hh = h
        if t + hh >= b or b - (t + hh) < 1e-12 * max(1.0, abs(b)):
            hh = b - t
        for s in range(1, 7):
            for i in range(n):
                acc = x[i]
                for q in range(s):
                    acc += hh * A[s, q] * K[q, i]
                y[i] = acc
            model_closed_rhs(th, t + c[s] * hh, y, td, tc, K[s])
            calls += 1
        err = 0.0
        for i in range(n):
            sc = atol + rtol * max(abs(x[i]), abs(y[i]))
            ei = 0.0
            for q in range(7):
                ei += E[q] * K[q, i]
            ei *= hh / sc
            err += ei * ei
        err = math.sqrt(err / n)
        if not err == err:
            return j, t, hh, False, calls
        if err <= 1.0:
            t_new = b if hh == b - t else t + hh
            while j < t_out.shape[0] and t_out[j] <= t_new + 1e-12:
                if t_out[j] >= t_new - 1e-15:
                    for i in range(n):
                        X[i, j] = y[i]
                else:
                    th1 = (t_out[j] - t) / hh
                    th2 = th1 * th1
                    th3 = th2 * th1
                    th4 = th3 * th1
                    for i in range(n):
                        acc = 0.0
                        for q in range(7):
                            acc += K[q, i] * (P[q, 0] * th1 + P[q, 1] * th2 + P[q, 2] * th3 + P[q, 3] * th4)
                        X[i, j] = x[i] + hh * acc
                model_output(th, t_out[j], X[:, j], tc, TC, ER, j)
                j += 1
            for i in range(n):
                x[i] = y[i]
                K[0, i] = K[6, i]  # first same as last
            t = t_new
            h = hh * (5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** -0.2)))
        else:
            h = hh * max(0.2, 0.9 * err ** -0.2)
            if h < 1e-14 * max(1.0, abs(t)):
                return j, t, h, False, calls
    return j, t, h, True, calls



# Variable-order BDF in the NDF form with a quasi-constant step: the method of
# scipy.integrate.BDF (Shampine & Reichelt 1997, "The MATLAB ODE suite"), step for step,
# with a forward-difference Jacobian. The stiff closed loop (a pole near -1500 1/s) holds an
# explicit method to its stability limit; this one takes the steps accuracy needs.
_MAX_ORDER = 5
_NEWTON_MAXITER = 4
_EPS = float(np.finfo(np.float64).eps)
_KAPPA = np.array([0.0, -0.1850, -1 / 9, -0.0823, -0.0415, 0.0])
_GAMMA = np.concatenate((np.zeros(1), np.cumsum(1 / np.arange(1, _MAX_ORDER + 1))))
_ALPHA = (1 - _KAPPA) * _GAMMA
_ERROR_CONST = _KAPPA * _GAMMA + 1 / np.arange(1, _MAX_ORDER + 2)


@inline
def rms_scaled(v: Array, scale: Array) -> float:
    acc = 0.0
    for i in range(v.shape[0]):
        q = v[i] / scale[i]
        acc += q * q
    return math.sqrt(acc / v.shape[0])


@jit
def change_D(D: Array, order: int, factor: float, work: Array) -> None:
    """Rescale the difference array D to a step `factor` times the current one (scipy's change_D).

    `work` is scratch of shape (4, MAX_ORDER + 1, max(MAX_ORDER + 1, n)).
    """
    m = order + 1
    R, U, RU, new = work[0], work[1], work[2], work[3]
    for col in range(m):
        R[0, col] = 1.0
        U[0, col] = 1.0
    for i in range(1, m):
        R[i, 0] = 0.0
        U[i, 0] = 0.0
        for col in range(1, m):
            R[i, col] = R[i - 1, col] * (i - 1 - factor * col) / i
            U[i, col] = U[i - 1, col] * (i - 1 - 1.0 * col) / i
    for i in range(m):
        for col in range(m):
            acc = 0.0
            for k in range(m):
                acc += R[i, k] * U[k, col]
            RU[i, col] = acc
    n = D.shape[1]
    for i in range(m):
        for q in range(n):
            acc = 0.0
            for k in range(m):
                acc += RU[k, i] * D[k, q]
            new[i, q] = acc
    for i in range(m):
        for q in range(n):
            D[i, q] = new[i, q]


@jit
def lu_factor(A: Array, piv: NDArray[np.int64]) -> None:
    """In-place LU with partial pivoting of a small dense matrix."""
    n = A.shape[0]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for q in range(n):
                A[k, q], A[p, q] = A[p, q], A[k, q]
        if A[k, k] != 0.0:
            for i in range(k + 1, n):
                A[i, k] /= A[k, k]
                for q in range(k + 1, n):
                    A[i, q] -= A[i, k] * A[k, q]


@inline
def lu_solve(LU: Array, piv: NDArray[np.int64], b: Array) -> None:
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        acc = b[i]
        for q in range(i):
            acc -= LU[i, q] * b[q]
        b[i] = acc
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for q in range(i + 1, n):
            acc -= LU[i, q] * b[q]
        b[i] = acc / LU[i, i]


@jit
def jacobian(th: Array, t: float, y: Array, f: Array, td: float, tc: Array, J: Array, w: Array,
             fw: Array) -> None:
    """Forward differences: J[:, k] = (f(y + h e_k) - f(y)) / h, h = sqrt(eps) max(1, |y_k|)."""
    n = y.shape[0]
    for k in range(n):
        for i in range(n):
            w[i] = y[i]
        h = math.sqrt(_EPS) * max(1.0, abs(y[k]))
        w[k] = y[k] + h
        h = w[k] - y[k]
        closed_rhs_call(th, t, w, td, tc, fw)
        for i in range(n):
            J[i, k] = (fw[i] - f[i]) / h



@inline
def _bdf_newton(th: Array, t_new: float, td: float, tc: Array, c: float, ypred: Array, psi: Array, scale: Array,
                LU: Array, piv: NDArray[np.int64], newton_tol: float, y: Array, d: Array, fw: Array,
                dy: Array) -> tuple[bool, int]:
    """Newton iterations of one BDF step (scipy's solve_bdf_system) into y and d: (converged, rhs calls)."""
    n = y.shape[0]
    for i in range(n):
        y[i] = ypred[i]
        d[i] = 0.0
    dy_norm_old = -1.0
    n_iter = 0
    for k in range(_NEWTON_MAXITER):
        n_iter = k + 1
        model_closed_rhs(th, t_new, y, td, tc, fw)
        finite = True
        for i in range(n):
            if not math.isfinite(fw[i]):
                finite = False
        if not finite:
            return False, n_iter
        for i in range(n):
            dy[i] = c * fw[i] - psi[i] - d[i]
        lu_solve(LU, piv, dy)
        dy_norm = rms_scaled(dy, scale)
        rate = -1.0 if dy_norm_old < 0 else dy_norm / dy_norm_old
        if rate >= 0 and (rate >= 1 or rate ** (_NEWTON_MAXITER - k) / (1 - rate) * dy_norm > newton_tol):
            return False, n_iter
        for i in range(n):
            y[i] += dy[i]
            d[i] += dy[i]
        if dy_norm == 0 or (rate >= 0 and rate / (1 - rate) * dy_norm < newton_tol):
            return True, n_iter
        dy_norm_old = dy_norm
    return False, n_iter


@inline
def _bdf_first_step(th: Array, x: Array, a: float, b: float, td: float, rtol: float, atol: float, tc: Array,
                    f0: Array, w: Array, fw: Array, scale: Array, dy: Array) -> float:
    """The first step of :func:`bdf_dense` from x (ẋ = f0): scipy's select_initial_step with order 1 (one rhs call)."""
    n = x.shape[0]
    interval = b - a
    for i in range(n):
        scale[i] = atol + abs(x[i]) * rtol
    d0 = rms_scaled(x, scale)
    d1 = rms_scaled(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        w[i] = x[i] + h0 * f0[i]
    closed_rhs_call(th, a + h0, w, td, tc, fw)
    for i in range(n):
        dy[i] = fw[i] - f0[i]
    d2 = rms_scaled(dy, scale) / h0
    h1 = max(1e-6, h0 * 1e-3) if d1 <= 1e-15 and d2 <= 1e-15 else (0.01 / max(d1, d2)) ** 0.5
    return min(100 * h0, h1, interval)


@inline
def _bdf_new_order(D: Array, order: int, scale: Array, dy: Array, error_norm: float,
                   safety: float) -> tuple[int, float]:
    """scipy's BDF order change after order + 1 equal steps: the new order and the step's factor."""
    n = D.shape[1]
    em = math.inf
    ep = math.inf
    if order > 1:
        for i in range(n):
            dy[i] = _ERROR_CONST[order - 1] * D[order, i]
        em = rms_scaled(dy, scale)
    if order < _MAX_ORDER:
        for i in range(n):
            dy[i] = _ERROR_CONST[order + 1] * D[order + 2, i]
        ep = rms_scaled(dy, scale)
    fm = math.inf if em == 0 else em ** (-1 / order)
    fc = math.inf if error_norm == 0 else error_norm ** (-1 / (order + 1))
    fp = math.inf if ep == 0 else ep ** (-1 / (order + 2))
    best, delta = fm, -1
    if fc > best:
        best, delta = fc, 0
    if fp > best:
        best, delta = fp, 1
    return order + delta, min(10.0, safety * best)


@inline
def _bdf_dense_output(th: Array, D: Array, order: int, t: float, h_abs: float, x: Array, tc: Array, t_out: Array,
                      j: int, X: Array, TC: Array, ER: Array) -> int:
    """The outputs on (t_old, t] (scipy's BdfDenseOutput, with the step and order now in force); the next index."""
    n = x.shape[0]
    while j < t_out.shape[0] and t_out[j] <= t + 1e-12:
        if t_out[j] >= t - 1e-15:
            for i in range(n):
                X[i, j] = x[i]
        else:
            for i in range(n):
                X[i, j] = D[0, i]
            p = 1.0
            for k in range(order):
                p *= (t_out[j] - (t - h_abs * k)) / (h_abs * (1 + k))
                for i in range(n):
                    X[i, j] += D[k + 1, i] * p
        model_output(th, t_out[j], X[:, j], tc, TC, ER, j)
        j += 1
    return j

@jit
def bdf_dense(th: Array, x: Array, a: float, b: float, td: float, rtol: float, atol: float, tc: Array,
              t_out: Array, j: int, X: Array, TC: Array, ER: Array) -> tuple[int, float, bool, int]:
    """Advance x in place from a to b (one solve of scipy's BDF), writing outputs t_out[j:] in (a, b].

    Returns (next output index, time reached, ok, rhs calls).
    """
    n = x.shape[0]
    f0 = np.empty(n)
    w = np.empty(n)
    fw = np.empty(n)
    scale = np.empty(n)
    ypred = np.empty(n)
    psi = np.empty(n)
    y = np.empty(n)
    d = np.empty(n)
    dy = np.empty(n)
    J = np.empty((n, n))
    LU = np.empty((n, n))
    piv = np.zeros(n, np.int64)
    D = np.zeros((_MAX_ORDER + 3, n))
    work = np.zeros((4, _MAX_ORDER + 1, max(_MAX_ORDER + 1, n)))
    calls = 0
    t = a
    closed_rhs_call(th, t, x, td, tc, f0)
    calls += 1
    h_abs = _bdf_first_step(th, x, a, b, td, rtol, atol, tc, f0, w, fw, scale, dy)
    calls += 1
    newton_tol = max(10 * _EPS / rtol, min(0.03, rtol ** 0.5))
    jacobian(th, t, x, f0, td, tc, J, w, fw)
    calls += n
    for i in range(n):
        D[0, i] = x[i]
        D[1, i] = f0[i] * h_abs
    order = 1
    n_equal = 0
    lu_ok = False
    while t < b:
        min_step = 10 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            change_D(D, order, min_step / h_abs, work)
            h_abs = min_step
            n_equal = 0
        current_jac = False
        accepted = False
        t_new = t
        error_norm = 0.0
        safety = 0.0
        while not accepted:
            if h_abs < min_step:
                return j, t, False, calls
            t_new = t + h_abs
            if t_new - b > 0:
                t_new = b
                change_D(D, order, abs(t_new - t) / h_abs, work)
                n_equal = 0
                lu_ok = False
            h = t_new - t
            h_abs = abs(h)
            for i in range(n):
                acc = 0.0
                for k in range(order + 1):
                    acc += D[k, i]
                ypred[i] = acc
                scale[i] = atol + rtol * abs(acc)
                acc = 0.0
                for k in range(1, order + 1):
                    acc += D[k, i] * _GAMMA[k]
                psi[i] = acc / _ALPHA[order]
            c = h / _ALPHA[order]
            converged = False
            n_iter = 0
            while not converged:
                if not lu_ok:
                    for i in range(n):
                        for q in range(n):
                            LU[i, q] = (1.0 if i == q else 0.0) - c * J[i, q]
                    lu_factor(LU, piv)
                    lu_ok = True
                converged, n_iter = _bdf_newton(th, t_new, td, tc, c, ypred, psi, scale, LU, piv, newton_tol, y, d,
                                                fw, dy)
                calls += n_iter
                if not converged:
                    if current_jac:
                        break
                    closed_rhs_call(th, t_new, ypred, td, tc, f0)
                    jacobian(th, t_new, ypred, f0, td, tc, J, w, fw)
                    calls += 1 + n
                    lu_ok = False
                    current_jac = True
            if not converged:
                h_abs *= 0.5
                change_D(D, order, 0.5, work)
                n_equal = 0
                lu_ok = False
                continue
            safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
            for i in range(n):
                scale[i] = atol + rtol * abs(y[i])
                dy[i] = _ERROR_CONST[order] * d[i]
            error_norm = rms_scaled(dy, scale)
            if error_norm > 1:
                factor = max(0.2, safety * error_norm ** (-1 / (order + 1)))
                h_abs *= factor
                change_D(D, order, factor, work)
                n_equal = 0
            else:
                accepted = True
        n_equal += 1
        t_old = t
        t = t_new
        for i in range(n):
            x[i] = y[i]
            D[order + 2, i] = d[i] - D[order + 1, i]
            D[order + 1, i] = d[i]
        for k in range(order, -1, -1):
            for i in range(n):
                D[k, i] += D[k + 1, i]
        if n_equal >= order + 1:
            order, factor = _bdf_new_order(D, order, scale, dy, error_norm, safety)
            h_abs *= factor
            change_D(D, order, factor, work)
            n_equal = 0
            lu_ok = False
        j = _bdf_dense_output(th, D, order, t, h_abs, x, tc, t_out, j, X, TC, ER)
        if t_old == t:
            return j, t, False, calls
    return j, t, True, calls

@jit
def rk4_step(th: Array, x: Array, a: float, b: float, td: float, tc: Array, K: Array, y: Array) -> None:
    n = x.shape[0]
    h = b - a
    model_torque(th, a, x, tc)
    model_rhs(th, a, x, tc, td, K[0])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[0, i]
    model_rhs(th, a + h / 2, y, tc, td, K[1])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[1, i]
    model_rhs(th, a + h / 2, y, tc, td, K[2])
    for i in range(n):
        y[i] = x[i] + h * K[2, i]
    model_rhs(th, b, y, tc, td, K[3])
    for i in range(n):
        x[i] = x[i] + h / 6 * (K[0, i] + 2 * K[1, i] + 2 * K[2, i] + K[3, i])

@jit
def diverged(th: Array, t: float, x: Array, limit: float) -> bool:
    for i in range(4):
        if not abs(x[i]) <= STATE_LIMIT:
            return True
    a, w = th[_REF], th[_REF + 1]
    return not (abs(a * math.sin(w * t) - x[0]) <= limit and abs(a * math.cos(w * t) - x[1]) <= limit)

@jit
def run(th: Array, x0: Array, t_out: Array, edges: Array, rtol: float, atol: float, limit: float,
        X: Array, TC: Array, ER: Array, stiff: bool) -> tuple[int, int, float, int]:
    """One run of model `th`: states X (n, k) and the model's outputs TC, ER on t_out; (samples, code, t_stop, calls).

    The SCARA's outputs are its torques TC (2, k) and errors ER (4, k); an arm's its
    torques TC (n, k), their feedforward part ER[:n], its payload mass ER[n] (kg) and
    its errors e ER[n + 1:2n + 1] (rad) and ė ER[2n + 1:] (rad/s). A continuous law is integrated
    by BDF when `stiff`, else by Dormand–Prince 5(4), restarted at every edge (the
    disturbance's switching instants); a sampled one by an RK4 step per edge.
    """
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(model_inputs(th))
    calls = 0
    for i in range(n):
        X[i, 0] = x[i]
    model_output(th, t_out[0], x, tc, TC, ER, 0)
    j = 1  # next output sample
    h = 1e-4
    sampled = model_sample_time(th) > 0
    for k in range(edges.shape[0] - 1):
        a, b = edges[k], edges[k + 1]
        td = model_disturbance(th, 0.5 * (a + b))
        if sampled:
            rk4_step(th, x, a, b, td, tc, K, y)
            calls += 4
            while j < t_out.shape[0] and t_out[j] <= b + 1e-12:
                for i in range(n):
                    X[i, j] = x[i]
                model_output(th, t_out[j], x, tc, TC, ER, j)
                j += 1
        elif stiff:
            j, t, ok, m = bdf_dense(th, x, a, b, td, rtol, atol, tc, t_out, j, X, TC, ER)
            calls += m
            if not ok:
                return j, _FAILED, t, calls
        else:
            j, t, h, ok, m = dopri_dense(th, x, a, b, td, h, rtol, atol, K, y, tc, t_out, j, X, TC, ER)
            calls += m
            if not ok:
                return j, _FAILED, t, calls
        if model_diverged(th, b, x, limit):
            return j, _DIVERGED, b, calls
    return j, _COMPLETED, edges[-1], calls

@jit
def refine(th: Array, x: Array, t0: float, fine: Array, counted: Array, rtol: float, atol: float) -> float:
    """max |Tc| at the `fine` times after t0 where `counted`, integrating from state x at t0 (continuous laws).

    `fine` holds the disturbance's switching instants too (not counted), so no step
    straddles a switch.
    """
    n = x.shape[0]
    z = x.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(model_inputs(th))
    peak = 0.0
    t = t0
    h = 1e-5
    for m in range(fine.shape[0]):
        b = fine[m]
        td = model_disturbance(th, 0.5 * (t + b))
        h, ok, _ = dopri_interval(th, z, t, b, td, h, rtol, atol, K, y, tc)
        if not ok:
            return np.nan
        t = b
        if counted[m]:
            model_torque(th, t, z, tc)
            for i in range(tc.shape[0]):
                peak = max(peak, abs(tc[i]))
    return peak

@jit
def batch(TH: Array, X0: Array, t_out: Array, edges_all: Array, n_edges: Array, rtol: float, atol: float,
          limit: float, X: Array, TC: Array, ER: Array, info: Array, stiff: bool) -> None:
    for r in range(TH.shape[0]):
        j, code, t_stop, calls = run(TH[r], X0[r], t_out, edges_all[r, :n_edges[r]], rtol, atol, limit,
                                     X[r], TC[r], ER[r], stiff)
        info[r, 0], info[r, 1], info[r, 2], info[r, 3] = j, code, t_stop, calls



@jit
def segment(th: Array, x0: Array, a: float, t_eval: Array, td: float, rtol: float, atol: float, X: Array) -> bool:
    """One segment from `a` through `t_eval` with the disturbance held at `td` (N·m, before the joint signs)."""
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(model_inputs(th))
    t = a
    h = 1e-4
    sampled = model_sample_time(th) > 0
    for m in range(t_eval.shape[0]):
        b = t_eval[m]
        if sampled:
            rk4_step(th, x, t, b, td, tc, K, y)
        else:
            h, ok, _ = dopri_interval(th, x, t, b, td, h, rtol, atol, K, y, tc)
            if not ok:
                return False
        t = b
        for i in range(n):
            X[i, m] = x[i]
    return True
