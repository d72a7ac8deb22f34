"""The plant: the SCARA of Eq. (1), any arm from its URDF, signals, initial conditions and uncertain models.

The bottom layer of the package; it imports only :mod:`scara_robust.paper` and the
validation helpers.
"""

from .arm import *  # noqa: F403
from .arm import __all__ as _arm
from .augment import *  # noqa: F403
from .augment import __all__ as _augment
from .base import *  # noqa: F403
from .base import __all__ as _base
from .feedforward import *  # noqa: F403
from .feedforward import __all__ as _feedforward
from .initial import *  # noqa: F403
from .initial import __all__ as _initial
from .perturbation import *  # noqa: F403
from .perturbation import __all__ as _perturbation
from .plant import *  # noqa: F403
from .plant import __all__ as _plant
from .polytopic import *  # noqa: F403
from .polytopic import __all__ as _polytopic
from .robot import *  # noqa: F403
from .robot import __all__ as _robot
from .scara import *  # noqa: F403
from .scara import __all__ as _scara
from .signals import *  # noqa: F403
from .signals import __all__ as _signals
from .uncertain import *  # noqa: F403
from .uncertain import __all__ as _uncertain

__all__ = [*_base, *_robot, *_signals, *_initial, *_uncertain, *_polytopic, *_augment, *_plant, *_scara, *_arm,
           *_feedforward, *_perturbation]
