"""Running a campaign: every controller on every drawn scenario, chunked, resumable, local or on Dask.

:func:`run_campaign` simulates the scenarios of a :class:`~scara_robust.CampaignSpec` in
chunks, locally (one process, or a pool of processes) or on a ``dask.distributed``
cluster (extra ``dask``), and rewrites the results file atomically after the first chunk
and then at checkpoints a few seconds apart, so a killed campaign keeps what it had
stored, an interrupted one everything it finished, and ``resume=True`` runs only the
rest. A failed run (diverged, solver error) becomes a row with its error; it never stops
the campaign. Each chunk's runs go through :func:`scara_robust.run_scenarios`, so each run
is the :func:`scara_robust.run_scenario` of its inputs, like every other run of the package.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

import pandas as pd
from tqdm import tqdm

from ..._resources import check_memory, simulation_bytes, table_bytes
from ..._validation import check_choice, check_instance, check_int, check_real
from ...exceptions import ArgumentValueError, CampaignSpecError
from ...io import table_format, write_atomic
from ...simulation.arm import simulate_arm
from ...simulation.compiled import compile_seconds, numba_available
from ...simulation.metrics import METRIC_NAMES
from ...simulation.run import run_scenarios
from .arm import ARM_FIXED_COLUMNS, arm_context, arm_drawn_columns, draw_arm_scenario, run_arm_draws
from .inputs import DRAWN_COLUMNS, FIXED_COLUMNS, fixed_inputs, run_arguments
from .spec import CampaignSpec, draw_scenario

__all__ = ["run_campaign", "read_results"]

#: Where :func:`run_campaign` can run.
SCHEDULERS = ("local", "dask")
#: How its runs are integrated (``'auto'``: compiled when numba is installed).
CAMPAIGN_ENGINES = ("auto", "compiled", "scipy")
#: Controllers the compiled engine runs; the others use the scipy engines in any campaign.
COMPILED_CONTROLLERS = ("pid", "pid-lmi", "smc", "smc-sign")


def run_draw(spec: CampaignSpec, draw: Mapping[str, Any], engine: str = "scipy") -> list[dict[str, Any]]:
    """Simulate every controller of `spec` on one drawn scenario; one row each.

    A run that raises or diverges gives a row with ``success = False`` and its
    ``error``; metrics that do not exist are NaN. ``status`` says whether the run tracks
    (see :data:`scara_robust.STATUSES`); a run that raises is ``failed``.

    Parameters
    ----------
    spec : CampaignSpec
    draw : mapping
        From :func:`draw_scenario`.
    engine : {'scipy', 'compiled'}
        ``'compiled'`` runs the package's PID and sliding-mode laws on the compiled engine
        (``method='compiled'``); other controllers, and everything with ``'scipy'``, on the
        engines of :func:`scara_robust.simulate` by default.

    Returns
    -------
    list of dict
        One row per controller: the drawn and fixed inputs (the run's arguments come
        from :func:`scara_robust.studies.campaign.inputs.run_arguments`, as for :func:`scara_robust.replay_scenario`),
        ``controller``, ``success``, ``diverged``, ``error``, ``status``, ``status_reason`` and the metrics of
        :func:`scara_robust.tracking_metrics`.
    """
    return run_draws(spec, [draw], engine)


def run_draws(spec: CampaignSpec, draws: Sequence[Mapping[str, Any]], engine: str = "scipy") -> list[dict[str, Any]]:
    """:func:`run_draw` for several draws (a chunk), its compiled runs batched.

    The runs go through :func:`scara_robust.run_scenarios`, so the compiled ones of a chunk
    are integrated in one compiled call per controller kind; the rows equal those of
    :func:`run_draw` for each draw.

    Parameters
    ----------
    spec : CampaignSpec
    draws : sequence of mapping
        From :func:`draw_scenario`.
    engine : {'scipy', 'compiled'}
        As :func:`run_draw`.

    Returns
    -------
    list of dict
        The rows of every draw, in order (draw by draw, controller by controller).
    """
    fixed = fixed_inputs(spec)
    rows: list[dict[str, Any]] = []
    requests: list[dict[str, Any]] = []
    for draw in draws:
        inputs = {**draw, **fixed}
        arguments = run_arguments(inputs)
        for name in spec.controllers:
            method = "compiled" if engine == "compiled" and name in COMPILED_CONTROLLERS else None
            rows.append({**inputs, "controller": name, "method": method or "default"})
            requests.append({"controller": name, "method": method, **arguments})
    for row, result in zip(rows, run_scenarios(requests, errors="return")):
        metrics = dict.fromkeys(METRIC_NAMES, math.nan)
        if isinstance(result, Exception):  # a failed scenario is data, not a crash
            error = f"{type(result).__name__}: {result}"
            row.update(success=False, diverged=False, error=error, status="failed", status_reason=error)
        else:
            row["method"] = result.method
            row.update(success=result.success, diverged=result.diverged, error="" if result.success else result.message)
            row.update(status=result.status, status_reason=result.status_reason)
            if result.success and result.has_metrics:
                metrics = result.metrics().to_dict()
        row.update(metrics)
    return rows


def _run_chunk(spec: CampaignSpec, seed: int, indices: Sequence[int], engine: str = "scipy") -> list[dict[str, Any]]:
    if spec.robot_file is not None:
        n = arm_context(spec)[0].arm.n_joints
        return run_arm_draws(spec, [draw_arm_scenario(spec, seed, i, n) for i in indices], seed, engine)
    return run_draws(spec, [draw_scenario(spec, seed, i) for i in indices], engine)


def resolve_engine(engine: str) -> str:
    """The campaign engine: ``'auto'`` is ``'compiled'`` when numba is installed, else ``'scipy'``.

    Parameters
    ----------
    engine : {'auto', 'compiled', 'scipy'}

    Returns
    -------
    {'compiled', 'scipy'}
    """
    engine = check_choice("engine", engine, CAMPAIGN_ENGINES)
    if engine == "auto":
        return "compiled" if numba_available() else "scipy"
    if engine == "compiled" and not numba_available():
        raise ArgumentValueError("engine", "'compiled' needs numba: pip install '.[compiled]', or use 'scipy'")
    return engine


#: Columns of a SCARA campaign's results table, in order (an arm's: :func:`result_columns`).
RESULT_COLUMNS = (
    "scenario",
    "controller",
    "status",
    "success",
    "diverged",
    "error",
    *METRIC_NAMES,
    *DRAWN_COLUMNS,
    *FIXED_COLUMNS,
    "method",
    "status_reason",
    "seed",
    "spec",
)


def result_columns(spec: CampaignSpec) -> list[str]:
    """The columns of `spec`'s results table, in order.

    Parameters
    ----------
    spec : CampaignSpec

    Returns
    -------
    list of str
        :data:`RESULT_COLUMNS` for the SCARA; for an arm, its drawn inputs (one initial
        error per joint) and fixed ones (``ARM_FIXED_COLUMNS``).
    """
    if spec.robot_file is None:
        return list(RESULT_COLUMNS)
    n = arm_context(spec)[0].arm.n_joints
    head = ["scenario", "controller", "status", "success", "diverged", "error", *METRIC_NAMES]
    return [*head, *arm_drawn_columns(n), *ARM_FIXED_COLUMNS, "method", "status_reason", "seed", "spec"]


def read_results(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a campaign results file (``.csv`` or ``.parquet``).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    pandas.DataFrame
        One row per (scenario, controller); ``error`` is a string (empty when none).


    Raises
    ------
    OSError
        If it cannot be read.
    ValueError
        If the extension is not ``.csv`` or ``.parquet`` or the file is not a campaign table.
    """
    fmt = table_format("path", path)
    if fmt == "csv":
        # the spec's digest is text: hexadecimal digits such as '8869e4053699' would read as a float (inf)
        frame = pd.read_csv(path, keep_default_na=False, na_values=["", "NaN", "nan"], dtype={"spec": str})
    else:
        frame = pd.read_parquet(path)
    missing = {"scenario", "controller", "status", "success", "seed", "spec"} - set(frame.columns)
    if missing:
        found = f"{os.fspath(path)!r} is not a campaign table: missing columns {sorted(missing)}"
        raise ArgumentValueError("path", found)
    for text in ("error", "status_reason"):
        frame[text] = ["" if isinstance(v, float) and math.isnan(v) else str(v) for v in frame[text]]
    return frame


