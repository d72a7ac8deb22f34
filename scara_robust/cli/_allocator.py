"""The command's memory allocator: freed arrays kept in the process for the next ones of their size.

The searches allocate the same temporaries again and again: a stack of 1 024 to 2 176 closed
loops of 6 states is 0.3–0.6 MB, one of 1 267 loops of 18 states 3.3 MB, and each product,
factorization and eigenvalue call of a scan step makes a few. glibc's ``malloc`` gives a block
above its mapping threshold (128 kB, raised on the fly to the largest block freed, up to 32 MB)
a mapping of its own and gives it back when freed, and it returns the top of the heap to the
system once more than its trim threshold is free there; the next array's pages are then faulted
in again, page by page. Which blocks that hits depends on the order of the allocations before
it: a change elsewhere in the program moved the 6-joint arm's frozen payload search from 1.7 s
to 2.6 s, with the same work. Keeping freed blocks (a mapping threshold of 32 MB, a trim
threshold of 64 MB) makes it 1.6 s either way, and the SCARA's ``margin`` 8 % faster.

A command runs this once, after its arguments parse. It does nothing where the C library is not
glibc, or where the environment already sets glibc's allocator (``GLIBC_TUNABLES``,
``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_``): the user's settings stand.
"""

from __future__ import annotations

import os

__all__ = ["keep_freed_memory", "MMAP_THRESHOLD", "TRIM_THRESHOLD"]

#: Bytes from which a block gets a mapping of its own (glibc's largest: 32 MB on 64 bits).
MMAP_THRESHOLD = 32 * 2**20
#: Free bytes at the top of the heap from which they are returned to the system.
TRIM_THRESHOLD = 64 * 2**20

_M_TRIM_THRESHOLD = -1  # glibc's <malloc.h>
_M_MMAP_THRESHOLD = -3
_USER_SETTINGS = ("GLIBC_TUNABLES", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")

_set: bool | None = None


def keep_freed_memory() -> bool:
    """Set glibc's mapping and trim thresholds for this process (once); True where they are set.

    Returns
    -------
    bool
        False on another C library, where the environment sets the allocator, or where
        ``mallopt`` refuses a value.
    """
    global _set
    if _set is None:
        _set = _apply()
    return _set


def _apply() -> bool:
    try:
        libc = os.confstr("CS_GNU_LIBC_VERSION") or ""
    except (AttributeError, ValueError, OSError):  # not a GNU system
        return False
    if not libc.startswith("glibc") or any(name in os.environ for name in _USER_SETTINGS):
        return False
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1 and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1)
