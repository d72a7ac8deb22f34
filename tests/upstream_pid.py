"""Independent reference port of ros2_control's PID (control_toolbox::Pid), as upstream C++ computes it.

Source ported (read with `git show`, nothing else consulted):
  repository : github.com/ros-controls/control_toolbox
  tag        : 6.3.0   (commit 36230f3f32379b0e200694459fc639571dda7b2f, 2026-04-17)
  files      : control_toolbox/src/pid.cpp                  (blob 524846c72820d353fd258fe1520bccec8020eb43)
               control_toolbox/include/control_toolbox/pid.hpp (blob 656370057c002b6df2108b6abf0aaf34aed56074)
               control_toolbox/src/pid_ros.cpp              (blob 37e7762b00d027eac33e765e4a9c45e7f41e52d8)
  The same pid.cpp/pid.hpp blobs are on `master` (e274281b41eb1c3f4817b2226c4ddbc6863b5d66), which is what
  ros2_controllers' rolling/lyrical .repos files pin.  Tags 6.0.0 and 6.1.0 (blob 7db7ecb...) differ from
  6.3.0 only in the licence comment and in print()/string() formatting - the arithmetic is identical.

  "pid.cpp:NNN" / "pid.hpp:NNN" / "pid_ros.cpp:NNN" below are line numbers at tag 6.3.0.
  "pid_controller.cpp:NNN" are line numbers of ros2_controllers tag 6.9.0
  (commit 78d6508ebc82fb1692cfed6e9840b6ebfc0c6756), pid_controller/src/pid_controller.cpp.

Faithfulness notes
  * C++ `double` arithmetic is IEEE-754 binary64, as is Python `float`.  Two places where Python would
    raise instead of producing inf/NaN are wrapped: division by 0.0 (`1 / tracking_time_constant`) and
    sqrt of a negative number (`std::sqrt(d / i)`).
  * Expressions keep the C++ association order so results are bit-identical on x86-64 (no FMA
    contraction there; on aarch64 a compiler may fuse `a*b + c`, giving 1-ulp differences).
  * std::invalid_argument -> InvalidArgument (a ValueError); std::runtime_error -> RuntimeError.
  * The RealtimeThreadSafeBox is modelled as a plain attribute `_gains_box`; `try_get()` always
    succeeds in single-threaded use, so new gains take effect at the next 3-argument compute_command()
    (after its dt checks) or at reset().
"""

from __future__ import annotations

import copy as _copy
import math
import sys
from dataclasses import dataclass, field

INF = math.inf
NAN = math.nan
DBL_EPSILON = sys.float_info.epsilon  # std::numeric_limits<double>::epsilon() == 2.220446049250313e-16


class InvalidArgument(ValueError):
    """Stands for std::invalid_argument."""


# --------------------------------------------------------------------------------------------------
# IEEE helpers (C++ semantics that Python does not give for free)
# --------------------------------------------------------------------------------------------------
def _div(a: float, b: float) -> float:
    """C++ `a / b` for doubles: never raises (x/0 -> +-inf, 0/0 -> nan)."""
    if b == 0.0:
        if a == 0.0 or math.isnan(a):
            return NAN
        # sign of result = sign(a) * sign(b), b may be -0.0
        return math.copysign(INF, a) * math.copysign(1.0, b)
    return a / b


def _sqrt(x: float) -> float:
    """std::sqrt: NaN for negative input instead of raising."""
    if x < 0.0:
        return NAN
    return math.sqrt(x)


def _std_max(a: float, b: float) -> float:
    # libstdc++: return (__a < __b) ? __b : __a;
    return b if a < b else a


def _std_min(a: float, b: float) -> float:
    # libstdc++: return (__b < __a) ? __b : __a;
    return b if b < a else a


