"""Processor-in-the-loop: the exported C, cross-compiled and run on an emulated board.

:func:`run_on_board` writes a controller's C (the ``'c'`` target), compiles it with the
board's cross-compiler and the flags of its floating-point unit, links it into a small test
image whose driver reads the inputs from a file and writes the outputs to another over
semihosting (the emulator's host file access), runs the image in QEMU, and compares the
outputs with the package's own Python step. It then runs the image again on the first
``trace_steps`` inputs with QEMU's execution trace, one instruction per translated block,
and counts the instructions of every call of the step, from its entry to the return into
the driver (the soft-float routines it calls included). The sizes come from the compiled
object (``size``), the helpers it pulls from the C and compiler libraries (their sizes in
the linked image) and the compiler's stack usage (``-fstack-usage``).

QEMU is not cycle-accurate: the time of a step is an estimate, instructions over a stated
clock, a lower bound (one cycle per instruction; a Cortex-M4 takes two cycles for a load, up
to 14 for a floating-point division, and flash wait states add more).

Board          -- one emulated board: compiler flags, QEMU machine, Debian packages, clock
BoardRun       -- outputs against Python, instructions per step, flash and RAM, share of Ts
BOARDS         -- the boards by name: ``'cortex-m4f'``
board_inputs   -- seeded random inputs of the shape a controller's step takes
run_on_board   -- cross-compile, run in the emulator, compare and measure
check_toolchain -- the board's tools, or an error naming the packages that install them
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import check_array, check_choice, check_int, check_real
from ..controller.discrete import DiscretePID
from ..controller.kinds import check_controller
from ..controller.scheduled import SampledScheduledGain
from ..controller.state_feedback import SampledStateFeedback
from ..exceptions import MissingToolError, ScaraRobustError
from ._common import DEFAULT_PREFIX, PRECISIONS, check_prefix
from .registry import get_target

__all__ = ["Board", "BoardRun", "BOARDS", "board_inputs", "run_on_board", "check_toolchain"]

Controller = DiscretePID | SampledStateFeedback | SampledScheduledGain


@dataclass(frozen=True)
class Board:
    """One emulated board.

    Attributes
    ----------
    name : str
        The board's name (``'cortex-m4f'``), as ``export --target`` takes it.
    description : str
        One line: the core, its floating-point unit and the emulated machine.
    compiler : str
        The cross-compiler (``'arm-none-eabi-gcc'``); ``size`` and ``nm`` are found beside it
        (same prefix).
    cflags : tuple of str
        Flags of the core and its FPU.
    machine : str
        QEMU's machine (``-M``).
    emulator : str
        QEMU's program (``'qemu-system-arm'``).
    packages : tuple of str
        The Debian packages that install the compiler, its C library and the emulator.
    clock_hz : float
        The clock of the stated time estimate, Hz.
    """

    name: str
    description: str
    compiler: str
    cflags: tuple[str, ...]
    machine: str
    emulator: str
    packages: tuple[str, ...]
    clock_hz: float

    def tool(self, name: str) -> str:
        """The binutils program `name` (``'size'``, ``'nm'``) of the compiler's prefix."""
        return self.compiler.rsplit("-", 1)[0] + "-" + name


#: The boards by name.
BOARDS: dict[str, Board] = {
    "cortex-m4f": Board(
        name="cortex-m4f",
        description="Arm Cortex-M4 with its single-precision FPU (FPv4-SP), emulated as QEMU's mps2-an386 board",
        compiler="arm-none-eabi-gcc",
        cflags=("-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-mthumb"),
        machine="mps2-an386",
        emulator="qemu-system-arm",
        packages=("gcc-arm-none-eabi", "libnewlib-arm-none-eabi", "qemu-system-arm"),
        clock_hz=168e6,
    ),
}

