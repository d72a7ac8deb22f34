"""Machine-code kernels of the compiled engine (numba); imported only when that engine runs.

See :mod:`scara_robust.simulation.compiled` for what they integrate and how. The layout
of the packed parameter vector θ is defined there and repeated here as constants.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .loop import STATE_LIMIT

__all__ = ["run", "refine", "batch", "torque", "rhs", "segment"]

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
def terms(rb: Array, off: int, q2: float, w1: float, w2: float, mp: float) -> tuple[float, float, float, float, float]:
    return mass_terms(rb, off, math.cos(q2), math.sin(q2), w1, w2, mp)


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
    closed_rhs(th, t, x, td, tc, K[0])
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
            closed_rhs(th, t + c[s] * h, y, td, tc, K[s])
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
    closed_rhs(th, t, x, td, tc, K[0])
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
            closed_rhs(th, t + c[s] * hh, y, td, tc, K[s])
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
                output(th, t_out[j], X[:, j], tc, TC, ER, j)
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


@jit
def rk4_step(th: Array, x: Array, a: float, b: float, td: float, tc: Array, K: Array, y: Array) -> None:
    n = x.shape[0]
    h = b - a
    torque(th, a, x, tc)
    rhs(th, a, x, tc, td, K[0])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[0, i]
    rhs(th, a + h / 2, y, tc, td, K[1])
    for i in range(n):
        y[i] = x[i] + h / 2 * K[1, i]
    rhs(th, a + h / 2, y, tc, td, K[2])
    for i in range(n):
        y[i] = x[i] + h * K[2, i]
    rhs(th, b, y, tc, td, K[3])
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
        X: Array, TC: Array, ER: Array) -> tuple[int, int, float, int]:
    """One run: states X (n, k), torques TC (2, k) and errors ER (4, k) on t_out; (samples, code, t_stop, calls)."""
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(2)
    calls = 0
    for i in range(n):
        X[i, 0] = x[i]
    output(th, t_out[0], x, tc, TC, ER, 0)
    j = 1  # next output sample
    h = 1e-4
    sampled = th[_TS] > 0
    for k in range(edges.shape[0] - 1):
        a, b = edges[k], edges[k + 1]
        td = th[_DIST] * disturbance_level(th, 0.5 * (a + b))
        if sampled:
            rk4_step(th, x, a, b, td, tc, K, y)
            calls += 4
            while j < t_out.shape[0] and t_out[j] <= b + 1e-12:
                for i in range(n):
                    X[i, j] = x[i]
                output(th, t_out[j], x, tc, TC, ER, j)
                j += 1
        else:
            j, t, h, ok, m = dopri_dense(th, x, a, b, td, h, rtol, atol, K, y, tc, t_out, j, X, TC, ER)
            calls += m
            if not ok:
                return j, _FAILED, t, calls
        if diverged(th, b, x, limit):
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
    tc = np.zeros(2)
    peak = 0.0
    t = t0
    h = 1e-5
    for m in range(fine.shape[0]):
        b = fine[m]
        td = th[_DIST] * disturbance_level(th, 0.5 * (t + b))
        h, ok, _ = dopri_interval(th, z, t, b, td, h, rtol, atol, K, y, tc)
        if not ok:
            return np.nan
        t = b
        if counted[m]:
            torque(th, t, z, tc)
            peak = max(peak, abs(tc[0]), abs(tc[1]))
    return peak

@jit
def batch(TH: Array, X0: Array, t_out: Array, edges_all: Array, n_edges: Array, rtol: float, atol: float,
          limit: float, X: Array, TC: Array, ER: Array, info: Array) -> None:
    for r in range(TH.shape[0]):
        j, code, t_stop, calls = run(TH[r], X0[r], t_out, edges_all[r, :n_edges[r]], rtol, atol, limit,
                                     X[r], TC[r], ER[r])
        info[r, 0], info[r, 1], info[r, 2], info[r, 3] = j, code, t_stop, calls



@jit
def segment(th: Array, x0: Array, a: float, t_eval: Array, td: float, rtol: float, atol: float, X: Array) -> bool:
    """One segment from `a` through `t_eval` with the disturbance held at `td` (N·m, before the joint signs)."""
    n = x0.shape[0]
    x = x0.copy()
    K = np.zeros((7, n))
    y = np.zeros(n)
    tc = np.zeros(2)
    t = a
    h = 1e-4
    for m in range(t_eval.shape[0]):
        b = t_eval[m]
        if th[_TS] > 0:
            rk4_step(th, x, t, b, td, tc, K, y)
        else:
            h, ok, _ = dopri_interval(th, x, t, b, td, h, rtol, atol, K, y, tc)
            if not ok:
                return False
        t = b
        for i in range(n):
            X[i, m] = x[i]
    return True
