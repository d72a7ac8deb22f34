"""control_toolbox's PID step, re-implemented in Python from its documentation and source, for the tests.

Independent of scara_robust: it reads nothing of the package (tests/test_ros2.py runs it against
:class:`scara_robust.DiscretePID`). It reproduces the expected values of control_toolbox's own unit tests
(``test/pid_tests.cpp`` at the commit below: integralOnly, derivativeOnly, completePID,
backCalculationPID, conditionalIntegrationPID, integrationAntiwindup), checked in tests/test_ros2.py.

Written from the documentation and source of ros-controls/control_toolbox:

  * CtPid        -> master @ e274281b41eb1c3f4817b2226c4ddbc6863b5d66 (package 6.3.0;
                    the kilted branch 5.10.0 has the same compute_command logic),
                    files control_toolbox/include/control_toolbox/pid.hpp and
                    control_toolbox/src/pid.cpp.  This is the version that
                    ros2_controllers master (pid_controller 6.9.0) builds against
                    (ros2_controllers.rolling.repos -> control_toolbox "master").
                    antiwindup_strategy in {"none", "back_calculation",
                    "conditional_integration"}.

Doc sentences (quoted from pid.hpp @ master) are given next to the code that
implements them.  No ROS dependency; dt is in seconds.
"""

from __future__ import annotations

import math

import numpy as np

EPS = float(np.finfo(np.float64).eps)  # std::numeric_limits<double>::epsilon()
INF = float("inf")

_VALID_STRATEGIES = ("none", "back_calculation", "conditional_integration")


def is_zero(value: float, tolerance: float = EPS) -> bool:
    """control_toolbox::is_zero: `return std::abs(value) <= tolerance;`"""
    return abs(value) <= tolerance


def _std_clamp(v: float, lo: float, hi: float) -> float:
    """Exactly std::clamp(v, lo, hi): `v < lo ? lo : (hi < v ? hi : v)` (NaN passes through)."""
    if v < lo:
        return lo
    if hi < v:
        return hi
    return v