# The test image: a vector table and reset handler (copy .data, zero .bss, enable the FPU, open the
# semihosting handles, exit with main's code), and its memory map (flash at 0, RAM at 0x20000000).
_STARTUP = r"""#include <stdint.h>
extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_top;
extern int main(void);
extern void initialise_monitor_handles(void);
extern void exit(int);
void Reset_Handler(void);
static void Default_Handler(void) { for (;;) {} }
__attribute__((section(".vectors"), used)) const void *vectors[16] = {
    &__stack_top, (void *)Reset_Handler, (void *)Default_Handler, (void *)Default_Handler,
    (void *)Default_Handler, (void *)Default_Handler, (void *)Default_Handler, 0, 0, 0, 0,
    (void *)Default_Handler, (void *)Default_Handler, 0, (void *)Default_Handler, (void *)Default_Handler};
void Reset_Handler(void)
{
    uint32_t *src = &__data_load, *dst = &__data_start;
    while (dst < &__data_end) *dst++ = *src++;
    for (dst = &__bss_start; dst < &__bss_end;) *dst++ = 0;
    *(volatile uint32_t *)0xE000ED88 |= (0xFu << 20); /* CPACR: CP10 and CP11 (the FPU) */
    __asm volatile("dsb\n isb");
    initialise_monitor_handles();
    exit(main());
}
"""

_LINKER = """MEMORY { FLASH (rx) : ORIGIN = 0x00000000, LENGTH = 4M  RAM (rwx) : ORIGIN = 0x20000000, LENGTH = 4M }
ENTRY(Reset_Handler)
SECTIONS {
  .text : { KEEP(*(.vectors)) *(.text*) *(.rodata*) . = ALIGN(4); } > FLASH
  .ARM.exidx : { *(.ARM.exidx*) } > FLASH
  __data_load = LOADADDR(.data);
  .data : { __data_start = .; *(.data*) . = ALIGN(4); __data_end = .; } > RAM AT > FLASH
  .bss (NOLOAD) : { __bss_start = .; *(.bss*) *(COMMON) . = ALIGN(4); __bss_end = .; } > RAM
  end = .; _end = .;
  __stack_top = ORIGIN(RAM) + LENGTH(RAM);
}
"""

# The driver: rows of inputs from in.bin, CHUNK at a time, one step per row, rows of outputs to out.bin.
_DRIVER = r"""#include <stdio.h>
#include "{prefix}.h"
#define CHUNK 64
static {T} in_rows[CHUNK][{n_in}];
static {T} out_rows[CHUNK][{n_out}];
int main(void)
{{
    FILE *fi = fopen("in.bin", "rb"), *fo = fopen("out.bin", "wb");
    size_t n, k;
{declare}
    if (fi == NULL || fo == NULL) return 3;
    while ((n = fread(in_rows, sizeof in_rows[0], CHUNK, fi)) > 0) {{
        for (k = 0; k < n; ++k) {{
            {call};
        }}
        if (fwrite(out_rows, sizeof out_rows[0], n, fo) != n) return 4;
    }}
    fclose(fi);
    fclose(fo);
    return 0;
}}
"""


