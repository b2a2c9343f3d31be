"""Offline reanalysis of many stored runs on Dask (issue 8).

One Dask task per run file: the task opens the file itself (h5py objects do not pickle, and HDF5
calls serialise within one process, so worker processes, not threads, give the speed-up), runs
the chosen estimator on every level and returns one flat row per level. A run that cannot be
read or analysed becomes a row with ``status = "failed"`` and a one-line ``error``; the other
runs carry on. Rows are gathered in input order (run, then level), so the table does not
depend on the number of workers or on completion order.
"""

from __future__ import annotations

import faulthandler
import logging
import math
import os
import statistics
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from analysis.errors import InputError
from analysis.models import Model
from analysis.recordings import Recording

from . import methods
from .store import TableRow, write_table

AUTO = "auto"  # each level's method from its excitation (`nlid_lab.methods.for_excitation`)
RUN_SUFFIXES = (".h5", ".hdf5", ".npz")
HEAD = ("path", "level_index", "level", "excitation", "method", "status")
TAIL = ("coherence_min", "cost", "warnings", "error")
CONNECT_TIMEOUT_S = 10.0
MAX_LISTED = 20  # failed rows named in the summary
SCHEMA_VERSION = 1
"""Version of the reanalysis JSON (`Reanalysis.to_json`, ``reanalyze --json``)."""
NANNY_ENVIRON = "distributed.nanny.pre-spawn-environ"


class ReanalysisError(InputError):
    """Bad reanalysis input: no runs, unknown method, unreachable scheduler."""


@dataclass(frozen=True)
class LevelRow:
    """One level of one run in the reanalysis table (a run that cannot be read: one failed
    row with ``level_index`` -1).

    ``estimates`` holds the estimated parameters by column, ``e{i}.{kind}.{param}``, each with
    its 95 % interval as ``....ci95_lo`` / ``....ci95_hi`` (None where the estimator gave
    none); ``warnings`` are joined by `` | ``, ``error`` is one line.
    """

    path: str
    level_index: int
    level: float | None
    excitation: str | None
    method: str
    status: str                   # "ok" or "failed"
    estimates: Mapping[str, float | None] = field(default_factory=dict)
    coherence_min: float | None = None
    cost: float | None = None
    warnings: str = ""
    error: str = ""

    @property
    def ok(self) -> bool:
        """Whether the level was estimated."""
        return self.status == "ok"


