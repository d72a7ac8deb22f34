"""Export a design of a system to a target, certified at its sample time first: what every front end runs.

:func:`export_certified` is the one pipeline: the sampled-data certificate of the controller
on the system's plants (refused where it fails, unless asked), the record and notes every
target writes (the certificate, the plant file, the continuous-time decay rate), an
optional run on an emulated board, then the target's files (:func:`scara_robust.export_controller`,
all or none). :func:`state_feedback_of` is the controller of a plant in the state form, and
:func:`export_pid` the export of K(ρ, η) with the PID's defaults (the design page's).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..controller.kinds import check_controller
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import OptionError
from ..export import DEFAULT_PREFIX, export_controller
from ..lyapunov.gain import Design, design
from ..robustness.decay import DecayRate
from ..robustness.jitter import jitter_certificate
from ..robustness.sampled import SampleTimeCheck, check_sample_time
from .system import LoadedSystem

__all__ = ["ExportedDesign", "check_state_form", "export_certified", "export_pid", "state_feedback_of"]


@dataclass(frozen=True)
class ExportedDesign:
    """What :func:`export_certified` wrote and the certificates it wrote them with.

    Attributes
    ----------
    files : tuple of pathlib.Path
        The files written, in the target's order.
    certificate : SampleTimeCheck
        The sampled-data certificate at the controller's Ts (of the controller as the
        target runs it: pid_controller's forward Euler for ``'ros2'``).
    tustin : SampleTimeCheck or None
        For ``'ros2'``: the package's own (Tustin) PID at the same Ts, reported beside it.
    board : BoardRun or None
        The run on an emulated board, where one was asked for.
    notes : tuple of str
        The notes written into the files.
    """

    files: tuple[Path, ...]
    certificate: SampleTimeCheck
    tustin: SampleTimeCheck | None
    board: Any
    notes: tuple[str, ...]


def check_state_form(system: LoadedSystem) -> None:
    """Refuse a plant whose gain static state feedback cannot run: one in the integral form.

    Parameters
    ----------
    system : LoadedSystem
        A plant file whose gain is static state feedback (:attr:`LoadedSystem.state_feedback`).

    Raises
    ------
    OptionError
        For a plant in the integral form (its gain needs the integrator on the controller).
    """
    physical = system.physical
    assert physical is not None
    if physical.form == "integral":
        raise OptionError(f"`--model` {system.file!r}: export writes a PID (form 'pid') or static state "
                          "feedback u = -K x (form 'state'); a gain on the integral form [∫(r - Cx), x] "
                          "needs its integrator on the controller and is not exported")


def state_feedback_of(system: LoadedSystem, d: Design, Ts: float) -> tuple[SampledStateFeedback, dict[str, Any]]:
    """Static state feedback ``u_k = −K x(t_k)`` held, for a plant in the state form; the signals it reads and writes.

    Parameters
    ----------
    system : LoadedSystem
        A plant file in the state form (:attr:`LoadedSystem.state_feedback`).
    d : Design
    Ts : float
        Sample time, s.

    Returns
    -------
    controller : SampledStateFeedback
    signals : dict
        ``outputs`` (the plant's inputs) and, where the plant's outputs are its state,
        ``inputs``.

    Raises
    ------
    OptionError
        For a plant in the integral form (:func:`check_state_form`).
    """
    check_state_form(system)
    physical = system.physical
    assert physical is not None
    controller = SampledStateFeedback(d.K, Ts)
    # the controller's outputs are the plant's inputs; it reads the state: the plant's outputs when they are
    # the state (no C), else x0..
    signals: dict[str, Any] = {"outputs": physical.inputs}
    if physical.C is None and len(physical.outputs) == d.K.shape[1]:
        signals["inputs"] = physical.outputs
    return controller, signals


def export_certified(system: LoadedSystem, controller: Any, folder: str | Path, *, meta: Mapping[str, Any],
                     decay: DecayRate, prefix: str, format: str = "c", precision: str = "double",
                     signals: Mapping[str, Sequence[Any]] | None = None, allow_uncertified: bool = False,
                     board: Callable[[Any, str], Any] | None = None, jitter: float | None = None) -> ExportedDesign:
    """Certify `controller` at its sample time on `system`'s plants, then write the target's files.

    Parameters
    ----------
    system : LoadedSystem
    controller : DiscretePID, SampledStateFeedback or SampledScheduledGain
    folder : str or pathlib.Path
        An existing, writable folder.
    meta : mapping
        The record of the design (its source, ρ and η, the model), first in the files' record.
    decay : DecayRate
        The continuous-time loop's decay rate (:meth:`LoadedSystem.decay_rate`), recorded.
    prefix : str
        C identifier of the files and names.
    format : str
        A registered export target (:func:`scara_robust.export_targets`).
    precision : {'double', 'single'}
    signals : mapping, optional
        ``outputs`` and ``inputs`` (signals with units), as :func:`scara_robust.export_controller` takes.
    allow_uncertified : bool
        Write the files where the certificate fails (the notes say so in capitals).
    board : callable, optional
        ``board(controller, prefix) -> BoardRun``: the run on an emulated board, noted.
    jitter : float, optional
        s: also certify every period in ``[Ts − jitter, Ts + jitter]``
        (:func:`scara_robust.jitter_certificate`), refused like Ts where it fails, and record it.

    Returns
    -------
    ExportedDesign

    Raises
    ------
    OptionError
        For a Ts the certificate does not hold at (without `allow_uncertified`), with its message.
    """
    ros2 = format == "ros2"
    plants, check, set_name = system.sampled()
    result = check_sample_time(plants, controller, check=check, set_name=set_name)
    if not result.certified and not allow_uncertified:
        which = " (pid_controller's forward Euler)" if ros2 else ""
        raise OptionError(f"`--ts` {result.message}{which}; nothing written (--allow-uncertified writes it "
                          "anyway)")
    jittered = None
    if jitter is not None:
        jittered = jitter_certificate(plants, controller, jitter, check=check)
        if not jittered.certified and not allow_uncertified:
            raise OptionError(f"`--ts-jitter` {jittered.message}; nothing written (--allow-uncertified writes it "
                              "anyway)")
    own = None
    if ros2:  # the package's own (Tustin) PID at the same Ts, reported beside pid_controller's
        pid = check_controller("controller", controller, ("pid",))
        own = check_sample_time(plants, replace(pid, integrator="tustin"), check=check, set_name=set_name)
    record = dict(meta)
    record["certificate"] = result.record()
    record["plant_file"] = system.file
    record["decay_rate"] = {"rate [1/s]": decay.rate if decay.certified else None, "from": decay.source,
                            "set": decay.set_name}
    notes = [f"Sampled-data certificate: {result.message}.", f"Continuous-time loop: {decay.message}."]
    if own is not None:
        notes[0] = f"Sampled-data certificate of pid_controller (forward Euler): {result.message}."
        notes.insert(1, f"The same gain with the package's Tustin integrator: {own.message}.")
    if jittered is not None:
        record["jitter_certificate"] = jittered.record()
        notes.insert(1, f"Jittering period: {jittered.message}.")
    if not result.certified or (jittered is not None and not jittered.certified):
        notes.insert(0, "WARNING: NOT CERTIFIED at this Ts; written with --allow-uncertified. Do not deploy it "
                        "without your own analysis.")
    record["precision"] = precision
    run = None if board is None else board(controller, prefix)
    if run is not None:
        notes.append(f"Run on an emulated board: {run.message}.")
    # export_controller dispatches through the registry (get_target) and writes the target's files, all or none
    files = export_controller(controller, folder, format=format, prefix=prefix, metadata=record, notes=notes,
                              precision=precision, **(signals or {}))
    return ExportedDesign(tuple(files), result, own, run, tuple(notes))


def export_pid(system: LoadedSystem, rho: float, eta: float, Ts: float, folder: str | Path, *,
               torque_limit: Sequence[float] | None = None) -> ExportedDesign:
    """K(ρ, η) of `system`, discretized at `Ts` with the PID's defaults, certified and written as C.

    The defaults are those of the ``export`` command: Tustin integrator, measured ė,
    N = 100 1/s, back-calculation anti-windup with its default T_t where a limit is given
    (an arm's effort limits unless `torque_limit` is given), an arm's model feedforward as its
    loop was certified with; static state feedback for a plant in the state form.

    Parameters
    ----------
    system : LoadedSystem
    rho, eta : float
        The design point.
    Ts : float
        Sample time, s.
    folder : str or pathlib.Path
    torque_limit : sequence of float, optional
        One limit for every input or one per input, in the inputs' units.

    Returns
    -------
    ExportedDesign

    Raises
    ------
    OptionError
        Where the certificate fails at `Ts`, or the plant is in the integral form.
    """
    model = system.model
    signals: dict[str, Any] = system.signal_names()
    controller: Any
    if system.state_feedback:
        d = design(model, rho, eta)
        controller, signals = state_feedback_of(system, d, Ts)
    else:
        d = design(model, rho, eta)
        effort = system.effort_limits() if torque_limit is None else None  # an arm's motors, by default
        controller = d.discretize(Ts, integrator="tustin", derivative="measured", N=100.0,
                                  torque_limit=torque_limit if effort is None else list(effort), tracking_time=None,
                                  anti_windup=True, feedforward=system.feedforward())
    meta = {"rho": d.rho, "eta": d.eta, "model": model.name}
    return export_certified(system, controller, folder, meta=meta, decay=system.decay_rate(d),
                            prefix=system.plant_prefix(DEFAULT_PREFIX), signals=signals)
