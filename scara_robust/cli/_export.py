"""``export``: the designed PID, discretized, as JSON or C99 source for a controller board."""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from typing import Any

import numpy as np

from .._validation import os_error_text
from ..controller.discrete import DERIVATIVE_MODES, INTEGRATOR_METHODS, DiscretePID
from ..controller.kinds import check_controller
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import ArgumentValueError
from ..export import DEFAULT_PREFIX, PRECISIONS, ROS2_ERROR_DEADBAND, coupling_of, export_targets, update_rate_of
from ..export._common import check_prefix
from ..io import PID_CONTROLLER_METHOD
from ..lyapunov.gain import design
from ..workflow.export import check_state_form, export_certified, state_feedback_of
from ._board import add_board_options, check_board_options, run_board
from ._common import (
    CommandLineError,
    add_setup_options,
    check_gain_options,
    finite_float,
    per_joint_values,
    resolve_design,
    resolve_gain,
)
from ._parser import COMMAND_HELP
from ._schedule import add_schedule_options, is_schedule_file, refuse_schedule_options, run_schedule_export
from ._system import LoadedSystem

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    """Register ``export``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "export",
        help=COMMAND_HELP["export"],
        description="Design K at (rho, eta), discretize it (Design.discretize) and write it into the folder "
        "--output: --format c writes PREFIX.h and PREFIX.c (PREFIX_init, PREFIX_step), --format json "
        "PREFIX.json with every gain and limit. Without options, the controller of Design.discretize(Ts). "
        "A plant file in the state form gets static state feedback u = -K x(t_k), held (PREFIX_step(x, u)). "
        "The sampled-data certificate runs first, on --model's plants or the robot's physical set: a Ts it "
        "does not certify is refused with the largest certified Ts, unless --allow-uncertified.",
    )
    p.add_argument("--rho", type=finite_float, help="design parameter rho > 0 (or --design)")
    p.add_argument("--eta", type=finite_float, help="design parameter eta >= 1 (or --design)")
    p.add_argument("--design", metavar="FILE.json",
                   help="export the PID gain of a design file (design --output, synthesize --output; or a ros2_control "
                   "pid_controller .yaml, its clamp and anti-windup as --torque-limit and --tracking-time) instead, "
                   "or a schedule file (synthesize --schedule --output): PREFIX_step(x, p_hat, u) with its breakpoint "
                   "table, refused beyond the rate and measurement error it was certified for")
    add_setup_options(p, scenario="signals", model=True)
    p.add_argument("--ts", type=finite_float, required=True, help="sample time, s (> 0)")
    p.add_argument("--integrator", choices=INTEGRATOR_METHODS, default=None,
                   help="discretization of the integral (default tustin; forward with --format ros2, as "
                   "pid_controller integrates)")
    p.add_argument("--derivative", choices=DERIVATIVE_MODES, default="measured",
                   help="measured edot, or a filtered difference of e (no joint velocity needed)")
    p.add_argument("--filter-n", type=finite_float, default=100.0, help="derivative filter bandwidth N, 1/s (> 0)")
    p.add_argument("--ts-jitter", type=finite_float, default=None, metavar="J",
                   help="also certify every sample period in [TS - J, TS + J], s, in any order (pid_controller "
                   "integrates over the measured period, which jitters); refused like --ts where it fails, and "
                   "written into the files")
    p.add_argument("--torque-limit", type=per_joint_values, default=None, metavar="L[,L2,...]",
                   help="per-joint torque limit, N·m (> 0): one value for all joints or one per joint")
    p.add_argument("--tracking-time", type=per_joint_values, default=None, metavar="T[,T2,...]",
                   help="anti-windup tracking time T_t, s (>= Ts; default sqrt(T_i T_d) per joint)")
    p.add_argument("--no-anti-windup", action="store_true", help="leave the integrator free against the limit")
    add_schedule_options(p, synthesis=False)
    p.add_argument("--allow-uncertified", action="store_true",
                   help="write the controller even where the sampled-data certificate fails at --ts (the header "
                   "and the JSON say so); by default such a Ts is refused")
    p.add_argument("--format", choices=export_targets(), default="c")  # every registered export target
    p.add_argument("--prefix", default=None,
                   help=f"C identifier of the names and files (default: the plant file's `prefix`, {DEFAULT_PREFIX} "
                   "for the robot)")
    p.add_argument("--precision", choices=PRECISIONS, default="double",
                   help="C floating-point type: double (default) or single, for a single-precision FPU")
    p.add_argument("--output", dest="folder", metavar="DIR", required=True, help="existing, writable folder")
    add_board_options(p)
    p.set_defaults(func=run)


def _check_folder(folder: str) -> None:
    if not os.path.isdir(folder):
        why = "is a file, not a folder" if os.path.exists(folder) else "no such folder"
        raise CommandLineError(f"`--output` {folder!r}: {why}")
    try:  # os.access says yes to root on read-only file systems; a real probe does not
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".tmp-")
    except OSError as err:
        raise CommandLineError(f"`--output` {folder!r}: the folder is not writable ({os_error_text(err)})") from err
    os.close(fd)
    os.unlink(probe)


def _pid_options(args: argparse.Namespace) -> list[str]:
    """The PID's options given with other than their defaults (for a controller that has none of them)."""
    return [o for o, v, default in (("--integrator", args.integrator, None),
                                    ("--derivative", args.derivative, "measured"),
                                    ("--filter-n", args.filter_n, 100.0),
                                    ("--torque-limit", args.torque_limit, None),
                                    ("--tracking-time", args.tracking_time, None),
                                    ("--no-anti-windup", args.no_anti_windup, False)) if v != default]