def std_clamp(v: float, lo: float, hi: float) -> float:
    """libstdc++ (GCC 12) std::clamp: `return std::min(std::max(__val, __lo), __hi);`.

    NaN v -> NaN (passes through); NaN lo/hi -> that bound is ignored.
    """
    return _std_min(_std_max(v, lo), hi)


def is_zero(value: float, tolerance: float = DBL_EPSILON) -> bool:
    """pid.hpp:180-184  `return std::abs(value) <= tolerance;`  (NaN -> False)."""
    return abs(value) <= tolerance


# --------------------------------------------------------------------------------------------------
# AntiWindupStrategy  (pid.hpp:62-178)
# --------------------------------------------------------------------------------------------------
class AntiWindupStrategy:
    # pid.hpp:65-71  enum Value : int8_t
    UNDEFINED = -1
    NONE = 0
    BACK_CALCULATION = 1
    CONDITIONAL_INTEGRATION = 2

    def __init__(
        self,
        type: int = NONE,  # pid.hpp:74  ctor init-list type(NONE) (the member default UNDEFINED at :168 is overridden)
        i_max: float = INF,  # pid.hpp:75
        i_min: float = -INF,  # pid.hpp:76
        tracking_time_constant: float = 0.0,  # pid.hpp:77
        error_deadband: float = DBL_EPSILON,  # pid.hpp:78
    ):
        self.type = type
        self.i_max = float(i_max)
        self.i_min = float(i_min)
        self.tracking_time_constant = float(tracking_time_constant)
        self.error_deadband = float(error_deadband)

    # pid.hpp:82-104
    def set_type(self, s: str) -> None:
        if s == "back_calculation":
            self.type = AntiWindupStrategy.BACK_CALCULATION
        elif s == "conditional_integration":
            self.type = AntiWindupStrategy.CONDITIONAL_INTEGRATION
        elif s == "none":
            self.type = AntiWindupStrategy.NONE
        else:
            self.type = AntiWindupStrategy.UNDEFINED
            raise InvalidArgument(
                "AntiWindupStrategy: Unknown antiwindup strategy : '" + s + "'. Valid strategies are: "
                "'back_calculation', 'conditional_integration', 'none'."
            )

    # pid.hpp:106-136
    def validate(self) -> None:
        if self.type == AntiWindupStrategy.UNDEFINED:  # :108
            raise InvalidArgument("AntiWindupStrategy is UNDEFINED. Please set a valid type")
        if self.type == AntiWindupStrategy.BACK_CALCULATION and (  # :112-114
            self.tracking_time_constant < 0.0 or not math.isfinite(self.tracking_time_constant)
        ):
            raise InvalidArgument(
                "AntiWindupStrategy 'back_calculation' requires a valid positive tracking time constant "
                "(tracking_time_constant)"
            )
        if self.i_min > 0:  # :120  (NaN passes!)
            raise InvalidArgument(f"PID requires i_min to be smaller or equal to 0 (i_min: {self.i_min})")
        if self.i_max < 0:  # :125  (NaN passes!)
            raise InvalidArgument(f"PID requires i_max to be greater or equal to 0 (i_max: {self.i_max})")
        if self.type not in (  # :130-135
            AntiWindupStrategy.NONE,
            AntiWindupStrategy.UNDEFINED,
            AntiWindupStrategy.BACK_CALCULATION,
            AntiWindupStrategy.CONDITIONAL_INTEGRATION,
        ):
            raise InvalidArgument("AntiWindupStrategy has an invalid type")
        # NOTE: error_deadband is never validated (negative or NaN accepted).

    # pid.hpp:152-166
    def to_string(self) -> str:
        return {
            AntiWindupStrategy.BACK_CALCULATION: "back_calculation",
            AntiWindupStrategy.CONDITIONAL_INTEGRATION: "conditional_integration",
            AntiWindupStrategy.NONE: "none",
        }.get(self.type, "UNDEFINED")

    def __eq__(self, other):  # pid.hpp:149 compares against an enum value
        if isinstance(other, int):
            return self.type == other
        if isinstance(other, AntiWindupStrategy):
            return vars(self) == vars(other)
        return NotImplemented

    def __repr__(self) -> str:
        return (
            f"AntiWindupStrategy({self.to_string()}, i_max={self.i_max}, i_min={self.i_min}, "
            f"tracking_time_constant={self.tracking_time_constant}, error_deadband={self.error_deadband})"
        )