@dataclass(frozen=True)
class BoardRun:
    """A controller's C run on an emulated board, against the package's Python step.

    Attributes
    ----------
    board : str
        The board's name.
    precision : str
        ``'double'`` or ``'single'``: the C's floating-point type.
    kind : str
        ``'pid'``, ``'state feedback'`` or ``'scheduled'``.
    Ts : float
        The controller's sample time, s.
    u : ndarray, shape (m, n_steps)
        The board's outputs, in the controller's output units (float32 values in single
        precision).
    u_reference : ndarray, shape (m, n_steps)
        The Python step's outputs on the same inputs: :func:`single_precision_step` for the PID,
        the controller's ``step_single`` for the other kinds in single precision; the
        controller's own ``step`` in double.
    max_abs_difference : float
        ``max |u − u_reference|``, in the output units.
    tolerance : float
        0 in single precision (bit for bit), ``1e-12 · max(1, max |u_reference|)`` in double.
    instructions : ndarray of int, shape (n_traced,)
        The instructions executed by each traced call of the step (entry to return, the
        routines it calls included).
    flash_bytes : int
        The controller's code and constants (text and data of its object) and the library
        routines it calls, bytes.
    ram_bytes : int
        Its static data, its state (the PID's) and the step's own stack frame, bytes.
    stack_bytes : int
        The step's own stack frame (``-fstack-usage``), bytes.
    helpers : tuple of str
        The library routines the controller calls (soft-float arithmetic in double on a
        single-precision FPU, ``memcpy``...).
    clock_hz : float
        The clock of the time estimate, Hz.
    compiler : str
        The compiler's version line.
    """

    board: str
    precision: str
    kind: str
    Ts: float
    u: NDArray[np.float64]
    u_reference: NDArray[np.float64]
    max_abs_difference: float
    tolerance: float
    instructions: NDArray[np.int64]
    flash_bytes: int
    ram_bytes: int
    stack_bytes: int
    helpers: tuple[str, ...]
    clock_hz: float
    compiler: str = field(default="")

    @property
    def agrees(self) -> bool:
        """Whether the board's outputs are the Python step's within :attr:`tolerance`."""
        return self.max_abs_difference <= self.tolerance

    @property
    def n_steps(self) -> int:
        """The number of steps compared."""
        return int(self.u.shape[1])

    @property
    def step_time(self) -> float:
        """A lower bound on the slowest traced step's time at :attr:`clock_hz`: one cycle per instruction, s."""
        return float(self.instructions.max()) / self.clock_hz

    @property
    def share_of_ts(self) -> float:
        """:attr:`step_time` over Ts."""
        return self.step_time / self.Ts

    @property
    def message(self) -> str:
        """One paragraph: agreement, instructions, time estimate, flash and RAM."""
        same = ("bit for bit" if self.tolerance == 0 else f"within {self.tolerance:.1e}") if self.agrees else (
            f"NOT within {self.tolerance:.1e}")
        ins = self.instructions
        return (f"{self.board} ({self.precision} precision): {self.n_steps} steps equal the Python step {same} "
                f"(max |difference| {self.max_abs_difference:.3g}); {int(ins.min())}-{int(ins.max())} instructions "
                f"per step (mean {ins.mean():.0f}, {ins.size} steps traced), at least {self.step_time * 1e6:.3g} µs at "
                f"{self.clock_hz / 1e6:g} MHz (one cycle per instruction; QEMU is not cycle-accurate), "
                f"{100 * self.share_of_ts:.3g} % of Ts = {self.Ts:g} s; flash {self.flash_bytes} B, "
                f"RAM {self.ram_bytes} B (stack of the step {self.stack_bytes} B)")

    def record(self) -> dict[str, Any]:
        """The run's figures, JSON-ready (no arrays)."""
        ins = self.instructions
        return {"board": self.board, "precision": self.precision, "kind": self.kind, "Ts [s]": self.Ts,
                "steps": self.n_steps, "agrees": self.agrees, "max |difference|": self.max_abs_difference,
                "tolerance": self.tolerance, "instructions per step": {"min": int(ins.min()), "mean": float(
                    ins.mean()), "max": int(ins.max()), "traced": int(ins.size)},
                "clock [Hz]": self.clock_hz, "step time [s]": self.step_time, "share of Ts": self.share_of_ts,
                "flash [B]": self.flash_bytes, "RAM [B]": self.ram_bytes, "stack [B]": self.stack_bytes,
                "helpers": list(self.helpers), "compiler": self.compiler}


def _kind(controller: Any) -> str:
    return str(check_controller("controller", controller, what="a DiscretePID, SampledStateFeedback or "
                                "SampledScheduledGain").kind)


def board_inputs(controller: Controller, n_steps: int, *, seed: int = 0) -> NDArray[np.float64]:
    """Seeded random inputs for `controller`'s step, one column per step.

    Parameters
    ----------
    controller : DiscretePID, SampledStateFeedback or SampledScheduledGain
    n_steps : int
        Number of steps (>= 1).
    seed : int, optional
        Seed of ``numpy.random.default_rng``.

    Returns
    -------
    ndarray, shape (n_in, n_steps)
        A PID's rows are e (uniform in ±0.05, the errors' units) then ė (±0.5 per s);
        state feedback's the state x (standard normal); a schedule's x then p̂, uniform
        over the breakpoints' range widened by 10 % on each side (the edge gain is
        exercised).
    """
    _kind(controller)
    n_steps = check_int("n_steps", n_steps, 1)
    return controller.random_inputs(np.random.default_rng(seed), n_steps)


def check_toolchain(board: str = "cortex-m4f") -> Board:
    """The board `board`, once its compiler, C library, binutils and emulator are found.

    Parameters
    ----------
    board : str, optional
        A name of :data:`BOARDS`.

    Returns
    -------
    Board

    Raises
    ------
    MissingToolError
        Naming the programs not found and the Debian packages that install them.
    """
    spec = BOARDS[check_choice("board", board, tuple(BOARDS))]
    missing = [tool for tool in (spec.compiler, spec.tool("size"), spec.tool("nm"), spec.emulator)
               if shutil.which(tool) is None]
    if not missing:
        found = subprocess.run([spec.compiler, "-print-file-name=rdimon.specs"], capture_output=True, text=True,
                               timeout=60).stdout.strip()
        if not os.path.isabs(found):
            missing.append("the C library (newlib: rdimon.specs)")
    if missing:
        raise MissingToolError(
            f"the {spec.name} target needs {', '.join(missing)}: install the Debian packages "
            f"{' and '.join(spec.packages)} (apt-get install {' '.join(spec.packages)})")
    return spec


