"""``app``: the graphical design as a local web page (Bokeh server on this machine)."""

from __future__ import annotations

import argparse
import errno
import os
import signal
import sys
import tempfile
from typing import Any

from .._validation import os_error_text
from ..controller.scheduled import SCHEDULE_KIND
from ..workflow.design import design_answer
from ..workflow.export import export_pid
from ._common import RANGE_HELP, CommandLineError, add_setup_options, parse_range
from ._parser import COMMAND_HELP
from ._schedule import is_schedule_file, read_schedule
from ._system import LoadedSystem, load_system, plant_source

__all__ = ["add_parser", "run", "explorer_of"]


def add_parser(sub: Any) -> None:
    """Register ``app``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
    """
    p = sub.add_parser(
        "app", help=COMMAND_HELP["app"],
        description="Serve the design page on this machine (every asset local; open the printed URL). Left: the "
        "(rho, eta) map coloured by max eig Z or the Theorem 1 margin, with its certification contour. Right, for "
        "the selected design: K, the verdicts, the margins, the payload margin, the largest sample time, the "
        "response, and its C controller (export's files). Stop with Ctrl-C.")
    add_setup_options(p, scenario="signals", model=True)
    p.add_argument("--rho", type=parse_range, default="0.1:10:100", metavar="START:STOP:NUM",
                   help=f"rho grid of the map (default 0.1:10:100): {RANGE_HELP}")
    p.add_argument("--eta", type=parse_range, default="1:200:200", metavar="START:STOP:NUM",
                   help="eta grid of the map (default 1:200:200)")
    p.add_argument("--elements", choices=("all", "A", "B"), default="all",
                   help="uncertain elements entering Theorem 1's Z on the map and in the verdict (default all; for "
                   "the SCARA, A shows the certified region)")
    p.add_argument("--design", metavar="SCHEDULE.json",
                   help="a schedule file (synthesize --schedule --output): the page draws its gains against the "
                   "parameter, the selected design's beside them, and re-verifies its certificate")
    p.add_argument("--port", type=int, default=5006, help="TCP port on 127.0.0.1 (default 5006)")
    p.set_defaults(func=run)


def explorer_of(args: argparse.Namespace, system: LoadedSystem | None = None) -> Any:
    """The page's :class:`~scara_robust.app.DesignExplorer` for the command's options.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem, optional
        The system of `args` (default: :func:`~._system.load_system` of them).

    Returns
    -------
    DesignExplorer
    """
    from ..app import DesignExplorer

    system = load_system(args) if system is None else system
    model = system.model
    if not system.interval_elements:
        raise CommandLineError(f"`--model` {system.file!r} is a polytope; the map of Theorem 1 needs an interval "
                               "model (elements with ranges, or physical parameters)")
    physical = system.require_physical(f"`--model` {system.file!r} has no physical parameters to simulate; the page "
                                       "needs a plant file with [parameters]")
    def exporter(rho: float, eta: float, ts: float, torque_limit: list[float] | None) -> dict[str, str]:
        with tempfile.TemporaryDirectory() as folder:
            export_pid(system, rho, eta, ts, folder, torque_limit=torque_limit)
            return {name: open(os.path.join(folder, name), encoding="utf-8").read()
                    for name in sorted(os.listdir(folder))}

    def design_file(rho: float, eta: float) -> str:
        return design_answer(system, rho, eta, args.elements).file_text() + "\n"

    schedule = None
    if args.design is not None:
        if not is_schedule_file(args.design):
            raise CommandLineError(f"`--design` {args.design!r}: the page takes a schedule file (JSON of kind "
                                   f"'{SCHEDULE_KIND}', written by synthesize --schedule --output)")
        schedule = read_schedule(args.design)
        shape = (model.n_inputs, model.n_states)
        if schedule.parameter not in physical.names or schedule.shape != shape:
            raise CommandLineError(f"`--design` {args.design!r}: schedules {schedule.parameter!r} with gains of shape "
                                   f"{schedule.shape}, not a gain of this plant ({shape} on one of "
                                   f"{list(physical.names)})")
    return DesignExplorer(model, system.title(), plant=physical,  # type: ignore[arg-type]  # a box, checked above
                          plant_source=plant_source(args, system),
                          robot_signals=system.robot_signals(),
                          sampled=system.sampled(), controller_ts=system.controller_ts, exporter=exporter,
                          design_file=design_file,
                          parse_grid=parse_range,
                          rhos=args.rho, etas=args.eta, elements=args.elements, schedule=schedule)


def run(args: argparse.Namespace, system: LoadedSystem) -> str:
    """Serve the page until SIGINT (Ctrl-C) or SIGTERM stops it.

    A stop signal, while the page starts or once it serves, stops it and its worker
    processes and says so in one line on stderr (``the design page stopped (SIGTERM)``);
    the command then exits with 0, as a server asked to stop does.

    Parameters
    ----------
    args : argparse.Namespace
    system : LoadedSystem

    Returns
    -------
    str
        Empty: the page prints nothing on stdout.
    """
    if not 1 <= args.port <= 65535:
        raise CommandLineError(f"`--port` must be a TCP port in 1..65535, found {args.port}")
    try:
        from threadpoolctl import threadpool_limits

        from ..app import serve
    except ImportError as err:
        raise CommandLineError(f"the page needs the `app` extra: pip install '.[app]' ({err})") from None
    # one BLAS thread: a click's matrices are 6 x 6 or smaller, and the page shares the machine's cores
    # with its browser and its worker process (whose own BLAS is limited the same way)
    threadpool_limits(1)
    # SIGTERM (a service manager, a test) and SIGINT (Ctrl-C) stop the page, its worker processes with
    # it, in one line: while it starts, by interrupting the start; once it serves, by stopping its loop
    stopped: list[int] = []

    def stop_start(signum: int, frame: Any) -> None:
        if not stopped:  # a second signal while the start unwinds changes nothing
            stopped.append(signum)
            raise _Stopped

    previous = {sig: signal.signal(sig, stop_start) for sig in _STOP_SIGNALS}
    explorer, handled = None, None
    try:
        explorer = explorer_of(args, system)
        try:
            server = serve(explorer, args.port)
            server.start()
        except OSError as err:
            why = "is in use" if err.errno == errno.EADDRINUSE else os_error_text(err)
            raise CommandLineError(f"`--port` {args.port}: {why}") from None
        explorer.start_workers()
        handled = server.io_loop.asyncio_loop
        for sig in _STOP_SIGNALS:
            handled.add_signal_handler(sig, _stop_loop, server.io_loop, sig, stopped)
        sys.stderr.write(f"serving the design page at http://127.0.0.1:{args.port}/ (Ctrl-C stops it)\n")
        sys.stderr.flush()
        server.io_loop.start()
    except _Stopped:
        pass  # stopped before it served
    finally:
        if explorer is not None:
            explorer.close()
        for sig, handler in previous.items():
            if handled is not None:
                handled.remove_signal_handler(sig)
            signal.signal(sig, handler)
    if stopped:
        sys.stderr.write(f"scara_robust: the design page stopped ({signal.Signals(stopped[0]).name})\n")
    return ""


#: The signals that stop the page (exit status 0: stopping is how a page ends).
_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Stopped(BaseException):
    """A stop signal while the page starts (a BaseException, as KeyboardInterrupt: no handler keeps it)."""


def _stop_loop(loop: Any, signum: int, stopped: list[int]) -> None:
    """Stop the page's loop for the signal `signum` (run by the loop, after the signal arrived)."""
    if not stopped:
        stopped.append(signum)
    loop.stop()