@dataclass
class Reanalysis:
    """Gathered result of `reanalyze`.

    Attributes
    ----------
    rows : list of LevelRow
        One row per run and level, input order (run, then level).
    method : str
    n_runs : int
    n_workers : int
        Workers the cluster had when the work was submitted.
    scheduler : str
        Address of the scheduler used.
    elapsed_s : float
        Wall time from submission to the last gathered result.
    attrs : dict
        Extra table attributes: model name and TOML, estimator options.
    """

    rows: list[LevelRow]
    method: str
    n_runs: int
    n_workers: int
    scheduler: str
    elapsed_s: float
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def n_ok(self) -> int:
        """Number of rows estimated."""
        return sum(row.ok for row in self.rows)

    @property
    def n_failed(self) -> int:
        """Number of rows that failed."""
        return len(self.rows) - self.n_ok

    @property
    def failed_runs(self) -> list[str]:
        """Paths with at least one failed row, in input order."""
        return list(dict.fromkeys(r.path for r in self.rows if not r.ok))

    def parameter_columns(self) -> list[str]:
        """Estimate columns (``e{i}.{kind}.{param}``), without their intervals."""
        columns = dict.fromkeys(c for row in self.rows for c in row.estimates)
        return [c for c in columns if ".ci95_" not in c]

    def summary(self) -> str:
        """A few lines for the terminal: counts, failures, parameter spread."""
        lines = [f"reanalysed {self.n_runs} run(s), {len(self.rows)} level(s) with "
                 f"{self.method} on {self.n_workers} worker(s) in {self.elapsed_s:.1f} s: "
                 f"{self.n_ok} ok, {self.n_failed} failed"]
        failed = [row for row in self.rows if not row.ok]
        for row in failed[:MAX_LISTED]:
            where = "" if row.level_index < 0 else f" level {row.level_index}"
            lines.append(f"  FAILED {row.path}{where}: {row.error}")
        if len(failed) > MAX_LISTED:
            lines.append(f"  ... and {len(failed) - MAX_LISTED} more failed rows (see the table)")
        ok = [row for row in self.rows if row.ok]
        for col in self.parameter_columns():
            values = [v for row in ok if _finite(v := row.estimates.get(col))]
            if values:
                lines.append(f"  {col}: median {statistics.median(values):.5g} "
                             f"[{min(values):.5g} .. {max(values):.5g}] over {len(values)}")
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The reanalysis as JSON: ``schema_version``, counts, workers, timing and rows."""
        return {"schema_version": SCHEMA_VERSION, "method": self.method, "n_runs": self.n_runs,
                "n_rows": len(self.rows), "n_ok": self.n_ok, "n_failed": self.n_failed, "n_workers": self.n_workers,
                "scheduler": self.scheduler, "elapsed_s": self.elapsed_s,
                "failed_runs": self.failed_runs,
                "rows": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                          for k, v in row.items()} for row in table_json(self.rows)]}


# --- inputs --------------------------------------------------------------------------------
def expand_runs(items: Sequence[str | Path]) -> list[str]:
    """Run files from paths and directories (a directory gives its *.h5/*.hdf5/*.npz, sorted).

    Raises `ReanalysisError` for a path that does not exist or a directory without runs.
    """
    runs: list[str] = []
    for item in items:
        path = Path(item)
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.suffix.lower() in RUN_SUFFIXES)
            if not found:
                raise ReanalysisError(f"{path}: directory holds no {'/'.join(RUN_SUFFIXES)} "
                                      "runs; give run files or a campaign directory")
            runs += [str(p) for p in found]
        elif path.exists():
            runs.append(str(path))
        else:
            raise ReanalysisError(f"{path}: no such run file; check the path")
    if not runs:
        raise ReanalysisError("no runs given; name run files or a campaign directory")
    return runs


def check_request(model: Model, method: str, run_timeout_s: float | None = None) -> None:
    """Raise `ReanalysisError` for an unknown method, a model with nothing to estimate or a
    time limit that is not positive."""
    if run_timeout_s is not None and not run_timeout_s > 0:
        raise ReanalysisError(f"the run time limit must be > 0 s, got {run_timeout_s:g}")
    names = [m.name for m in methods.methods()] + [AUTO]
    if method not in names:
        raise ReanalysisError(f"unknown method '{method}'; use one of {', '.join(names)}")
    if model.complete:
        raise ReanalysisError(f"the candidate model '{model.name}' has no unknown parameter; "
                              "omit the parameters to estimate from its elements")


# --- the task ------------------------------------------------------------------------------
def analyse_run(path: str, model: Model, method: str, options: methods.BatchOptions,
                timeout_s: float | None = None) -> list[LevelRow]:
    """Rows of one run: open ``path`` here (on the worker), estimate every level.

    Never raises for a bad run: failures become rows with ``status = "failed"``; a run that
    cannot be read gives a single row with ``level_index = -1``. With ``timeout_s`` (worker
    processes with one thread only!) the process dumps its stacks to stderr and exits when the
    run takes longer: a thread stuck inside HDF5 holds the GIL, so only faulthandler's C-level
    watchdog can still act; Dask's nanny then starts a fresh worker.
    """
    if timeout_s:
        faulthandler.dump_traceback_later(timeout_s, exit=True)
    try:
        return _analyse_levels(path, model, method, options)
    finally:
        if timeout_s:
            faulthandler.cancel_dump_traceback_later()


def _analyse_levels(path: str, model: Model, method: str,
                    options: methods.BatchOptions) -> list[LevelRow]:
    from nlid_lab.formats import load_recordings  # the worker opens the file itself
    try:
        recordings = load_recordings(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable run is reported, not raised
        return [_failed_row(path, -1, None, None, method, exc)]
    rows = []
    for index, rec in enumerate(recordings):
        try:
            chosen = _method_for(rec, method)
        except InputError as exc:
            rows.append(_failed_row(path, index, rec.level, rec.excitation, method, exc))
            continue
        try:
            row = _estimate_row(path, index, rec, model, chosen, options)
        except Exception as exc:  # noqa: BLE001 - one bad level must not stop the others
            rows.append(_failed_row(path, index, rec.level, rec.excitation, chosen, exc))
        else:
            rows.append(row)
    return rows


def _estimate_row(path: str, index: int, rec: Recording, model: Model, method: str,
                 options: methods.BatchOptions) -> LevelRow:
    """The row of level ``index`` of run ``path``, estimated by ``method`` (its options
    from the batch ``options``; the method's defaults where not given)."""
    chosen = methods.get(method)
    estimate = chosen.estimate_one(rec, model, chosen.make_options(options))
    return level_row(path, index, rec, method, estimate)


def _method_for(rec: Recording, method: str) -> str:
    return methods.for_excitation(rec.excitation).name if method == AUTO else method


def level_row(path: str, index: int, rec: Recording, method: str,
              estimate: methods.LevelEstimate) -> LevelRow:
    """The row of a level's ``estimate``: what the method's result type reads from it
    (`nlid_lab.methods.Method.result`), the reader a stored result of the method goes
    through too, so a row says what ``report`` would show of the same estimate."""
    stored = methods.get(method).result.from_json(estimate.to_json())
    estimates: dict[str, float | None] = {}
    for i, el in enumerate(stored.elements):
        for name, value in el.params.items():
            if name not in el.estimated:                      # hbm lists known ones too
                continue
            col = f"e{i}.{el.kind}.{name}"
            lo, hi = el.ci95.get(name) or (None, None)
            estimates.update({col: _num(value), f"{col}.ci95_lo": _num(lo),
                              f"{col}.ci95_hi": _num(hi)})
    return LevelRow(path, index, rec.level, rec.excitation, method, "ok", estimates,
                    stored.coherence_min, stored.cost, " | ".join(stored.warnings))


def _failed_row(path: str, index: int, level: float | None, excitation: str | None,
                method: str, exc: BaseException | str) -> LevelRow:
    text = " ".join(str(exc).split()) or "no message"
    if isinstance(exc, BaseException) and not isinstance(exc, InputError):
        text = f"{type(exc).__name__}: {text}"
    return LevelRow(path, index, level, excitation, method, "failed", error=text)


def _num(value: Any) -> float | None:
    return None if value is None else float(value)


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value)


# --- the cluster ---------------------------------------------------------------------------
def default_workers() -> int:
    """Cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


@contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A `distributed.Client`: to ``scheduler`` if given, else to a new `LocalCluster`.

    The local cluster has ``workers`` process workers (default: one per core) with one thread
    each; Dask's nanny pins BLAS/OpenMP to one thread per worker.
    """
    import dask                   # dask and distributed load on use: seconds of import
    from distributed import Client, LocalCluster
    if scheduler:
        if workers is not None:
            raise ReanalysisError("--workers applies to the local cluster only; start the "
                                  "wanted workers on the cluster behind --scheduler instead")
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ReanalysisError(f"cannot reach Dask scheduler at {scheduler} "
                                  f"({' '.join(str(exc).split())}); check the address "
                                  "(tcp://host:port) and that the scheduler runs") from None
        with client:
            yield client
        return
    n = default_workers() if workers is None else workers
    if n < 1:
        raise ReanalysisError(f"--workers must be at least 1, got {n}")
    with dask.config.set({NANNY_ENVIRON: worker_environ()}), \
            LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                         dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        yield client


def worker_environ() -> dict[str, str | int]:
    """Dask's pre-spawn worker environment without ``MALLOC_TRIM_THRESHOLD_``.

    Dask sets it to return freed memory to the OS early; setting it also switches off glibc's
    dynamic mmap threshold, so every large numpy temporary is a fresh mmap with page faults:
    measured 29 -> 42 ms per run of reverse path (+45 %). The BLAS/OpenMP one-thread pins stay.
    """
    import dask                   # dask loads on use: seconds of import

    environ = dict(dask.config.get(NANNY_ENVIRON, default={}))
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    return environ


def reanalyze(runs: Sequence[str | Path], model: Model, client: Any,
              method: str = "reverse-path", options: methods.BatchOptions | None = None,
              progress: bool = True, run_timeout_s: float | None = None) -> Reanalysis:
    """Map `analyse_run` over ``runs`` on ``client`` and gather one table.

    Parameters
    ----------
    runs : sequence of path
        Run files (use `expand_runs` for directories); workers must see the same paths.
    model : Model
        Candidate model; elements without parameters are estimated.
    client : distributed.Client
        From `dask_client` or any connected client.
    method : str
        A registered method (`nlid_lab.methods`: "reverse-path", "hbm") or "auto": each
        level's method from its excitation (reverse path for random, HBM for stepped sine).
    options : nlid_lab.methods.BatchOptions, optional
        Batch options of the methods (`nlid_lab.methods.batch_values`): ``band``,
        ``nperseg``, ``refine`` (reverse path), ``harmonics`` (hbm).
    progress : bool
        Show a tqdm bar on stderr while results come in.
    run_timeout_s : float, optional
        Time limit per run: a worker whose run takes longer ends itself (its nanny restarts
        it) and the run becomes a failed row. Dask retries a task whose worker died (config
        ``distributed.scheduler.allowed-failures``, default 3), so a hanging run costs up to
        four times the limit.

    Returns
    -------
    Reanalysis
    """
    from distributed import as_completed   # loads on use, as dask
    from tqdm import tqdm

    check_request(model, method, run_timeout_s)
    paths = [os.path.abspath(p) for p in runs]  # workers may run in another directory
    if not paths:
        raise ReanalysisError("no runs given; name run files or a campaign directory")
    options = options or methods.BatchOptions()
    n_workers = len(client.scheduler_info(n_workers=-1).get("workers", {}))
    start = time.perf_counter()
    futures = client.map(analyse_run, paths, model=model, method=method, options=options,
                         timeout_s=run_timeout_s, pure=False)
    order = {f.key: i for i, f in enumerate(futures)}
    gathered: list[list[LevelRow]] = [[] for _ in paths]
    failed = 0
    with tqdm(total=len(paths), unit="run", file=sys.stderr, disable=not progress,
              desc="reanalyze") as bar:
        for future, result in as_completed(futures, with_results=True, raise_errors=False):
            i = order[future.key]
            if future.status != "finished":  # worker died, result not picklable, ...
                result = [_failed_row(paths[i], -1, None, None, method,
                                      _lost(future.exception(), run_timeout_s))]
            gathered[i] = result
            failed += any(not row.ok for row in result)
            bar.set_postfix(failed=failed, refresh=False)
            bar.update()
    elapsed = time.perf_counter() - start
    rows = [row for rows in gathered for row in rows]
    return Reanalysis(rows, method, len(paths), n_workers, client.scheduler.address, elapsed,
                      {"model_name": model.name, "model_toml": model.dumps(),
                       "options": options.to_json()})


def _lost(exc: BaseException, run_timeout_s: float | None) -> BaseException | str:
    """The error of a task without result; a dead worker explained in words."""
    from distributed import KilledWorker   # loads on use, as dask
    if not isinstance(exc, KilledWorker):
        return exc
    why = f"took over the {run_timeout_s:g} s run time limit or crashed" if run_timeout_s \
        else "crashed"
    return (f"no result: the worker analysing this run {why} (Dask gave up after "
            f"{exc.allowed_failures + 1} attempt(s))")


def table_json(rows: Sequence[LevelRow]) -> list[TableRow]:
    """The rows as the table stores and the JSON lists them: every row with every column,
    head, parameters (first-seen order), tail (coherence and cost only when some row has
    them)."""
    flat = [{**{k: getattr(row, k) for k in HEAD + TAIL}, **row.estimates} for row in rows]
    middle: list[str] = []
    for row in flat:
        middle += [k for k in row if k not in HEAD + TAIL and k not in middle]
    tail = [k for k in TAIL if any(row.get(k) is not None for row in flat) or k in
            ("warnings", "error")]
    columns = list(HEAD) + middle + tail
    return [{c: row.get(c) for c in columns} for row in flat]


def write_results(result: Reanalysis, out: str | Path) -> None:
    """Write the table of ``result`` to HDF5 ``out`` (see `nlid_lab.store._tables`)."""
    attrs = {"kind": "nlid-lab reanalysis", "method": result.method,
             "n_runs": result.n_runs, "n_ok": result.n_ok, "n_failed": result.n_failed,
             "n_workers": result.n_workers, "elapsed_s": result.elapsed_s, **result.attrs}
    write_table(out, table_json(result.rows), attrs)