def _check_ros2_options(args: argparse.Namespace, system: LoadedSystem) -> None:
    """``--format ros2``: a PID per joint as pid_controller runs it (forward Euler, measured ė, double)."""
    if system.state_feedback:
        raise CommandLineError(f"`--format ros2` writes a pid_controller (a PID per joint); --model {system.file!r} "
                               "is in the state form")
    if args.integrator not in (None, "forward"):
        raise CommandLineError(f"`--integrator {args.integrator}`: pid_controller (control_toolbox) integrates by "
                               "forward Euler; --format ros2 certifies and writes that")
    if args.derivative != "measured":
        raise CommandLineError("`--derivative filtered`: pid_controller reads the error rate from the velocity "
                               "interfaces (measured)")
    if args.precision != "double":
        raise CommandLineError("`--precision` is the C's floating-point type; --format ros2 writes YAML")
    try:
        update_rate_of(args.ts)
    except ArgumentValueError as err:
        raise CommandLineError(f"`--ts` {err.problem}") from err


def _feedforward(args: argparse.Namespace, system: LoadedSystem, ros2: bool) -> Any:
    """The model feedforward the arm's loop was certified with, for the exported controller (None without one)."""
    setup_ff = system.arm().feedforward if system.capabilities.run == "arm" else "none"
    if setup_ff == "none":
        return None
    if ros2:
        raise CommandLineError(f"`--format ros2`: {system.file!r} certifies its loop with the {setup_ff} "
                               "feedforward, which a pid_controller file cannot carry; export it as C (--format c), "
                               "or design with feedforward = \"none\" in the robot file, whose certificate then "
                               "treats gravity as the disturbance it is")
    if args.precision != "double":
        raise CommandLineError(f"`--precision {args.precision}`: the {setup_ff} feedforward of {system.file!r} is "
                               "exported in double precision (its RNEA is checked against Pinocchio in double)")
    try:
        return system.feedforward()
    except ArgumentValueError as err:
        raise CommandLineError(f"`--robot` {system.file!r}: {err.problem}") from err


