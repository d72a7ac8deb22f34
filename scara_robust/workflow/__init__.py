"""The workflow the front ends share: the system a design runs on, loaded from the files a user names.

Below the design page and the command line, above the library: a front end chooses the
kind of system and its files, and asks the :class:`LoadedSystem` for everything a design
needs (its plant and uncertainty set, the sampled-data plants, decay rate, loop margins,
input limits). Errors are :class:`~scara_robust.OptionError` naming the options.

LoadedSystem, ScaraSystem, PlantFileSystem, ArmSystem -- the system, by kind
SYSTEM_KINDS, open_system -- the kinds by name; a system over the files named
Setup, Capabilities, PhysicalSet -- the SCARA's robot and signals; what a system can do; synthesis samples
CERTIFICATE_GRID, CERTIFICATE_CHECK_GRID -- the SCARA's samples of the sampled-data certificate
load_input -- a file read with the option that named it in any error
design_answer, DesignAnswer -- K(ρ, η) of a system, its certificate and its design file
export_certified, ExportedDesign -- certify a controller at its Ts on the system, then write a target's files
export_pid -- K(ρ, η) discretized with the PID's defaults, certified and written as C (the page's export)
state_feedback_of, check_state_form -- the controller of a plant in the state form
simulate_system -- one closed-loop run of any system under any controller, a Run
Requirements, tune_system, TuneReport -- a PID tuned to stated requirements, certified and run on the robot
evaluate_gain, GainEvaluation -- one gain against the requirements: certified bound beside the simulated error
TUNE_GRID, TUNE_CHECK_GRID -- the samples of the tuning's LMI and of its independent check
"""

from .design import *  # noqa: F403
from .design import __all__ as _design
from .export import *  # noqa: F403
from .export import __all__ as _export
from .simulate import *  # noqa: F403
from .simulate import __all__ as _simulate
from .system import *  # noqa: F403
from .system import __all__ as _system
from .tune import *  # noqa: F403
from .tune import __all__ as _tune

__all__ = [*_system, *_design, *_export, *_simulate, *_tune]