def _run(command: Sequence[str], cwd: Path, what: str, timeout: float) -> subprocess.CompletedProcess[str]:
    try:
        done = subprocess.run(list(command), cwd=cwd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as err:
        raise ScaraRobustError(f"{what} did not finish within {timeout:g} s") from err
    if done.returncode != 0:
        last = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or [""]
        raise ScaraRobustError(f"{what} failed (exit {done.returncode}): {last[0]}")
    return done


def _driver(controller: Controller, prefix: str, ctype: str) -> str:
    n_in, n_out = controller.step_sizes
    declare = ""
    p = n_in // 5
    call = {"pid": f"{prefix}_step(&s, &in_rows[k][0], &in_rows[k][{n_in // 2}], out_rows[k])"
            if getattr(controller, "feedforward", None) is None else  # the whole controller: r, ṙ, r̈, q, q̇
            f"{prefix}_step(&s, &in_rows[k][0], &in_rows[k][{p}], &in_rows[k][{2 * p}], &in_rows[k][{3 * p}], "
            f"&in_rows[k][{4 * p}], out_rows[k])",
            "scheduled": f"(void){prefix}_step(in_rows[k], in_rows[k][{n_in - 1}], out_rows[k])",
            "state feedback": f"{prefix}_step(in_rows[k], out_rows[k])"}[controller.kind]
    if controller.n_state_values:
        declare = f"    {prefix}_state s;\n    {prefix}_init(&s);"
    return _DRIVER.format(prefix=prefix, T=ctype, n_in=n_in, n_out=n_out, declare=declare, call=call)


#: The guest pc of each line of QEMU's ``-d exec`` log: ``Trace N: 0x... [cpu/pc/flags/...]``.
_TRACE_PC = re.compile(rb"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/", re.MULTILINE)
#: Bytes of the log read at once (a traced step of the arm's feedforward logs some 100 000 lines).
_TRACE_CHUNK = 1 << 24
_HEX = np.full(256, -1, dtype=np.int64)
_HEX[np.frombuffer(b"0123456789abcdef", dtype=np.uint8)] = np.arange(16)


def _pcs(found: list[bytes]) -> NDArray[np.int64]:
    """The hexadecimal pcs as integers (vectorized where QEMU printed them at one width, as it does)."""
    width = len(found[0]) if found else 0
    joined = b"".join(found)
    if width and len(joined) == width * len(found) and width <= 15:
        digits = _HEX[np.frombuffer(joined, dtype=np.uint8).reshape(len(found), width)]
        return np.asarray(digits @ (16 ** np.arange(width - 1, -1, -1, dtype=np.int64)), dtype=np.int64)
    return np.array([int(x, 16) for x in found], dtype=np.int64)


def _count_steps(trace: Any, entry: int, main: tuple[int, int]) -> list[int]:
    """Instructions from each entry to `entry` until the next instruction inside `main` [start, end).

    `trace` is the binary stream of QEMU's ``-d exec`` log, one line per instruction executed
    (``-singlestep``); lines of another form are not counted. The log is read in chunks and
    searched with numpy: a step of the arm's RNEA feedforward in soft double logs about
    10⁵ lines.
    """
    counts: list[int] = []
    inside, n = False, 0
    rest = b""
    while True:
        chunk = trace.read(_TRACE_CHUNK)
        data = rest + chunk
        if chunk:
            cut = data.rfind(b"\n") + 1
            data, rest = data[:cut], data[cut:]
        else:
            rest = b""
        pc = _pcs(_TRACE_PC.findall(data))
        in_main = np.flatnonzero((pc >= main[0]) & (pc < main[1]))
        entries = np.flatnonzero(pc == entry)
        at = 0
        while at < pc.size:
            if inside:
                k = int(np.searchsorted(in_main, at))
                if k == in_main.size:
                    n += pc.size - at
                    break
                counts.append(n + int(in_main[k]) - at)
                inside, at = False, int(in_main[k]) + 1
            else:
                k = int(np.searchsorted(entries, at))
                if k == entries.size:
                    break
                inside, n, at = True, 1, int(entries[k]) + 1
        if not chunk:
            return counts


def _symbols(nm: str, path: Path, cwd: Path) -> dict[str, tuple[int, int]]:
    """Name -> (address, size) of the defined symbols of `path` (Thumb bit cleared)."""
    out = _run([nm, "-S", "--defined-only", str(path)], cwd, "nm", 60).stdout
    table: dict[str, tuple[int, int]] = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4:
            table[parts[3]] = (int(parts[0], 16) & ~1, int(parts[1], 16))
    return table


def run_on_board(
    controller: Controller,
    inputs: Any,
    *,
    board: str = "cortex-m4f",
    precision: str = "double",
    prefix: str = DEFAULT_PREFIX,
    trace_steps: int = 100,
    clock_hz: float | None = None,
    timeout: float = 600.0,
    workdir: str | os.PathLike[str] | None = None,
) -> BoardRun:
    """Run `controller`'s exported C on an emulated board and compare it with the Python step.

    Parameters
    ----------
    controller : DiscretePID, SampledStateFeedback or SampledScheduledGain
        As :func:`export_controller` takes it. The PID starts from state zero (``init``).
    inputs : array_like, shape (n_in, n_steps)
        One column per step, as :func:`board_inputs` makes them: a PID's e then ė, state
        feedback's x, a schedule's x then p̂. In single precision they are rounded to
        float32 first (the board and the reference read the same numbers).
    board : str, optional
        A name of :data:`BOARDS`.
    precision : {'double', 'single'}, optional
        The C's floating-point type (default double, as :func:`export_controller`). On a
        Cortex-M4F ``'double'`` runs in the compiler's software floating point.
    prefix : str, optional
        The C names' prefix.
    trace_steps : int, optional
        The first steps traced to count instructions (>= 1; each traced instruction is a
        line of QEMU's log, so keep it in the hundreds).
    clock_hz : float, optional
        The clock of the time estimate, Hz (default: the board's, 168 MHz for the
        Cortex-M4F).
    timeout : float, optional
        Seconds allowed to each compile and emulator run.
    workdir : path-like, optional
        An existing folder to build in and keep (the C, the driver, ``image.elf``, the
        objects and ``controller.su``); by default a temporary folder, removed.

    Returns
    -------
    BoardRun

    Raises
    ------
    MissingToolError
        Where the compiler, its C library or the emulator is missing (naming the packages).
    ScaraRobustError
        Where a compile or an emulator run fails.
    """
    kind = _kind(controller)
    spec = BOARDS[check_choice("board", board, tuple(BOARDS))]
    check_choice("precision", precision, PRECISIONS)
    check_prefix(prefix)
    n_in, n_out = controller.step_sizes
    x = check_array("inputs", inputs, shape=(n_in, None))
    if x.shape[1] < 1:
        raise ScaraRobustError("`inputs` must have at least one column (step), found 0")
    trace_steps = check_int("trace_steps", trace_steps, 1)
    clock = spec.clock_hz if clock_hz is None else check_real("clock_hz", clock_hz, positive=True)
    timeout = check_real("timeout", timeout, positive=True)
    check_toolchain(board)
    ftype = np.float32 if precision == "single" else np.float64
    ctype = "float" if precision == "single" else "double"
    x = x.astype(ftype)
    reference = controller.run_steps(x.astype(float), precision)
    flags = [*spec.cflags, "-std=c99", "-O2", "-ffp-contract=off", "-ffunction-sections", "-fdata-sections"]
    if workdir is not None and not Path(workdir).is_dir():
        raise ScaraRobustError(f"`workdir` {os.fspath(workdir)!r}: no such folder")
    with (contextlib.nullcontext(os.fspath(workdir)) if workdir is not None
          else tempfile.TemporaryDirectory(prefix="scara-board-")) as tmp:
        work = Path(tmp)
        files = get_target("c").files(controller, prefix=prefix, precision=precision)
        for name, text in files.items():
            (work / name).write_text(text)
        (work / "driver.c").write_text(_driver(controller, prefix, ctype))
        (work / "startup.c").write_text(_STARTUP)
        (work / "link.ld").write_text(_LINKER)
        cc = spec.compiler
        version = _run([cc, "--version"], work, cc, timeout).stdout.splitlines()[0]
        _run([cc, *flags, "-Wall", "-Wextra", "-Werror", "-pedantic", "-fstack-usage", "-c", f"{prefix}.c",
              "-o", "controller.o"], work, f"{cc} (the controller)", timeout)
        for name in ("driver", "startup"):
            _run([cc, *flags, "-c", f"{name}.c", "-o", f"{name}.o"], work, f"{cc} (the test image's {name})",
                 timeout)
        libm = ["-lm"] if getattr(controller, "feedforward", None) is not None else []  # the RNEA's cos and sin
        _run([cc, *spec.cflags, "-nostartfiles", "-T", "link.ld", "--specs=rdimon.specs", "-Wl,--gc-sections",
              "-o", "image.elf", "startup.o", "driver.o", "controller.o", *libm], work, f"{cc} (linking)", timeout)
        emulate = [spec.emulator, "-M", spec.machine, "-nographic", "-monitor", "none", "-serial", "none",
                   "-semihosting-config", "enable=on,target=native", "-kernel", "image.elf"]
        (work / "in.bin").write_bytes(np.ascontiguousarray(x.T).tobytes())
        _run(emulate, work, f"{spec.emulator} -M {spec.machine}", timeout)
        raw = np.frombuffer((work / "out.bin").read_bytes(), dtype=ftype)
        if raw.size != n_out * x.shape[1]:
            raise ScaraRobustError(f"the board wrote {raw.size} outputs, expected {n_out * x.shape[1]}")
        u = raw.reshape(x.shape[1], n_out).T.astype(float)
        # the instruction count: the first trace_steps rows again, every executed instruction logged
        (work / "in.bin").write_bytes(np.ascontiguousarray(x[:, :trace_steps].T).tobytes())
        symbols = _symbols(spec.tool("nm"), work / "image.elf", work)
        entry = symbols[f"{prefix}_step"][0]
        main = (symbols["main"][0], symbols["main"][0] + symbols["main"][1])
        with subprocess.Popen([*emulate, "-singlestep", "-d", "exec,nochain"], cwd=work, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE) as proc:
            assert proc.stderr is not None
            counts = _count_steps(proc.stderr, entry, main)
            code = proc.wait(timeout=timeout)
        if code != 0 or len(counts) != min(trace_steps, x.shape[1]):
            raise ScaraRobustError(f"the traced run of {spec.emulator} gave {len(counts)} steps (exit {code}), "
                                   f"expected {min(trace_steps, x.shape[1])}")
        flash, ram, stack, helpers = _footprint(spec, work, prefix, symbols, controller, ctype)
    diff = float(np.max(np.abs(u - reference)))
    tolerance = 0.0 if precision == "single" else 1e-12 * max(1.0, float(np.max(np.abs(reference))))
    return BoardRun(board=spec.name, precision=precision, kind=kind, Ts=float(controller.Ts), u=u,
                    u_reference=reference, max_abs_difference=diff, tolerance=tolerance,
                    instructions=np.asarray(counts, dtype=np.int64), flash_bytes=flash, ram_bytes=ram,
                    stack_bytes=stack, helpers=helpers, clock_hz=clock, compiler=version)


def _footprint(spec: Board, work: Path, prefix: str, symbols: dict[str, tuple[int, int]], controller: Controller,
               ctype: str) -> tuple[int, int, int, tuple[str, ...]]:
    """(flash, RAM, stack of the step, helpers) of the controller, bytes."""
    size = _run([spec.tool("size"), "controller.o"], work, spec.tool("size"), 60).stdout.splitlines()[-1].split()
    text, data, bss = (int(v) for v in size[:3])
    undefined = _run([spec.tool("nm"), "-u", "controller.o"], work, spec.tool("nm"), 60).stdout.split()
    helpers = sorted({name for name in undefined if name in symbols})  # nm's "U" markers are no symbols
    by_address = {symbols[name][0]: symbols[name][1] for name in helpers}  # aliases share an address
    usage = (work / "controller.su").read_text() if (work / "controller.su").exists() else ""
    stack = max((int(parts[-2]) for line in usage.splitlines()
                 if (parts := line.split()) and parts[0].endswith(f":{prefix}_step")), default=0)
    state = controller.n_state_values * (4 if ctype == "float" else 8)
    return text + data + sum(by_address.values()), data + bss + state + stack, stack, tuple(helpers)