# --------------------------------------------------------------------------------------------------
# Pid::Gains  (pid.hpp:269-335)
# --------------------------------------------------------------------------------------------------
@dataclass
class Gains:
    p_gain_: float = 0.0  # pid.hpp:329
    i_gain_: float = 0.0  # pid.hpp:330
    d_gain_: float = 0.0  # pid.hpp:331
    u_max_: float = INF  # pid.hpp:332
    u_min_: float = -INF  # pid.hpp:333
    antiwindup_strat_: AntiWindupStrategy = field(default_factory=AntiWindupStrategy)  # pid.hpp:334

    # pid.hpp:296-318
    def validate(self) -> tuple[bool, str]:
        if self.u_min_ >= self.u_max_:  # :298  "is false if any value is nan"
            return False, f"Gains: u_min ({self.u_min_}) must be less than u_max ({self.u_max_})"
        elif math.isnan(self.u_min_) or math.isnan(self.u_max_):  # :303
            return False, "Gains: u_min and u_max must not be NaN"
        try:  # :308-316
            self.antiwindup_strat_.validate()
        except InvalidArgument as e:
            return False, str(e)
        return True, ""
        # NOTE: p, i, d are never validated (NaN / inf / negative gains are accepted).

    def clone(self) -> Gains:
        return _copy.deepcopy(self)