def _pid_controller_options(args: argparse.Namespace, info: dict[str, Any]) -> dict[str, Any]:
    """The torque limit and anti-windup of a pid_controller file (``--design F.yaml``), unless given as options."""
    strategies = set(info["antiwindup_strategy"])
    if "conditional_integration" in strategies:
        raise CommandLineError(f"`--design` {args.design!r}: antiwindup_strategy 'conditional_integration' is not the "
                               "package's PID (back_calculation or none)")
    dropped = [name for name, kept in (("i_clamp", all(math.isinf(v) for v in info["i_clamp"])),
                                       ("feedforward_gain", not any(info["feedforward_gain"])),
                                       ("angle_wraparound", not any(info["angle_wraparound"]))) if not kept]
    if dropped:
        raise CommandLineError(f"`--design` {args.design!r}: {dropped[0]} is set, and the package's PID has no such "
                               "term: the export would drop it (remove it from the file, or keep your file)")
    clamp = np.array(info["u_clamp"], dtype=float)
    band = sorted(set(info.get("error_deadband", [])))
    if len(band) > 1:
        raise CommandLineError(f"`--design` {args.design!r}: error_deadband differs between joints ({band}); the "
                               "package's PID takes one")
    out: dict[str, Any] = {"error_deadband": band[0]} if band and band[0] >= 0 else {}
    if args.torque_limit is None and np.isfinite(clamp).any():
        if not np.isfinite(clamp).all():
            raise CommandLineError(f"`--design` {args.design!r}: u_clamp is given for some joints only; the PID "
                                   "limits all of them or none (give --torque-limit)")
        out["torque_limit"] = clamp
        if strategies == {"none"}:
            out["anti_windup"] = False
        elif args.tracking_time is None:
            # control_toolbox's own time constant: the file's, or where it is 0 its default from p, i, d
            tt = np.array(info["tracking_time"], dtype=float)
            if (tt > 0).all() and np.isfinite(tt).all():
                out["tracking_time"] = tt
    return out


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Design (or read), discretize, certify at Ts and write the files; the list of files written.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str

    Raises
    ------
    CommandLineError
        For a Ts the sampled-data certificate does not hold at (without
        ``--allow-uncertified``), naming the largest certified Ts and the smallest Ts
        with an unstable frozen plant.
    """
    _check_folder(args.folder)  # before any computation
    if args.ts_jitter is not None and not 0 <= args.ts_jitter < args.ts:
        raise CommandLineError(f"`--ts-jitter` must be in [0, --ts) s (a period stays > 0), found {args.ts_jitter:g}")
    if args.prefix is not None:
        check_prefix(args.prefix)
    check_board_options(args)
    if is_schedule_file(args.design):
        if args.ts_jitter is not None:
            raise CommandLineError("`--ts-jitter` certifies a PID or state feedback over jittering periods; a "
                                   "schedule's export certifies its own Ts")
        changed = _pid_options(args)
        if changed:
            raise CommandLineError(f"`{changed[0]}` is an option of the PID; a schedule file's controller is "
                                   "u = -K(p_hat) x(t_k) held")
        return run_schedule_export(args, system)
    refuse_schedule_options(args, "--design SCHEDULE.json")
    check_gain_options(args)
    ros2 = args.format == "ros2"
    if ros2:
        _check_ros2_options(args, system)
    feedforward = _feedforward(args, system, ros2)
    model = system.model
    prefix = args.prefix or system.plant_prefix(DEFAULT_PREFIX)
    signals: dict[str, Any] = system.signal_names()
    effort = system.effort_limits() if args.torque_limit is None else None  # an arm's, its default limit
    options = {"integrator": args.integrator or ("forward" if ros2 else "tustin"), "derivative": args.derivative,
               "N": args.filter_n, "torque_limit": args.torque_limit if effort is None else list(effort),
               "tracking_time": args.tracking_time, "anti_windup": not args.no_anti_windup,
               **({"error_deadband": ROS2_ERROR_DEADBAND} if ros2 else {}),
               **({"feedforward": feedforward} if feedforward is not None else {})}
    if system.state_feedback:
        check_state_form(system)
        changed = _pid_options(args)
        if changed:
            raise CommandLineError(f"`{changed[0]}` is an option of the PID; --model {system.file!r} is in the state "
                                   "form, whose controller is u = -K x(t_k) held")
        d, gain = resolve_gain(args, model, system.joint_names())
        controller: DiscretePID | SampledStateFeedback
        controller, signals = state_feedback_of(system, d, args.ts)
        gain = f"static state feedback, {gain}"
        meta: dict[str, Any] = ({"design_file": args.design} if args.design is not None else
                                {"rho": d.rho, "eta": d.eta})
        meta["model"] = model.name
        decay_of: tuple[Any, Any] = (d, None)
    elif args.design is not None:
        # a pid_controller file's joints come in the plant's order
        loaded = resolve_design(args, (model.n_states // 3, model.n_states), "this plant's PID (x = [∫e, e, ė])",
                                system.joint_names())
        assert loaded is not None
        m, n = loaded.K.shape
        if n != 3 * m:
            raise CommandLineError(f"`--design` {args.design!r}: field `K` must have shape (p, 3p) for a PID "
                                   f"(x = [∫e, e, ė]), found {loaded.K.shape}")
        if loaded.info.get("method") == PID_CONTROLLER_METHOD:  # its clamps and anti-windup
            options.update(_pid_controller_options(args, loaded.info))
        p = m
        controller = DiscretePID(args.ts, -loaded.K[:, :p], -loaded.K[:, p:2 * p], -loaded.K[:, 2 * p:], **options)
        gain = f"gain of {args.design!r}"
        meta = {"design_file": args.design, "model": model.name}
        decay_of = (loaded.K, loaded.P)
    else:
        d = design(model, args.rho, args.eta)
        controller = d.discretize(args.ts, **options)
        gain = f"PID at (rho, eta) = ({d.rho:g}, {d.eta:g})"
        meta = {"rho": d.rho, "eta": d.eta, "model": model.name}
        decay_of = (d, None)
    if ros2:  # a PID: export refused state feedback and schedules above; refused before the decay rate's LMI
        coupled = coupling_of(check_controller("controller", controller, ("pid",)))
        if coupled is not None:
            raise CommandLineError(f"`--format ros2` writes one PID per joint (pid_controller), and this gain is "
                                   f"coupled ({coupled}); synthesize --structure decentralized gives a per-joint PID")
    decay = system.decay_rate(decay_of[0], P=decay_of[1])
    source = system.source(model, sep=" ")
    exported = export_certified(system, controller, args.folder, meta=meta, decay=decay, prefix=prefix,
                                format=args.format, precision=args.precision, signals=signals,
                                allow_uncertified=args.allow_uncertified,
                                board=lambda ctrl, name: run_board(args, ctrl, name), jitter=args.ts_jitter)
    files, result, own, board = exported.files, exported.certificate, exported.tustin, exported.board
    if controller.kind == "state feedback":
        lines = [f"{gain}, {source}, Ts = {controller.Ts:g} s, u = -K x(t_k) held, {args.precision} precision",
                 ("" if result.certified else "WARNING: not certified; ") + result.message, decay.message]
        lines += [n[len("Jittering period: "):].rstrip(".") for n in exported.notes if n.startswith("Jittering")]
        lines += [] if board is None else [board.message]
        return "\n".join([*lines, *(f"wrote {f}" for f in files)])
    pid = check_controller("controller", controller, ("pid",))
    lines = [f"{gain}, {source}, Ts = {pid.Ts:g} s, integrator {pid.integrator}, derivative {pid.derivative}, "
             + ("ros2_control pid_controller" if ros2 else f"{args.precision} precision"),
             ("" if result.certified else "WARNING: not certified; ") + ("pid_controller (forward Euler): " if ros2
                                                                          else "") + result.message]
    lines += [n[len("Jittering period: "):].rstrip(".") for n in exported.notes if n.startswith("Jittering period")]
    if own is not None:
        lines.append(f"the package's Tustin PID at the same Ts: {own.message}")
        if pid.torque_limit is None:
            lines.append("no output clamp: u_clamp is ±inf and antiwindup_strategy 'none' (give --torque-limit, N·m)")
    lines.append(decay.message)
    if pid.torque_limit is not None:
        tt = [round(float(v), 4) for v in np.atleast_1d(np.asarray(pid.tracking_time, dtype=float))]
        lines.append(f"torque limit {[round(float(v), 6) for v in pid.torque_limit]} N·m"
                     + (" (the arm's effort limits)" if effort is not None else "") + ", anti-windup "
                     + ("off" if not pid.anti_windup else f"T_t = {tt} s"))
    if pid.feedforward is not None:
        ff = pid.feedforward
        worst = ff.check(system.arm().arm)
        lines.append(f"feedforward {ff.kind} at the nominal payload {ff.payload:g} kg in the controller, as certified "
                     f"(RNEA on the arm's bodies: {worst:.1e} relative from Pinocchio's on 200 random states); the "
                     "torque limit acts on the total torque")
    lines += [] if board is None else [board.message]
    lines += [f"wrote {f}" for f in files]
    return "\n".join(lines)
