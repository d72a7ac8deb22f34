"""Monte-Carlo robustness campaigns.

Specs (:mod:`.spec`), run inputs and replay (:mod:`.inputs`), runs (:mod:`.runner`),
statistics (:mod:`.report`), campaigns on a URDF arm (:mod:`.arm`).
"""

from ...exceptions import CampaignSpecError as CampaignSpecError  # where the old module had it
from .arm import *  # noqa: F403
from .arm import __all__ as _arm
from .inputs import *  # noqa: F403
from .inputs import __all__ as _inputs
from .report import *  # noqa: F403
from .report import __all__ as _report
from .runner import *  # noqa: F403
from .runner import __all__ as _runner
from .spec import *  # noqa: F403
from .spec import __all__ as _spec

__all__ = [*_spec, *_inputs, *_runner, *_report, *_arm]