# --------------------------------------------------------------------------------------------------
# Pid  (pid.hpp:263-627, pid.cpp)
# --------------------------------------------------------------------------------------------------
class Pid:
    # ---- construction -------------------------------------------------------------------------
    # pid.cpp:45-59
    def __init__(
        self,
        p: float = 0.0,
        i: float = 0.0,
        d: float = 0.0,
        u_max: float = INF,
        u_min: float = -INF,
        antiwindup_strat: AntiWindupStrategy | None = None,
    ):
        if antiwindup_strat is None:
            antiwindup_strat = AntiWindupStrategy()  # pid.hpp:355 default argument
        # pid.hpp:610-616  local RT copy of the gains, default-constructed
        self.gains_ = Gains(0.0, 0.0, 0.0, INF, -INF, AntiWindupStrategy())
        # pid.hpp:619  realtime box initialised from gains_
        self._gains_box = self.gains_.clone()
        # pid.hpp:621-626  state
        self.p_error_last_ = 0.0  # Save state for derivative state calculation.
        self.p_error_ = 0.0  # Error.
        self.d_error_ = 0.0  # Derivative of error.
        self.i_term_ = 0.0  # Integrator state.
        self.cmd_ = 0.0  # Command to send.
        self.cmd_unsat_ = 0.0  # command without saturation.

        if u_min >= u_max:  # pid.cpp:49-52  (NaN does not throw here; set_gains then refuses it)
            raise InvalidArgument("received u_min >= u_max")
        # pid.cpp:53  return value ignored: invalid gains leave the default (all-zero) gains in place
        self.set_gains(p, i, d, u_max, u_min, antiwindup_strat)
        self.clear_saved_iterm()  # pid.cpp:56
        self.reset()  # pid.cpp:58

    # pid.cpp:61-71 copy constructor / pid.hpp:592-606 assignment: copies the gains box only, then
    # resets (state is NOT copied; i_term_ of the copy is 0 for the ctor, kept for operator=).
    def __copy__(self) -> Pid:
        new = Pid.__new__(Pid)
        new.gains_ = Gains(0.0, 0.0, 0.0, INF, -INF, AntiWindupStrategy())
        new._gains_box = self._gains_box.clone()
        new.p_error_last_ = new.p_error_ = new.d_error_ = new.i_term_ = new.cmd_ = new.cmd_unsat_ = 0.0
        new.clear_saved_iterm()
        new.reset()
        return new

    def assign_from(self, source: Pid) -> Pid:
        """pid.hpp:592-606 operator=: copy gains box, reset() (which clears i_term_)."""
        if self is source:
            return self
        self._gains_box = source._gains_box.clone()
        self.reset()
        return self

    # pid.cpp:75-85
    def initialize(self, p, i, d, u_max, u_min, antiwindup_strat: AntiWindupStrategy) -> bool:
        if self.set_gains(p, i, d, u_max, u_min, antiwindup_strat):
            self.reset()  # reset(false): i_term_ cleared
            return True
        return False

    # ---- reset ---------------------------------------------------------------------------------
    # pid.cpp:87 reset() == reset(false);  pid.cpp:89-104 reset(bool save_i_term)
    def reset(self, save_i_term: bool = False) -> None:
        self.p_error_last_ = 0.0  # :91
        self.p_error_ = 0.0  # :92
        self.d_error_ = 0.0  # :93
        self.cmd_ = 0.0  # :94
        # NOTE: cmd_unsat_ is NOT reset (it is recomputed before use anyway).
        if not save_i_term:  # :97-100
            self.clear_saved_iterm()
        self.gains_ = self._gains_box.clone()  # :103  pull the latest gains into the RT copy

    # pid.cpp:106
    def clear_saved_iterm(self) -> None:
        self.i_term_ = 0.0

    # ---- gains ---------------------------------------------------------------------------------
    # pid.cpp:121-125 (non-RT: what was last stored, incl. the rewritten tracking_time_constant)
    def get_gains(self) -> Gains:
        return self._gains_box.clone()

    # pid.hpp:436 (RT copy actually used by the last compute)
    def get_gains_rt(self) -> Gains:
        return self.gains_.clone()

    def set_gains(self, *args) -> bool:
        """set_gains(p, i, d, u_max, u_min, antiwindup_strat)  -> pid.cpp:127-144
        set_gains(gains: Gains)                              -> pid.cpp:146-180"""
        if len(args) == 1 and isinstance(args[0], Gains):
            return self._set_gains_struct(args[0])
        p, i, d, u_max, u_min, antiwindup_strat = args
        g = Gains(float(p), float(i), float(d), float(u_max), float(u_min), _copy.deepcopy(antiwindup_strat))
        return self._set_gains_struct(g)  # pid.cpp:133-143 (exceptions would be printed, return false)

    def _set_gains_struct(self, gains_in: Gains) -> bool:
        ok, error_msg = gains_in.validate()  # pid.cpp:149  validation happens BEFORE the rewrite below
        if not ok:
            print("PID: Invalid gains: " + error_msg + ". Skipping new gains.", file=sys.stderr)  # :151
            return False  # :152  old gains kept
        gains = gains_in.clone()  # :156
        aw = gains.antiwindup_strat_
        if aw.type == AntiWindupStrategy.BACK_CALCULATION:  # :158
            if (
                is_zero(aw.tracking_time_constant) and not is_zero(gains.d_gain_) and not is_zero(gains.i_gain_)
            ):  # :160-162
                # :165  default tracking time constant sqrt(d/i)  (NaN if d/i < 0; never re-validated)
                aw.tracking_time_constant = _sqrt(_div(gains.d_gain_, gains.i_gain_))
            elif (
                is_zero(aw.tracking_time_constant) and is_zero(gains.d_gain_) and not is_zero(gains.i_gain_)
            ):  # :167-169
                # :172  default tracking time constant p/i  (0 if p == 0, negative if p/i < 0)
                aw.tracking_time_constant = _div(gains.p_gain_, gains.i_gain_)
            # i == 0 (|i| <= eps): tracking_time_constant left as given (e.g. 0.0).
            # No rule whatsoever relates tracking_time_constant to dt.
        self._gains_box = gains  # :176
        return True

    # ---- compute -------------------------------------------------------------------------------
    def compute_command(self, error: float, a: float, b: float | None = None) -> float:
        """compute_command(error, dt_s)              -> pid.cpp:182-206
        compute_command(error, error_dot, dt_s)   -> pid.cpp:238-327"""
        if b is None:
            return self.compute_command_error_only(error, a)
        return self.compute_command_with_error_dot(error, a, b)

    # pid.cpp:208-211 / 218-221 / 223-226 / 233-236 and rclcpp::Duration::seconds():
    # all convert integer nanoseconds with `static_cast<double>(ns) / 1.e9`.
    def compute_command_ns(self, error: float, dt_ns: int) -> float:
        return self.compute_command_error_only(error, float(dt_ns) / 1.0e9)

    def compute_command_with_error_dot_ns(self, error: float, error_dot: float, dt_ns: int) -> float:
        return self.compute_command_with_error_dot(error, error_dot, float(dt_ns) / 1.0e9)

    # pid.cpp:182-206
    def compute_command_error_only(self, error: float, dt_s: float) -> float:
        error = float(error)
        dt_s = float(dt_s)
        if is_zero(dt_s):  # :184  |dt| <= DBL_EPSILON
            return self.cmd_  # :187  don't update anything (not even gains)
        elif dt_s < 0.0:  # :189  (NaN dt passes both checks)
            raise InvalidArgument("Pid is called with negative dt")
        if not math.isfinite(error):  # :195-199  don't reset, return NaN; p_error_last_/d_error_ untouched
            print("Received a non-finite error value", file=sys.stderr)
            self.cmd_ = NAN  # std::numeric_limits<float>::quiet_NaN()
            return self.cmd_
        # :202-203  backward-difference derivative; p_error_last_ updated HERE only (3-arg never does)
        self.d_error_ = (error - self.p_error_last_) / dt_s
        self.p_error_last_ = error
        return self.compute_command_with_error_dot(error, self.d_error_, dt_s)  # :205

    # pid.cpp:238-327
    def compute_command_with_error_dot(self, error: float, error_dot: float, dt_s: float) -> float:
        error = float(error)
        error_dot = float(error_dot)
        dt_s = float(dt_s)
        if is_zero(dt_s):  # :240-244
            return self.cmd_
        elif dt_s < 0.0:  # :245-248
            raise InvalidArgument("Pid is called with negative dt")

        # :250-254  fetch latest gains from the realtime box (try_get succeeds when uncontended)
        self.gains_ = self._gains_box.clone()
        g = self.gains_
        aw = g.antiwindup_strat_

        self.p_error_ = error  # :257  error = target - state
        self.d_error_ = error_dot  # :258

        # :261-265  non-finite inputs: cmd_ = NaN, integrator untouched (p_error_/d_error_ already stored)
        if not math.isfinite(error) or not math.isfinite(error_dot):
            print("Received a non-finite error/error_dot value", file=sys.stderr)
            self.cmd_ = NAN
            return self.cmd_

        p_term = g.p_gain_ * self.p_error_  # :268
        d_term = g.d_gain_ * self.d_error_  # :271

        if aw.type == AntiWindupStrategy.UNDEFINED:  # :273-277
            raise RuntimeError(
                "PID: Antiwindup strategy cannot be UNDEFINED. Please set a valid antiwindup strategy."
            )

        # :279-280  deadband test: |error| <= error_deadband  -> "in deadband" (inclusive)
        is_error_in_deadband_zone = is_zero(error, aw.error_deadband)

        # :283  command uses the integrator state from BEFORE this step's update
        self.cmd_unsat_ = p_term + self.i_term_ + d_term

        # :285-300  output saturation
        if math.isfinite(g.u_min_) or math.isfinite(g.u_max_):
            if g.u_min_ > g.u_max_:  # :287-290
                raise RuntimeError("Pid: Error while saturating the command : u_min > u_max")
            if math.isnan(g.u_min_) or math.isnan(g.u_max_):  # :291-294
                raise RuntimeError("Pid: Error while saturating the command : u_min or u_max is NaN")
            self.cmd_ = std_clamp(self.cmd_unsat_, g.u_min_, g.u_max_)  # :295
        else:
            self.cmd_ = self.cmd_unsat_  # :299

        # :301-322  integrator update (forward Euler, with THIS step's error; affects the NEXT command)
        if not is_error_in_deadband_zone:
            if aw.type == AntiWindupStrategy.BACK_CALCULATION and not is_zero(g.i_gain_):  # :303-305
                # :307-308  i_term_ += dt_s * (i_gain * error + 1 / Tt * (cmd_ - cmd_unsat_));
                self.i_term_ += dt_s * (
                    g.i_gain_ * error + _div(1.0, aw.tracking_time_constant) * (self.cmd_ - self.cmd_unsat_)
                )
            elif aw.type == AntiWindupStrategy.CONDITIONAL_INTEGRATION:  # :310
                # :312  integrate unless (saturated AND error has the same sign as the UNSATURATED command)
                if not ((not is_zero(self.cmd_unsat_ - self.cmd_)) and error * self.cmd_unsat_ > 0):
                    self.i_term_ += dt_s * g.i_gain_ * error  # :314
            elif aw.type == AntiWindupStrategy.NONE:  # :317
                self.i_term_ += dt_s * g.i_gain_ * error  # :320
            # BACK_CALCULATION with |i| <= eps: nothing (i_term_ frozen, NOT zeroed).

        # :324  integrator clamp, applied on every call that gets here (also inside the deadband)
        self.i_term_ = std_clamp(self.i_term_, aw.i_min, aw.i_max)

        return self.cmd_  # :326

    # ---- accessors -----------------------------------------------------------------------------
    def set_current_cmd(self, cmd: float) -> None:  # pid.cpp:329
        self.cmd_ = float(cmd)

    def get_current_cmd(self) -> float:  # pid.cpp:331
        return self.cmd_

    def get_current_pid_errors(self) -> tuple[float, float, float]:  # pid.cpp:333-338 -> (pe, ie, de)
        return self.p_error_, self.i_term_, self.d_error_


