"""``python -m scara_robust``: see :mod:`scara_robust.cli`."""

from .cli import main

raise SystemExit(main())