def _div(a: float, b: float) -> float:
    """IEEE-754 division like C++ (x/0 -> +-inf, 0/0 -> nan) instead of ZeroDivisionError."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.float64(a) / np.float64(b))


class CtPid:
    r"""control_toolbox::Pid (master / kilted semantics).

    Class doc (pid.hpp):
      "The standard PID equation is:  command = p_term + i_term + d_term
       where:
        - p_term = p_gain * error
        - i_term += i_gain * error * dt
        - d_term = d_gain * d_error
       and:
        - error = desired_state - measured_state
        - d_error = (error - error_last) / dt"

    NOTE (from pid.cpp): the command of a step is formed with the i_term
    accumulated up to the *previous* step; i_term is updated (forward Euler,
    i_gain applied inside the sum, i.e. i_term is already in command units)
    *after* the command is computed, and then clamped to [i_clamp_min, i_clamp_max].
    """

    def __init__(
        self,
        p: float,
        i: float,
        d: float,
        i_clamp_max: float = INF,
        i_clamp_min: float = -INF,
        u_clamp_max: float = INF,
        u_clamp_min: float = -INF,
        antiwindup_strategy: str = "none",
        tracking_time_constant: float = 0.0,
        error_deadband: float = EPS,
    ):
        # "\throws An std::invalid_argument exception is thrown if u_min >= u_max."
        if u_clamp_min >= u_clamp_max:
            raise ValueError("received u_min >= u_max")
        self.set_gains(
            p, i, d, i_clamp_max, i_clamp_min, u_clamp_max, u_clamp_min,
            antiwindup_strategy, tracking_time_constant, error_deadband,
        )
        self.i_term = 0.0
        self.cmd_unsat = 0.0
        self.reset()

    # ------------------------------------------------------------------ gains
    def set_gains(
        self,
        p, i, d, i_clamp_max=INF, i_clamp_min=-INF, u_clamp_max=INF, u_clamp_min=-INF,
        antiwindup_strategy="none", tracking_time_constant=0.0, error_deadband=EPS,
    ):
        """Pid::set_gains + Gains::validate + AntiWindupStrategy::validate.

        Upstream prints an error and keeps the old gains when validation fails;
        here a ValueError is raised instead.
        """
        p, i, d = float(p), float(i), float(d)
        u_max, u_min = float(u_clamp_max), float(u_clamp_min)
        i_max, i_min = float(i_clamp_max), float(i_clamp_min)
        tt = float(tracking_time_constant)
        strat = str(antiwindup_strategy)
        # Gains::validate
        if u_min >= u_max:  # "is false if any value is nan"
            raise ValueError(f"Gains: u_min ({u_min}) must be less than u_max ({u_max})")
        if math.isnan(u_min) or math.isnan(u_max):
            raise ValueError("Gains: u_min and u_max must not be NaN")
        # AntiWindupStrategy::set_type / validate
        if strat not in _VALID_STRATEGIES:
            raise ValueError(
                f"AntiWindupStrategy: Unknown antiwindup strategy : '{strat}'. Valid strategies "
                "are: 'back_calculation', 'conditional_integration', 'none'."
            )
        if strat == "back_calculation" and (tt < 0.0 or not math.isfinite(tt)):
            raise ValueError(
                "AntiWindupStrategy 'back_calculation' requires a valid positive tracking time "
                "constant (tracking_time_constant)"
            )
        if i_min > 0:
            raise ValueError(f"PID requires i_min to be smaller or equal to 0 (i_min: {i_min})")
        if i_max < 0:
            raise ValueError(f"PID requires i_max to be greater or equal to 0 (i_max: {i_max})")
        # "\param tracking_time_constant  Tracking time constant for BACK_CALCULATION anti-windup.
        #   If zero, a default is chosen based on gains:
        #   - sqrt(d_gain / i_gain) if d_gain != 0
        #   - p_gain / i_gain otherwise."
        # (pid.cpp: only when i_gain != 0; is_zero() uses DBL_EPSILON as tolerance)
        if strat == "back_calculation":
            if is_zero(tt) and not is_zero(d) and not is_zero(i):
                tt = float(np.sqrt(np.float64(d) / np.float64(i)))  # NaN if d/i < 0, as in C++
            elif is_zero(tt) and is_zero(d) and not is_zero(i):
                tt = _div(p, i)
        self.p_gain, self.i_gain, self.d_gain = p, i, d
        self.u_max, self.u_min = u_max, u_min
        self.i_max, self.i_min = i_max, i_min
        self.antiwindup_strategy = strat
        self.tracking_time_constant = tt
        self.error_deadband = float(error_deadband)
        return True

    # ------------------------------------------------------------------ state
    def reset(self, save_i_term: bool = False) -> None:
        """Pid::reset(bool save_i_term): "\\param save_i_term boolean indicating if integral
        term is retained on reset()". Resets p_error_last_, p_error_, d_error_, cmd_."""
        self.p_error_last = 0.0
        self.p_error = 0.0
        self.d_error = 0.0
        self.cmd = 0.0
        if not save_i_term:
            self.i_term = 0.0  # clear_saved_iterm()

    def get_current_pid_errors(self):
        """(pe, ie, de) = (p_error_, i_term_, d_error_) -- ie is the integral *term*."""
        return self.p_error, self.i_term, self.d_error

    # ---------------------------------------------------------------- compute
    def compute_command(self, error: float, error_dot: float | None, dt: float) -> float:
        """Pid::compute_command(double error, double error_dot, const double & dt_s).

        "Set the PID error and compute the PID command with nonuniform time step size.
         This also allows the user to pass in a precomputed derivative error.
         \\param error Error since last call (error = target - state)
         \\param error_dot d(Error)/dt_s since last call
         \\param dt_s Change in time since last call in seconds"

        If error_dot is None, the 2-argument overload Pid::compute_command(error, dt_s)
        is emulated: "The derivative error is computed from the change in the error and
        the timestep dt_s."
        """
        if error_dot is None:
            return self._compute_command_fd(error, dt)
        return self._compute_command(float(error), float(error_dot), float(dt))

    def _compute_command_fd(self, error: float, dt: float) -> float:
        error, dt = float(error), float(dt)
        if is_zero(dt):
            return self.cmd  # "don't update anything"
        if dt < 0.0:
            raise ValueError("Pid is called with negative dt")
        if not math.isfinite(error):
            # "don't reset controller but return NaN"
            self.cmd = float("nan")
            return self.cmd
        # "Calculate the derivative error":  d_error = (error - error_last) / dt
        d_error = (error - self.p_error_last) / dt
        self.p_error_last = error  # only the 2-arg overload updates error_last
        return self._compute_command(error, d_error, dt)

    def _compute_command(self, error: float, error_dot: float, dt: float) -> float:
        if is_zero(dt):
            return self.cmd  # "Don't update anything"
        if dt < 0.0:
            raise ValueError("Pid is called with negative dt")

        self.p_error = error  # "This is error = target - state"
        self.d_error = error_dot  # "This is the derivative of error"

        if not (math.isfinite(error) and math.isfinite(error_dot)):
            # "Don't reset controller but return NaN"
            self.cmd = float("nan")
            return self.cmd

        # "p_term = p_gain * error"
        p_term = self.p_gain * error
        # "d_term = d_gain * d_error"  (d_error is the error_dot passed in, no filtering)
        d_term = self.d_gain * error_dot

        # "Error deadband is used to stop integration when the error is within the given range."
        in_deadband = is_zero(error, self.error_deadband)

        # "command = p_term + i_term + d_term"  -- i_term from previous steps
        self.cmd_unsat = p_term + self.i_term + d_term

        # "u_min / u_max: Minimum/Maximum bound for the controller output."
        if math.isfinite(self.u_min) or math.isfinite(self.u_max):
            self.cmd = _std_clamp(self.cmd_unsat, self.u_min, self.u_max)
        else:
            self.cmd = self.cmd_unsat

        if not in_deadband:
            if self.antiwindup_strategy == "back_calculation" and not is_zero(self.i_gain):
                # "i_term += dt * (i_gain * error + 1/trk_tc * (command_sat - command))"
                self.i_term += dt * (
                    self.i_gain * error
                    + _div(1.0, self.tracking_time_constant) * (self.cmd - self.cmd_unsat)
                )
            elif self.antiwindup_strategy == "conditional_integration":
                # "Integrates only if (command - command_sat = 0) or (error * command <= 0)"
                # (command = unsaturated command; equality tested with is_zero / DBL_EPSILON)
                if is_zero(self.cmd_unsat - self.cmd) or error * self.cmd_unsat <= 0:
                    self.i_term += dt * self.i_gain * error
            elif self.antiwindup_strategy == "none":
                # "NONE: no anti-windup (integral always accumulates)."
                self.i_term += dt * self.i_gain * error
            # back_calculation with i_gain == 0: no integration at all

        # i_clamp ("Upper/Lower integral clamp") always applied to the integral *term*
        self.i_term = _std_clamp(self.i_term, self.i_min, self.i_max)
        return self.cmd