# ==================================================================================================
# How ros2_controllers' pid_controller (6.9.0) drives the PID (via control_toolbox::PidROS)
# ==================================================================================================

# pid_controller.yaml (6.9.0) per-dof defaults under gains.<dof>.*
PID_CONTROLLER_DEFAULTS = dict(
    p=0.0,
    i=0.0,
    d=0.0,
    u_clamp_max=INF,
    u_clamp_min=-INF,
    i_clamp_max=INF,
    i_clamp_min=-INF,
    antiwindup_strategy="none",
    tracking_time_constant=0.0,
    error_deadband=1.0e-16,  # NOTE: differs from the Pid class default DBL_EPSILON (2.22e-16)
    feedforward_gain=0.0,
    angle_wraparound=False,
    save_i_term=True,  # NOTE: PidROS's own default is false; pid_controller declares true
    activate_state_publisher=False,
)


def pid_from_ros_parameters(
    p: float = 0.0,
    i: float = 0.0,
    d: float = 0.0,
    i_clamp_max: float = INF,
    i_clamp_min: float = -INF,
    u_clamp_max: float = INF,
    u_clamp_min: float = -INF,
    error_deadband: float = 1.0e-16,
    tracking_time_constant: float = 0.0,
    antiwindup_strategy: str = "none",
    saturation: bool | None = None,
) -> tuple[bool, Pid]:
    """pid_ros.cpp:157-220 PidROS::initialize_from_ros_parameters(), minus the ROS plumbing.

    `saturation` (gains.<dof>.saturation) is not in pid_controller.yaml; PidROS declares it with the
    default isfinite(u_max) || isfinite(u_min) (pid_ros.cpp:180-181).  If it is false the u-clamps
    are replaced by +-inf (pid_ros.cpp:182-186).
    """
    pid = Pid()
    u_max, u_min = float(u_clamp_max), float(u_clamp_min)
    sat = math.isfinite(u_max) or math.isfinite(u_min)  # :180
    if saturation is not None:
        sat = bool(saturation)  # :181
    if not sat:  # :182-186
        u_max, u_min = INF, -INF
    aw = AntiWindupStrategy()  # :197-202
    aw.set_type(antiwindup_strategy)  # throws (uncaught in C++) on an unknown string
    aw.i_max = float(i_clamp_max)
    aw.i_min = float(i_clamp_min)
    aw.tracking_time_constant = float(tracking_time_constant)
    aw.error_deadband = float(error_deadband)
    try:  # :204-212
        aw.validate()
    except InvalidArgument as e:
        print("Invalid antiwindup strategy: " + str(e), file=sys.stderr)
        return False, pid
    return pid.initialize(p, i, d, u_max, u_min, aw), pid  # :214-219


