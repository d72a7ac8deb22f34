"""Robust PID design for uncertain time-varying systems, with the load-varying SCARA as flagship.

Use as ``import scara_robust as sr``. Every name below is re-exported from the
subpackage that defines it; each subpackage's ``__all__`` is the one source of the API.
The layers, bottom to top (each imports only those before it)::

    paper, exceptions, results  ->  sdp  ->  model  ->  controller  ->  lyapunov  ->  robustness | simulation
                       ->  io  ->  export  ->  studies  ->  plotting  ->  workflow  ->  app, cli (front ends)

The paper's numbers (:mod:`scara_robust.paper`)
    PAPER_DESIGN_POINT, PAPER_GAIN, PAPER_GAIN_DECIMALS -- (ρ*, η*) and K as printed in Section 4
    PAPER_A_STAR, PAPER_B_STAR, PAPER_TABLE1, PAPER_TABLE2 -- the published model and Tables 1-2
    PAPER_TRANSIENT, PAPER_T_FINAL  -- "after 6 s" of Figures 3 and 6; the 20-s horizon
    PAPER_PAYLOAD_FRACTION, PAPER_CP -- payload m_p = 0.3 m2 (sin t + 1), I_p = c_p m_p
    PAPER_DISTURBANCE_AMPLITUDE, PAPER_DISTURBANCE_PERIOD -- ±5 N·m square waves, period π/5 s
    PAPER_INITIAL_ERRORS            -- the large and small initial conditions
Results (:mod:`scara_robust.results`)
    AnalysisResult, RESULT_FIELDS   -- base of every certificate and bound: certified, verdict, status, message
    CertificateRow, verdict_of      -- one row of certificate_table; the verdict of a yes/no/unknown answer
Errors (:mod:`scara_robust.exceptions`)
    ScaraRobustError                -- base of every error raised on purpose
    ArgumentError, ArgumentValueError, ArgumentTypeError -- a bad argument, named by its parameter
    InputFileError, CampaignSpecError -- a bad robot, scenario or campaign file, naming file and field
    OptionError                     -- a front end's input that cannot be used (naming the option, e.g. --robot)
    MissingToolError                -- a program a command needs (a cross-compiler, an emulator) is not installed
The LMI solver (:mod:`scara_robust.sdp`)
    LMIProblem, LMIVariable, LMIFamily -- an LMI described once: variables, blocks of terms UᵀXV + VᵀXᵀU, objective
    solve_lmi, LMI_BACKENDS, LMIResult -- solve it: the package's interior-point method or cvxpy + Clarabel
    solve_lmi_interior              -- a margin form's strictly interior point where rounding stops the optimum short
    default_lmi_solver, use_lmi_solver -- the solver of every analysis's solver=None, and a block that changes it
    resolve_lmi_solver              -- an analysis's solver argument checked, None as the default
    solve_ipm, solve_lmi_cvxpy      -- the two backends: structure-exploiting NT predictor-corrector; cvxpy's
    dense_schur                     -- the Schur complement by its definition, the reference of the structured one
Model (:mod:`scara_robust.model`)
    UncertainSystem, CAPABILITIES   -- what every uncertain system is, and what it can do (intervals, vertices, ...)
    ScaraParams, PARAM_UNITS, PARAM_LIMITS, paper_params -- robot data (SI, plausible ranges), the paper's by default
    SinusoidalPayload, ConstantPayload, paper_payload, payload_range -- payload mass profiles m_p(t)
    mass_matrix, coriolis, forward_dynamics, kinetic_energy -- Eq. (1)
    error_dynamics_jacobians        -- linearized error dynamics (Eq. 3)
    scara_plant                     -- the robot as a control.NonlinearIOSystem
    Reference, paper_reference, sinusoidal_reference -- joint references with derivatives
    SquareWave, paper_disturbance   -- square-wave disturbance torques
    MeasurementNoise                -- band-limited noise on the measured joint angles
    Scenario, SCENARIOS             -- initial tracking errors ('large', 'small')
    UncertainElement, UncertainLTVModel, ELEMENT_SETS -- ẋ = (A + ΔA)x + (B + ΔB)u with interval elements
    ANCHORS                         -- what a margin θ scales the set about: the lower corner or the centre
    paper_model, derived_model      -- published bounds / bounds derived from the robot
    physical_samples, PhysicalSamples -- the robot's own (A, B) along the reference
    scara_perturbed_samples, PerturbedSamples -- those plants with Eq. (4)'s perturbation as bounded channels
    PolytopicModel                  -- (A(t), B(t)) in the convex hull of vertices; box_hull() for Theorem 1
    pid_augment, integral_augment, augment_table, AUGMENT_FORMS -- your plant in PID form (Eq. 4) / integral form
    UncertainPlant, Parameter, Signal -- the uncertain plant over named physical parameters (units, ranges, rates)
    NonlinearDynamics               -- a control.NonlinearIOSystem behind a plant (UncertainPlant.from_nonlinear)
    ParameterSamples, PLANT_FORMS   -- its frozen plants on a grid; its design forms; the sampled hull's rtol
    POSITIVE_UNITS                  -- units of a mass, a length, an inertia: a parameter positive by its unit
    scara_uncertain_plant, SCARA_BOUNDS -- the SCARA with its payload as an UncertainPlant (derived or published hull)
    RobotArm, ArmSetup, JointSinusoids -- any arm from its URDF with a varying payload (Pinocchio, extra ``robots``)
    PayloadTerms                    -- an arm's inverse-dynamics derivatives, affine in the payload mass
    effort_limited_payload, EffortPayload -- the largest payload the joints' effort limits carry along the reference
    holding_torque                  -- each joint's largest torque holding the reference over the payload range
    arm_perturbed_samples           -- an arm's samples with Eq. (4)'s perturbation: T_d, the feedforward's residual
    integral_drift, IntegralDrift, DRIFT_RATE_STEP -- that residual as a slow torque a PID's integral absorbs
    arm_feedforward, ArmFeedforward, FEEDFORWARD_RTOL -- an arm's model feedforward as the exported controller runs it
    arm_uncertain_plant, FEEDFORWARDS -- its error dynamics along a reference as an UncertainPlant; its feedforwards
    require_pinocchio               -- import Pinocchio or name the extra to install
The controller on a board (:mod:`scara_robust.controller`)
    DiscretePID, INTEGRATOR_METHODS, DERIVATIVE_MODES -- Design.discretize(Ts): sampled PID, limits, anti-windup
    default_tracking_time           -- the anti-windup tracking time sqrt(T_i T_d) per joint
    SampledStateFeedback            -- u_k = -K x(t_k) held by a zero-order hold: a gain of your own, sampled
    ScheduledGain, load_schedule, SCHEDULE_KIND -- gains at breakpoints of a measured parameter, linear between
    SampledScheduledGain            -- u_k = -K(p̂_k) x(t_k) held: the scheduled gain as exported to C
    single_precision_step           -- the PID's float32 step in the C's order, which the single-precision C matches
    check_controller, controller_kind, SAMPLED_CONTROLLERS -- a sampled controller by its kind, never its class
    schedule_of, held_gain          -- a gain's schedule, and a held gain's K and Ts
The paper's method (:mod:`scara_robust.lyapunov`)
    design, Design, riccati_solution -- K from (ρ, η), steps 2-3
    design_or_none                  -- a Design, or None for a plain gain
    certify, Certificate, UltimateBound -- Theorem 1 and Corollary 1
    design_surface, DesignSurface, SURFACE_FORMULATIONS, SURFACE_METHODS -- max λ(Z) over a (ρ, η) grid (Fig. 2)
    MAX_SURFACE_POINTS              -- the largest grid of one call and its memory
    SURFACE_MEASURES, MARGIN_MAP_METHODS -- design_surface(measure='margin'): the margin θ(ρ, η) map
Beyond Theorem 1 (:mod:`scara_robust.robustness`)
    AnalysisMethod, register_method, unregister_method -- one registry of every analysis method, by family
    analysis_methods, get_method, checked_result -- its names, one method, the check of a method's result
    METHOD_FAMILIES, METHOD_BOUNDS, METHOD_NEEDS -- certificate, margin, parameter, payload; lower/upper; needs
    CertificateContext, PayloadContext -- what a registered method is given
    bisect, MIDPOINTS               -- the one bisection of every margin, range, rate and sample-time search
    vertex_certificate, physical_certificate, polytope_certificate, PolytopeCertificate -- exact test of P
    lmi_certificate, LMICertificate, verify_lyapunov -- common quadratic P by SDP (extra ``lmi``), by cutting planes
    lmi_search, LMI_STOPS           -- the common-P test of a search, each solve from the last active set
    LMI_VERDICTS                    -- what an LMI answer proves: certified, infeasible, inaccurate, unknown
    LMI_SOLVERS, cvxpy_available    -- its solvers, and whether cvxpy is there
    falsify, FalsifierResult, FALSIFIER_RULES -- search for a destabilizing switching signal
    certificate_table, CERTIFICATE_METHODS -- every certificate of one design (``certify`` command)
    robustness_margin, margin_table, Margin, MARGIN_METHODS, MARGIN_TOL -- how much uncertainty a design tolerates
    worst_loop_margins, LoopMargins -- each input's worst disk margin (±dB, ±°) and delay margin (s), frozen plants
    loop_view, LoopView             -- one loop of one frozen plant: its step response and Bode data, its margins
    frozen_loop_views               -- each loop's view at the frozen plant of its smallest delay margin
    payload_margin, PAYLOAD_METHODS -- the robot's largest certified payload, kg (``margin`` command)
    synthesize, Synthesis, decay_rate, GAIN_BOUND -- a gain with its own certificate (LMI, extra ``lmi``)
    OBJECTIVES                      -- its objectives: decay, worst-case L2 gain to the error e, margin θ
    STRUCTURES, decentralized_pattern -- any gain, or one PID per joint (block-diagonal Q and Y)
    input_limit_certificate, InputLimitCertificate -- the initial errors certified within the input limits
    initial_error_vertices, MAX_BOX_CORNERS -- a box of initial errors as its corners; the most enumerated
    peak_inputs                     -- each input's peak |u| of a simulated run
    step_initial_errors             -- the initial errors of a reference step from rest, on the PID form's state
    LIMIT_MARGIN, MAX_LIMIT_VERTICES -- synthesize with input limits: the initial errors' margin, the most points
    l2_gain, L2Gain, L2_INFLATION   -- worst-case L2 gain: bounded-real LMI (upper, inflated), frozen H∞ norms (lower)
    rate_bounded_l2_gain, RateL2Gain, verify_rate_bounded_l2 -- the L2 gain for |ṗ| <= ν, P(p) = P0 + p·P1
    peak_gain, PeakBound            -- worst-case peak for bounded disturbances: invariant ellipsoid, worst sinusoid
    tracking_bound, TrackingBound   -- the certified tracking error after a settling time: invariant ellipsoid, decay
    tracking_bound_problem, ellipsoid_tracking_bound -- its LMI at one rate; numpy's check of an ellipsoid
    tune_gain, GainTuning           -- the smallest gain bound whose synthesized gain meets an error requirement
    tracking_gain, TrackingGain, tracking_synthesis_problem, ALPHA_SETTLING -- the best gain at one bound; its LMI
    CHANNEL_ITERATIONS              -- syntheses at one gain bound when the channels depend on the gain
    input_peaks                     -- each input's largest |k_i x| on an ellipsoid (the torque the synthesis holds)
    rate_bounded_certificate, RateCertificate, verify_rate_bounded -- P(p) = P0 + p·P1 for |ṗ| <= ν (extra ``lmi``)
    synthesize_schedule, ScheduleSynthesis, schedule_riccati -- a gain scheduled on a measured parameter
    synthesize_schedule_rate        -- the scheduled gain certified for the fastest parameter (extra ``lmi``)
    schedule_certificate, ScheduleCertificate, max_schedule_rate, max_measurement_error, schedule_decay -- its
                                    certificate for |ṗ| <= ν and |p̂ − p| <= δ (extra ``lmi``)
    scheduled_parameter, SCHEDULE_POINTS, SCHEDULE_REFINE -- the parameter scheduled on; the grids
    schedule_sampled_certificate    -- the scheduled gain held at Ts: one discrete P, exact in p̂ (extra ``lmi``)
    max_certified_rate, RateMargin  -- the largest certified rate ν, by bisection
    payload_rate_certificate        -- the robot's largest certified payload rate, kg/s
    payload_switching_growth        -- growth under a periodic payload ramping at a given rate (the other side)
    parameter_margin, PARAMETER_METHODS -- the certified range of every parameter, in its unit (``margin --model``)
    frozen_end                      -- which end of a parameter's range holds the unstable frozen plant, in its unit
    frozen_limit                    -- one parameter's frozen bound and its end, from a parameter_margin table
    design_decay_rate, certified_decay_rate, DecayRate, DECAY_RTOL -- a design's decay rate: its own P or an LMI's
                                    refined towards the decay-optimal common P, the larger
    parameter_rate, rate_bracket, RateBracket -- how fast a parameter may vary, unit/s: certificate below, growth above
    parameter_switching_growth      -- growth under a periodic ramp of a parameter at a given rate
    sampled_closed_loops, sampled_certificate, SampledCertificate -- exact ZOH loops, discrete common P
    discrete_lyapunov_check         -- numpy's check of A_iᵀPA_i − P ≺ 0
    max_sample_time, SampleTimeLimit -- largest certified Ts and smallest Ts with an unstable frozen plant
    MAX_SAMPLE_TIME_CAP             -- where max_sample_time stops looking for a frozen instability, s
    check_sample_time, SampleTimeCheck -- is this Ts safe? (run by ``export``)
    synthesize_sampled, SampledSynthesis -- a gain certified for the loop held at a given Ts (LMI on ZOH plants)
    jitter_certificate, max_jitter, JitterCertificate -- every period in [Ts - J, Ts + J], in any order
    JITTER_PERIODS, JITTER_CHECK_PERIODS -- the periods of its LMI and of numpy's check
Simulation (:mod:`scara_robust.simulation`)
    Run                             -- what every run has: t, e, u, status, reason, max_abs_error, peak_input, to_pandas
    simulate_plant, PlantRun, PLANT_TRACKING_RTOL -- any UncertainPlant in closed loop with parameters p(t)
    simulate_arm, ArmRun, ARM_ENGINES -- an arm from its URDF (Pinocchio's ABA) under the PID, with a varying payload
    parameter_profile, PROFILES     -- p(t): constant, sinusoid, ramp, random walk within the rate bound, CSV column
    pid_controller, sliding_mode_controller, SlidingModeGains -- the controllers
    pid_lmi_gain                    -- the synthesized gain the ``pid-lmi`` controller runs
    compiled_run, compiled_batch, CompiledRun -- the compiled engine (numba, extra ``compiled``)
    numba_available                 -- its packed inputs, scope, compile cost
    COMPILED_INTEGRATORS            -- its integrators of a continuous law: stiff BDF (default) or Dormand–Prince
    CONTROLLERS, ControllerKind, SAMPLE_TIMES, make_controller -- controllers by name, with sample times
    sampled_pid_controller, SampledPID -- a DiscretePID on the robot, zero-order hold (``pid-sampled``)
    scheduled_pid_controller        -- the SCARA's PID with its gain scheduled on the measured payload
    ENGINES                         -- integrators by name
    simulate, run_scenario, SimulationResult -- one run (``simulate`` command)
    run_scenarios                   -- many runs, the compiled ones batched (a campaign chunk)
    tracking_metrics, TrackingMetrics, METRIC_NAMES -- errors and torques after the transient
    STATUSES, TRACKING_TOLERANCE    -- does a run track: tracking, not-tracking, diverged, failed, too-short
Files (:mod:`scara_robust.io`)
    load_robot, load_scenario, ScenarioFile -- robot and scenario files
    load_model, load_plant, MODEL_FORMS -- your plant's file: physical parameters, an interval model or a polytope
    load_arm, is_arm_file, ARM_KEYS -- a robot file naming a URDF: the arm, its payload, reference and feedforward
    controller_sample_time, CONTROLLER_KEYS -- the sample time a robot or plant file gives its controller, s
    file_requirements, REQUIREMENT_KEYS -- what a robot file's [requirements] asks of the loop (tune)
    write_design, load_design, DesignFile -- design files (``synthesize --output``)
    load_pid_controller, PidControllerGains -- a ros2_control pid_controller's YAML (``--design F.yaml``)
    PID_CONTROLLER_GAINS, PID_CONTROLLER_KEYS, PID_CONTROLLER_TYPE -- its per-joint keys, its keys, its type
    PID_CONTROLLER_METHOD, ros2_dof_name -- the method a design file read from it records; a joint's ROS name
Export (:mod:`scara_robust.export`)
    export_controller, c_source, controller_record, EXPORT_FORMATS, DEFAULT_PREFIX -- C99, JSON, ros2 (``export``)
    PRECISIONS                      -- the C's floating-point types, double or single
    ExportTarget, register_target, unregister_target, export_targets, get_target -- the formats, by name
    pid_controller_parameters, coupling_of -- a per-joint PID as ros2_control's pid_controller parameters
    ROS2_ERROR_DEADBAND             -- pid_controller's default error deadband, rad: the integral is frozen within it
    update_rate_of                  -- pid_controller's update rate for a Ts (a whole number of Hz)
    run_on_board, BoardRun, board_inputs, Board, BOARDS, check_toolchain -- the C on an emulated Cortex-M4F
Studies (:mod:`scara_robust.studies`)
    compare_controllers, COMPARISON_COLUMNS, COMPARED_CONTROLLERS -- the PID vs sliding-mode table (``compare`` command)
    compare_plant_designs           -- a plant's designs side by side: certificates, margins, a run (``compare``)
    compare_schedules, ScheduleRun  -- scheduled and fixed gains side by side: decay, rate, error, runs
    plant_schedule_run, scara_schedule_run, arm_schedule_run -- how compare_schedules runs a plant, the SCARA, an arm
    reproduction_table              -- the paper's claims next to the package's results
    error_sensitivity               -- the PID's error after 6 s against L2, payload and disturbance phase
    load_spec, spec_from_dict, CampaignSpec, Range, PAYLOAD_PROFILES, draw_scenario -- campaign specs
    run_campaign, read_results      -- run (local or Dask), resume
    replay_scenario                 -- run one row of a campaign table again (``simulate --from-campaign``)
    arm_campaign_spec, draw_arm_scenario, run_arm_draws, replay_arm_scenario, ARM_SPEC_FIELDS -- arm campaigns
    campaign_report                 -- per-controller statistics with confidence intervals
    worst_scenarios                 -- the worst runs of each controller with their drawn inputs
    anti_windup_study, AntiWindupStudy -- the sampled PID under a torque limit, anti-windup on/off
Plotting (:mod:`scara_robust.plotting`)
    plot_surface, plot_surface_contour, plot_response, plot_signals, plot_campaign, plot_comparison, SIGNALS
    plot_margin_map, plot_margin_bracket -- the margin θ(ρ, η) map and the bounds at one design
    plot_anti_windup                -- errors and torques under a torque limit, with and without anti-windup
    plot_plant_run                  -- a plant run: outputs and references, errors, inputs, parameters, with units
    plot_arm_run                    -- an arm run: joint errors, torques and payload over time
    plot_schedule                   -- a scheduled gain's entries against its parameter, a fixed gain beside
    plot_loop_views                 -- each loop's step response and Bode plot, the margins marked, per gain
The workflow the front ends share (:mod:`scara_robust.workflow`)
    open_system, SYSTEM_KINDS, LoadedSystem -- the system a design runs on, from the files a user names, by kind
    ScaraSystem, PlantFileSystem, ArmSystem -- the built-in SCARA, a plant file, an arm of a URDF robot file
    Setup, Capabilities, PhysicalSet -- the SCARA's robot and signals; what a system can do; synthesis samples
    CERTIFICATE_GRID, CERTIFICATE_CHECK_GRID -- the SCARA's samples of the sampled-data certificate
    load_input                      -- a file read with the option that named it in any error
    design_answer, DesignAnswer     -- K(ρ, η) of a system, its certificate and the design file that records them
    export_certified, ExportedDesign -- certify a controller at its Ts on the system, then write a target's files
    export_pid                      -- K(ρ, η) with the PID's defaults, certified and written as C (the page's)
    state_feedback_of, check_state_form -- static state feedback for a plant in the state form
    simulate_system                 -- one closed-loop run of any system under any controller: a Run
    Requirements, tune_system, TuneReport -- a PID tuned to stated requirements, certified, run on the robot
    evaluate_gain, GainEvaluation, loop_checks -- one gain against the requirements: bound beside simulated error
    search_tracking_error, TrackingSearch -- the nonlinear robot over payload and disturbance profiles
    worst_loop_views                -- each loop's step response and Bode data at its worst frozen plant
    TUNE_GRID, TUNE_CHECK_GRID      -- the samples of the tuning's LMIs and numpy's checks
    ARM_TUNE_GRID, ARM_TUNE_CHECK_GRID -- those of a URDF arm
    torque_limits                   -- the torque each input must stay within: the requirement's or the URDF's
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.2.0"

#: The subpackages whose ``__all__`` make the API, in the order of the index above.
_SUBPACKAGES = ("paper", "exceptions", "sdp", "model", "controller", "lyapunov", "results", "robustness",
                "simulation", "io", "export", "studies", "plotting", "workflow")

if TYPE_CHECKING:  # what the names are, for type checkers; at run time they are imported on first use
    from .controller import *  # noqa: F403
    from .exceptions import *  # noqa: F403
    from .export import *  # noqa: F403
    from .io import *  # noqa: F403
    from .lyapunov import *  # noqa: F403
    from .model import *  # noqa: F403
    from .paper import *  # noqa: F403
    from .plotting import *  # noqa: F403
    from .results import *  # noqa: F403
    from .robustness import *  # noqa: F403
    from .sdp import *  # noqa: F403
    from .simulation import *  # noqa: F403
    from .studies import *  # noqa: F403
    from .workflow import *  # noqa: F403


def _api() -> list[str]:
    """Import every subpackage and bind its ``__all__`` here, once; the API's names, in order.

    The numerical stack (scipy, pandas, python-control, matplotlib) takes a second or more to
    import: ``import scara_robust`` and the command line's ``--help`` do not pay it, the first
    use of a name does.
    """
    if "__all__" not in globals():
        names: list[str] = []
        for sub in _SUBPACKAGES:
            module = importlib.import_module(f".{sub}", __name__)
            globals().update({name: getattr(module, name) for name in module.__all__})
            names.extend(module.__all__)
        globals()["__all__"] = names
    api: list[str] = globals()["__all__"]
    return api


def __getattr__(name: str) -> Any:
    if name.startswith("__") and name != "__all__":  # inspect, doctest and pickle ask for dunders: none here
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    api = _api()
    if name == "__all__":
        return api
    if name in globals():
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_api()))