def _write(path: str, frame: pd.DataFrame) -> None:
    if table_format("output", path) == "csv":
        write_atomic(path, lambda tmp: frame.to_csv(tmp, index=False))
    else:
        write_atomic(path, lambda tmp: frame.to_parquet(tmp, index=False))


def _normalize(frame: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    frame = frame[columns].sort_values(["scenario", "controller"], kind="stable").reset_index(drop=True)
    return frame.astype(
        {"scenario": int, "seed": int, "success": bool, "diverged": bool, "error": str, "status": str,
         "status_reason": str}
    )


def _chunks(indices: Sequence[int], size: int) -> Iterator[list[int]]:
    for start in range(0, len(indices), size):
        yield list(indices[start : start + size])


def run_campaign(
    spec: CampaignSpec,
    output: str | os.PathLike[str],
    *,
    runs: int | None = None,
    seed: int | None = None,
    workers: int = 1,
    scheduler: str = "local",
    address: str | None = None,
    resume: bool = False,
    chunk_size: int = 4,
    progress: bool = False,
    engine: str = "auto",
    checkpoint: float = 2.0,
    on_chunk: Callable[[int], None] | None = None,
) -> pd.DataFrame:
    """Run a campaign and store one row per (scenario, controller) in `output`.

    Parameters
    ----------
    spec : CampaignSpec
        A SCARA campaign, or an arm's (:func:`~scara_robust.arm_campaign_spec`).
    output : path
        ``.csv`` or ``.parquet`` file, sorted by scenario and controller, rewritten
        atomically after the first chunk, then at checkpoints (see `checkpoint`), and at
        the end or on an interruption.
    runs, seed : int, optional
        Number of scenarios and seed (default: the spec's).
    workers : int
        Processes (local) or workers of the ``LocalCluster`` (dask), >= 1. One local
        worker runs in this process.
    scheduler : {'local', 'dask'}
    address : str, optional
        Address of a running dask scheduler (default: start a ``LocalCluster``).
    resume : bool
        Continue an existing `output` of the same spec and seed, running only the
        scenarios it lacks. Without it, an existing `output` is an error (never
        overwritten).
    chunk_size : int
        Scenarios per task (>= 1).
    progress : bool
        A tqdm bar over scenarios on stderr.
    engine : {'auto', 'compiled', 'scipy'}
        See :func:`resolve_engine` and :func:`run_draw`; the table does not depend on the
        worker count or the chunking with either.
    checkpoint : float
        Least time between two rewrites of `output`, s (>= 0; 0 rewrites it after every
        chunk). The interval also grows to ten times the last rewrite's duration, so that
        rewriting a large table costs at most about a tenth of the campaign. A killed
        campaign loses the chunks finished since the last rewrite; ``resume`` reruns them.
    on_chunk : callable, optional
        Called with the number of scenarios stored after each rewrite of `output`.

    Returns
    -------
    pandas.DataFrame
        The whole table, as stored.
    """
    check_instance("spec", spec, CampaignSpec, "a CampaignSpec (see load_spec)")
    check_choice("scheduler", scheduler, SCHEDULERS)
    if spec.robot_file is None and spec.arm_ranges:
        name = next(iter(spec.arm_ranges))
        raise CampaignSpecError(f"campaign spec field `{name}`: applies to an arm campaign (a robot file naming a "
                                "URDF); the SCARA's campaign does not draw it")
    runs = spec.runs if runs is None else runs
    seed = spec.seed if seed is None else seed
    checks = (("runs", runs, 1), ("seed", seed, 0), ("workers", workers, 1), ("chunk_size", chunk_size, 1))
    for name, value, low in checks:
        check_int(name, value, low)
    n_rows = runs * len(spec.controllers)
    check_memory("runs", table_bytes(n_rows, len(RESULT_COLUMNS)), f"a table of {n_rows:,} runs")
    states = 8 if spec.robot_file is None else 3 * arm_context(spec)[0].arm.n_joints
    check_memory("spec", workers * simulation_bytes(spec.t_final, 1e-3, states),
                 f"{workers} run(s) at once of t_final = {spec.t_final:g} s each")
    checkpoint = check_real("checkpoint", checkpoint, nonnegative=True)
    engine = resolve_engine(engine)
    path = os.fspath(output)
    table_format("output", path)
    columns = result_columns(spec)
    digest = spec.digest()
    done: set[int] = set()
    stored = pd.DataFrame(columns=columns)
    if os.path.exists(path):
        if not resume:
            raise FileExistsError(f"{path!r} exists; pass resume=True to continue it, or choose another file")
        stored = read_results(path)
        other = stored[(stored["spec"] != digest) | (stored["seed"] != seed)]
        if len(other):
            raise ArgumentValueError("resume", f"cannot continue {path!r}: it holds rows of another spec or seed")
        lacking = [c for c in columns if c not in stored.columns]
        if lacking:
            raise ArgumentValueError(
                "resume", f"cannot continue {path!r}: it lacks the columns {lacking} (an older table); start a new file"
            )
        counts = stored.groupby("scenario")["controller"].nunique()
        done = set(counts[counts == len(spec.controllers)].index.astype(int))
        stored = stored[stored["scenario"].isin(done)]
    todo = [i for i in range(int(runs)) if i not in done]
    bar = tqdm(
        total=int(runs), initial=len(done), disable=not progress, file=sys.stderr, desc="campaign", unit="scenario"
    )

    pending: list[dict[str, Any]] = []
    last_write = -math.inf
    interval = checkpoint

    def flush() -> None:
        nonlocal stored, pending, last_write, interval
        if not pending:
            return
        fresh = pd.DataFrame(pending).assign(seed=int(seed), spec=digest)
        stored = _normalize(pd.concat([stored, fresh], ignore_index=True) if len(stored) else fresh, columns)
        start = time.monotonic()
        _write(path, stored)
        last_write = time.monotonic()
        interval = max(checkpoint, 10.0 * (last_write - start)) if checkpoint > 0 else 0.0
        pending = []
        if on_chunk is not None:
            on_chunk(int(stored["scenario"].nunique()))

    if engine == "compiled" and todo and scheduler == "local":
        # the kernels load (or compile: about 30 s on a machine without numba's cache) before the first chunk
        bar.set_description("campaign (compiling the simulation kernels, once)")
        _load_kernels(spec)
        bar.set_description("campaign")
    try:
        for rows in _execute(spec, int(seed), todo, int(workers), scheduler, address, int(chunk_size), engine):
            pending.extend(rows)
            bar.update(len({r["scenario"] for r in rows}))
            if time.monotonic() - last_write >= interval:
                flush()
    finally:
        try:
            flush()
        finally:
            bar.close()
    if not len(stored):
        stored = _normalize(pd.DataFrame(columns=columns), columns)
    return stored


def _execute(
    spec: CampaignSpec, seed: int, todo: list[int], workers: int, scheduler: str, address: str | None, size: int,
    engine: str,
) -> Iterable[list[dict[str, Any]]]:
    chunks = list(_chunks(todo, size))
    if not chunks:
        return
    if scheduler == "dask":
        yield from _execute_dask(spec, seed, chunks, workers, address, engine)
    elif workers == 1:
        for chunk in chunks:
            yield _run_chunk(spec, seed, chunk, engine)
    else:
        if engine == "compiled":
            _load_kernels(spec)  # load the kernels once here; forked workers inherit them
        with ProcessPoolExecutor(max_workers=workers, initializer=_exit_with_parent, initargs=(os.getpid(),)) as pool:
            futures = [pool.submit(_run_chunk, spec, seed, chunk, engine) for chunk in chunks]
            try:
                for future in as_completed(futures):
                    yield future.result()
            finally:
                for future in futures:
                    future.cancel()


def _load_kernels(spec: CampaignSpec) -> None:
    """Load (or compile) the compiled kernels `spec`'s runs use, in this process."""
    if spec.robot_file is None:
        compile_seconds()
        return
    setup, K = arm_context(spec)  # a short run loads the arm's kernels and checks its dynamics against Pinocchio
    simulate_arm(setup, K, method="compiled", t_final=0.01, t_transient=0.0)


def _exit_with_parent(parent: int, period: float = 0.5) -> None:
    """In a worker process: exit as soon as the campaign's process is gone (killed, say).

    A worker blocked on its task queue would otherwise outlive a ``kill -9`` of the
    campaign, since its siblings keep the queue's pipe open.
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(period)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _execute_dask(
    spec: CampaignSpec, seed: int, chunks: list[list[int]], workers: int, address: str | None, engine: str
) -> Iterable[list[dict[str, Any]]]:
    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError as err:
        raise ArgumentValueError("scheduler", "'dask' needs the `dask` extra: pip install '.[dask]'") from err
    # dask.distributed is not typed: its calls are untyped for mypy
    cluster = (
        None
        if address
        else LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)  # type: ignore[no-untyped-call]
    )
    client = Client(address if address else cluster)  # type: ignore[no-untyped-call]
    try:
        futures = [client.submit(_run_chunk, spec, seed, chunk, engine, pure=False) for chunk in chunks]
        for future in dask_completed(futures):  # type: ignore[no-untyped-call]
            yield future.result()
    finally:
        client.close()  # type: ignore[no-untyped-call]
        if cluster is not None:
            cluster.close()
