"""``python -m scara_robust.compare``: the PID vs sliding-mode table.

Same as ``python -m scara_robust compare``; see :func:`scara_robust.compare_controllers`.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from .cli import main as cli_main

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``compare`` with `argv` (default: the process arguments); return the exit code.

    Parameters
    ----------
    argv : sequence of str, optional

    Returns
    -------
    int
        The exit code of :func:`scara_robust.cli.main`.
    """
    return cli_main(["compare", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
