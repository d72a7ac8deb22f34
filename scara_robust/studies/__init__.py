"""Studies built on the core: the PID vs sliding-mode comparison, the paper's claims, campaigns.

Imports everything below it (model, the paper's method, simulation, io); nothing below
imports it.
"""

from .antiwindup import *  # noqa: F403
from .antiwindup import __all__ as _antiwindup
from .campaign import *  # noqa: F403
from .campaign import __all__ as _campaign
from .comparison import *  # noqa: F403
from .comparison import __all__ as _comparison
from .reproduction import *  # noqa: F403
from .reproduction import __all__ as _reproduction

__all__ = [*_comparison, *_reproduction, *_campaign, *_antiwindup]