def pid_controller_on_activate(pid: Pid, save_i_term: bool = True) -> None:
    """pid_controller.cpp:458-462 -> PidROS::reset() (pid_ros.cpp:285-290) reads gains.<dof>.save_i_term
    (pid_controller default true) -> Pid::reset(save_i_term)."""
    pid.reset(save_i_term)


def normalize_angle(angle: float) -> float:
    """ros/angles angles.h (commit 0042845b): fmod(angle + M_PI, 2*M_PI); <=0 ? +M_PI : -M_PI."""
    result = math.fmod(angle + math.pi, 2 * math.pi)
    if result <= 0:
        return result + math.pi
    return result - math.pi


def shortest_angular_distance(from_: float, to: float) -> float:
    return normalize_angle(to - from_)


def pid_controller_dof_update(
    pid: Pid,
    period_s: float,
    ref: float,
    state: float,
    ref_dot: float = NAN,
    state_dot: float = NAN,
    two_interfaces: bool = False,
    feedforward_gain: float = 0.0,
    angle_wraparound: bool = False,
) -> float | None:
    """pid_controller.cpp:540-607, one DoF of PidController::update_and_write_commands().

    period_s is the `period` the controller_manager hands to the controller (measured: current_time -
    last_update_cycle_time; nominal 1/update_rate only on the first cycle after activation), an integer
    number of nanoseconds converted with ns / 1e9.  two_interfaces means reference_and_state_interfaces
    has 2 entries (e.g. [position, velocity]).  Returns the value written to the command interface, or
    None when nothing is written (the interface then keeps its previous value).
    """
    tmp_command = 0.0  # :542
    if math.isfinite(ref) and math.isfinite(state):  # :546
        # :548-564 feed-forward (added OUTSIDE the PID, i.e. after its u-clamp)
        if two_interfaces:
            if math.isfinite(ref_dot):
                tmp_command = ref_dot * feedforward_gain  # :557-558
        else:
            tmp_command = ref * feedforward_gain  # :563
        error = ref - state  # :566
        if angle_wraparound:  # :567-571
            error = shortest_angular_distance(state, ref)
        if two_interfaces:  # :574-592
            if math.isfinite(ref_dot) and math.isfinite(state_dot):
                # :584-585  error_dot = ref_dot - state_dot, 3-argument PID
                tmp_command += pid.compute_command(error, ref_dot - state_dot, period_s)
            else:
                tmp_command += pid.compute_command(error, period_s)  # :590 fallback
        else:
            tmp_command += pid.compute_command(error, period_s)  # :596
        return tmp_command  # :600 written to the command interface
    return None
