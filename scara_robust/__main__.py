"""``python -m scara_robust``: see :mod:`scara_robust.cli`."""

from .cli import main

if __name__ == "__main__":  # not when a worker process of the design page imports this module again
    raise SystemExit(main())
