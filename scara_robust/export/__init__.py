"""Export a :class:`~scara_robust.DiscretePID` (or static state feedback) for a controller board.

Every format is an :class:`ExportTarget` in a registry (:mod:`scara_robust.export.registry`):
a new format is one module that builds its target and registers it at import. The
built-in targets are ``'c'`` (C99 header and source, private module ``_c``),
``'json'`` (the controller's record, ``_json``) and ``'ros2'`` (a ros2_control ``pid_controller``
parameter file, ``_ros2``); :func:`export_controller` and the
``export`` command offer every registered target. Ts in s, and the signals' units as the
plant gives them (by default the SCARA's: e in rad, ė in rad/s, u in N·m).

export_controller      -- write a controller's files into a folder, all or none (``export`` command)
c_source               -- the C99 header and source of a DiscretePID
pid_controller_parameters -- a per-joint PID as ros2_control's pid_controller parameters (target ``'ros2'``)
coupling_of            -- where a PID is coupled (a torque reads another joint's error), or None
update_rate_of         -- pid_controller's update rate for a Ts (a whole number of Hz), or an error
controller_record      -- every gain, limit and matrix of a DiscretePID, JSON-ready
EXPORT_FORMATS         -- the built-in formats, ``('c', 'json', 'ros2')``
PRECISIONS             -- the C's floating-point types, ``('double', 'single')``
DEFAULT_PREFIX         -- the default prefix of the exported names and files, ``'scara_pid'``
ExportTarget           -- one format: name, file suffix, description, write function
register_target        -- add a format (``replace=True`` replaces one of the same name)
unregister_target      -- remove a format by name
export_targets         -- the registered formats' names, in the order registered
get_target             -- a registered format by name
run_on_board           -- the exported C cross-compiled and run on an emulated board, against Python
board_inputs           -- seeded random inputs of the shape a controller's step takes
check_toolchain        -- a board's cross-compiler and emulator, or an error naming their packages
Board                  -- one emulated board: compiler flags, QEMU machine, packages, clock
BoardRun               -- a board run: outputs against Python, instructions per step, flash, RAM
BOARDS                 -- the boards by name, ``'cortex-m4f'``
"""

# Importing a target module registers its target: `_c` before `_json` gives the order ('c', 'json').
from ._c import *  # noqa: F403
from ._c import __all__ as _c_names
from ._common import *  # noqa: F403
from ._common import __all__ as _common_names
from ._json import *  # noqa: F403
from ._json import __all__ as _json_names
from ._ros2 import *  # noqa: F403
from ._ros2 import __all__ as _ros2_names
from ._write import *  # noqa: F403
from ._write import __all__ as _write_names
from .board import *  # noqa: F403
from .board import __all__ as _board_names
from .registry import *  # noqa: F403
from .registry import __all__ as _registry_names

__all__ = [*_write_names, *_c_names, *_json_names, *_ros2_names, *_common_names, *_registry_names, *_board_names]
