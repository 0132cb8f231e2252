"""Parameter sweeps of a generated module on Dask (``dask.distributed``).

The generated module's *source text* is shipped to every worker once (``client.scatter(...,
broadcast=True)``) and imported there (:func:`~neweul_py.analysis.sweep_tasks.module_from_source`);
the cases travel as small parameter mappings, in chunks, so a sweep changes numbers, never code
(``docs/analysis.md``). Results come back as one tidy table, one row per case: ``case``, the swept
parameters, ``ok``, ``error`` and the task's values; a failing case is recorded with its
message and never aborts the sweep.

Without a client or scheduler address a :class:`~distributed.LocalCluster` is started (2 worker
processes by default, one thread each) and closed afterwards. It is authenticated: Dask's TLS
security with temporary credentials (:meth:`distributed.security.Security.temporary`, a
self-signed key and certificate made for this sweep and held in memory only) for the
scheduler, the workers and the client, so a process without them cannot submit work to the
workers; it listens on free ports of 127.0.0.1 (its HTTP server too, which serves the health
check only: no dashboard), so that two sweeps never collide. ``scheduler="tls://host:8786"``
connects to a running cluster instead (whose workers need neweul-py installed) with the TLS
settings of the Dask configuration: who may submit work to that cluster is the choice of
whoever started it.
"""

from __future__ import annotations

import importlib.util
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import atomic_savez, atomic_write
from ..errors import DataError, NeweulError
from ..files import load_npz, read_checked
from .admissible import check_parameters, describe_values
from .module import MAX_MODULE_BYTES, GeneratedModel, ModelLike, as_model
from .protocol import resolve_parameters
from .results import ResultDisplay, check_output_path, require_pandas
from .sweep_tasks import STATS, TASKS, run_cases

__all__ = ["MAX_WORKERS", "SUFFIXES", "SweepResult", "check_sweep_output", "connect",
           "sweep"]

#: Suffixes of sweep tables (:meth:`SweepResult.save`).
SUFFIXES: tuple[str, ...] = (".csv", ".parquet", ".npz")

_FIXED = ("case", "ok", "error")


@dataclass(frozen=True, repr=False)
class SweepResult(ResultDisplay):
    """The table of a sweep: one row per case.

    Attributes
    ----------
    data : dict of str → ndarray
        Columns: ``case`` (int), the swept parameters, ``ok`` (bool), ``error`` (str, ``""``
        when ok), then the task's values (NaN where a case failed).
    parameters : tuple of str
        The swept parameter names.
    task : str
        ``simulate``, ``equilibrium``, ``modes``, ``frf`` or the name of a callable.
    model_name : str
    workers : int
        Worker threads of the cluster.
    seconds : float
        Wall time of the sweep (from submitting to gathering).
    """

    data: dict[str, np.ndarray]
    parameters: tuple[str, ...]
    task: str
    model_name: str = ""
    workers: int = 0
    seconds: float = 0.0
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the cases that ran."""
        return self.data["ok"]

    @property
    def failures(self) -> list[tuple[int, str]]:
        """``(case, message)`` of every failed case."""
        return [(int(c), str(m)) for c, m, good in
                zip(self.data["case"], self.data["error"], self.ok, strict=True) if not good]

    def columns(self) -> dict[str, np.ndarray]:
        """The table's columns by name."""
        return dict(self.data)

    def summary(self) -> str:
        """One line: task, cases, failures, workers, time."""
        n = self.ok.size
        bad = n - int(self.ok.sum())
        return (f"SweepResult({self.task} of {self.model_name or 'model'} over "
                f"{', '.join(self.parameters) or 'no parameters'}: {n} cases, {bad} failed; "
                f"{self.workers} workers, {self.seconds:.3g} s)")

    def to_text(self, max_columns: int = 10) -> str:
        """An aligned text table (the first ``max_columns`` columns; errors last)."""
        names = [n for n in self.data if n != "error"][:max_columns]
        cells = [[str(int(v)) if n in ("case", "ok") else f"{float(v):.6g}"
                  for v in self.data[n]] for n in names]
        widths = [max([len(n), *map(len, c)]) for n, c in zip(names, cells, strict=True)]
        lines = ["  ".join(n.rjust(w) for n, w in zip(names, widths, strict=True))]
        for i in range(self.ok.size):
            row = "  ".join(c[i].rjust(w) for c, w in zip(cells, widths, strict=True))
            lines.append(row + (f"  {self.data['error'][i]}" if not self.ok[i] else ""))
        return "\n".join(lines)

    def _csv_text(self) -> str:
        names = list(self.data)
        lines = [",".join(names)]
        cols = [self.data[n] for n in names]
        for i in range(self.ok.size):
            cells = []
            for n, c in zip(names, cols, strict=True):
                v = c[i]
                if n == "error":  # no separators or quotes: every reader splits the same way
                    cells.append(str(v).replace(",", ";").replace('"', "'"))
                elif n in ("case", "ok"):
                    cells.append(str(int(v)))
                else:
                    cells.append(f"{float(v):.17g}")
            lines.append(",".join(cells))
        return "\n".join(lines) + "\n"

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write the table as CSV (header of names; ``ok`` as 1/0; commas in error messages
        become ``;``), atomically — readable by ``pandas.read_csv`` and ``numpy.genfromtxt``."""
        return atomic_write(path, self._csv_text())

    def to_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write every column as an array of an uncompressed ``.npz`` (no pickles; ``error``
        as a string array), plus ``parameters`` and ``task``."""
        arrays = {f"column_{n}": (np.asarray(v, dtype=str) if n == "error" else np.asarray(v))
                  for n, v in self.data.items()}
        return atomic_savez(path, columns=np.array(list(self.data), dtype=str),
                            parameters=np.array(self.parameters, dtype=str),
                            task=np.array(self.task), model_name=np.array(self.model_name),
                            **arrays)

    def to_parquet(self, path: str | os.PathLike[str]) -> Path:
        """Write the table as Parquet (needs pandas and pyarrow), atomically."""
        check_sweep_output(path)
        frame = self.to_dataframe()
        import io

        buf = io.BytesIO()
        frame.to_parquet(buf, index=False)
        return atomic_write(path, buf.getvalue())

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write ``.csv``, ``.parquet`` or ``.npz`` by the suffix."""
        path = check_sweep_output(path)
        suffix = path.suffix.lower()
        if suffix == ".npz":
            return self.to_npz(path)
        return self.to_parquet(path) if suffix == ".parquet" else self.to_csv(path)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SweepResult:
        """Read a ``.npz`` written by :meth:`to_npz`."""
        f = load_npz(path, "sweep table")
        try:
            names = [str(n) for n in f["columns"]]
            return cls(data={n: f[f"column_{n}"] for n in names},
                       parameters=tuple(str(p) for p in f["parameters"]),
                       task=str(f["task"]), model_name=str(f["model_name"]))
        except (ValueError, KeyError) as exc:
            raise DataError(f"cannot read a sweep table: {exc}", file=str(path)) from None


def check_sweep_output(path: str | os.PathLike[str]) -> Path:
    """``path`` if it is a table suffix this installation writes (``.parquet`` needs pyarrow),
    else one clear error — checked before a sweep starts."""
    path = check_output_path(path, SUFFIXES, "sweep tables")
    if path.suffix.lower() == ".parquet":
        require_pandas()
        if importlib.util.find_spec("pyarrow") is None:
            raise NeweulError(
                f"{path}: writing .parquet needs pyarrow: pip install pyarrow (or "
                "'neweul-py[parquet]'); .csv and .npz need nothing more"
            )
    return path


#: Largest number of worker processes of a local cluster (``--workers``; docs/limits.md).
MAX_WORKERS = 256


def connect(
    scheduler: str | None = None, *, workers: int = 2, processes: bool = True,
    timeout: float = 5.0,
) -> tuple[Any, Any]:
    """A Dask ``(client, cluster)``: connected to ``scheduler``, or a new authenticated
    ``LocalCluster`` (``cluster`` is None for a remote scheduler).

    The local cluster and its client share temporary TLS credentials
    (:meth:`distributed.security.Security.temporary`): only they can talk to its scheduler
    and workers. It listens on free ports of 127.0.0.1, without a dashboard.

    Raises
    ------
    NeweulError
        When dask.distributed (or, for a local cluster, cryptography) is not installed,
        ``workers`` is not within 1 … :data:`MAX_WORKERS`, or the scheduler cannot be reached
        within ``timeout`` seconds.
    """
    try:
        import logging

        import dask
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise NeweulError(
            "sweeps run on Dask: pip install 'dask[distributed]' cryptography (or "
            "'neweul-py[sweep]')"
        ) from None
    if scheduler:
        try:
            return Client(scheduler, timeout=f"{timeout}s"), None
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            why = " ".join(str(exc).split())[:160] or type(exc).__name__
            raise NeweulError(
                f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s ({why}); "
                "start one (`dask scheduler`) or leave out the address for a local cluster"
            ) from None
    if not 1 <= workers <= MAX_WORKERS:
        raise NeweulError(f"workers must be between 1 and {MAX_WORKERS} (docs/limits.md), "
                          f"got {workers}")
    from distributed.security import Security

    try:
        security = Security.temporary()
    except ImportError:
        raise NeweulError(
            "the local sweep cluster is authenticated with temporary TLS credentials, which "
            "need cryptography: pip install cryptography (or 'neweul-py[sweep]')"
        ) from None
    # the scheduler's HTTP server (Dask starts one even without a dashboard, on port 8787
    # unless told otherwise) on a free port of 127.0.0.1, serving the health check only
    with dask.config.set({"distributed.scheduler.http.routes": ["distributed.http.health"]}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=processes,
                               host="127.0.0.1", scheduler_port=0,
                               dashboard_address="127.0.0.1:0",
                               scheduler_kwargs={"dashboard": False}, security=security,
                               silence_logs=logging.ERROR)
    try:
        return Client(cluster, security=security), cluster
    except BaseException:
        cluster.close()
        raise


def _source(module: ModelLike) -> tuple[str, GeneratedModel]:
    mod = as_model(module)
    if not mod.path:
        raise NeweulError("sweep: the module has no file to ship to the workers")
    raw = read_checked(mod.path, "generated module", MAX_MODULE_BYTES, NeweulError)
    try:
        return raw.decode("utf-8"), mod
    except UnicodeDecodeError:
        raise NeweulError(f"{mod.path}: the generated module is not UTF-8 text") from None


def _check(mod: GeneratedModel, cases: Sequence[Mapping[str, float]], task: Any,
           options: Mapping[str, Any]) -> list[str]:
    if not cases:
        raise NeweulError("sweep: no cases (give --param NAME=VALUES or --cases FILE)")
    names = list(dict.fromkeys(k for c in cases for k in c))
    unknown = [n for n in names if n not in mod.PARAMETERS]
    if unknown:
        raise NeweulError(f"sweep: unknown parameter(s) {', '.join(unknown)}; parameters are: "
                          f"{', '.join(mod.PARAMETERS) or '(none)'}")
    if not callable(task) and task not in TASKS:
        raise NeweulError(f"unknown sweep task {task!r}; tasks are: {', '.join(TASKS)}")
    if task == "simulate" and "t_end" not in options:
        raise NeweulError("sweep --task simulate needs t_end (--t-end)")
    if task == "frf" and "f" not in options:
        raise NeweulError("sweep --task frf needs frequencies f (--f)")
    bad = [s for s in options.get("stats", ()) if s not in STATS]
    if bad:
        raise NeweulError(f"unknown statistics {', '.join(bad)}; valid: {', '.join(STATS)}")
    # the one parameter check of every command (simulate -p …): no case runs a model its
    # description would refuse
    for k, case in enumerate(cases):
        p = resolve_parameters(mod, case)
        check_parameters(mod, p, f"sweep case {k} ({describe_values(list(case), case.values())})")
    return names


def _table(cases: Sequence[Mapping[str, float]], params: Sequence[str],
           rows: Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    values = list(dict.fromkeys(k for r in rows for k in r if k not in ("ok", "error")))
    data: dict[str, np.ndarray] = {"case": np.arange(len(cases))}
    for p in params:
        data[p] = np.array([c.get(p, np.nan) for c in cases], dtype=float)
    data["ok"] = np.array([bool(r.get("ok")) for r in rows], dtype=bool)
    data["error"] = np.array([str(r.get("error", "")) for r in rows], dtype=str)
    for v in values:
        data[v] = np.array([r.get(v, np.nan) for r in rows], dtype=float)
    return data


def sweep(
    module: ModelLike,
    cases: Sequence[Mapping[str, float]],
    task: str | Callable[..., Mapping[str, float]] = "simulate",
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    chunk_size: int | None = None,
    timeout: float = 5.0,
    progress: Callable[[float, float], None] | None = None,
    **options: Any,
) -> SweepResult:
    """Run ``task`` for every case on Dask and gather one table.

    Parameters
    ----------
    module
        A generated module (or its path); its source is shipped to each worker once.
    cases
        Parameter overrides, one mapping per case (:func:`~neweul_py.analysis.sweep_cases.grid`,
        :func:`~neweul_py.analysis.sweep_cases.read_cases`).
    task
        ``"simulate"`` (options ``t_end``, ``method``, ``rtol``, ``atol``, ``n_out``, ``stats``),
        ``"equilibrium"`` (``y0``, ``u``, ``fixed``), ``"modes"`` (``n_modes``, ``undamped``,
        ``at``), ``"frf"`` (``f``, ``inputs``, ``outputs``, ``at``) — see
        :mod:`~neweul_py.analysis.sweep_tasks` — or a module-level function
        ``task(module, p) -> mapping of numbers``.
    client
        A ``dask.distributed.Client`` to use (left open); else one is made from ``scheduler``
        or a new local cluster of ``workers`` processes (``processes=False``: threads), closed
        at the end.
    chunk_size
        Cases per Dask task (default: about four chunks per worker thread, so that the
        per-task overhead is spread over several cases).
    timeout
        Seconds to wait for a remote scheduler.
    progress
        Called as ``progress(done, total)`` with the number of finished cases.
    **options
        Options of the built-in task.

    Returns
    -------
    SweepResult
        One row per case, in the order of ``cases``; failures recorded in ``ok``/``error``.

    Examples
    --------
    >>> res = sweep("generated/pendulum.py", grid({"l": [0.5, 1, 2]}), "simulate",
    ...             t_end=2.0)                                       # doctest: +SKIP
    >>> res.save("pendulum_sweep.csv")                                 # doctest: +SKIP
    """
    source, mod = _source(module)
    cases = [dict(c) for c in cases]
    params = _check(mod, cases, task, options)
    if chunk_size is not None and (isinstance(chunk_size, bool)
                                   or not isinstance(chunk_size, int) or chunk_size < 1):
        raise NeweulError(f"chunk_size must be a whole number ≥ 1, got {chunk_size!r}")
    own = client is None
    cluster = None
    if own:
        client, cluster = connect(scheduler, workers=workers, processes=processes,
                                  timeout=timeout)
    try:
        from dask.distributed import as_completed

        t0 = time.perf_counter()
        nthreads = max(1, sum(client.nthreads().values()))
        size = chunk_size or max(1, math.ceil(len(cases) / (4 * nthreads)))
        chunks = [cases[i:i + size] for i in range(0, len(cases), size)]
        # the module, once per worker; a fresh key per sweep (hash=False): with the content
        # hash as key, a sweep of the same module right after another could be handed the
        # previous sweep's scattered data while the workers were releasing it
        shipped = client.scatter(source, broadcast=True, hash=False)
        futures = [client.submit(run_cases, shipped, task, options, c, pure=False)
                   for c in chunks]
        index = {f.key: k for k, f in enumerate(futures)}
        results: list[list[dict[str, Any]] | None] = [None] * len(chunks)
        done = 0
        for fut in as_completed(futures):
            k = index[fut.key]
            try:
                results[k] = fut.result()
            except Exception as exc:  # the worker died or the task could not run
                msg = f"worker failed: {type(exc).__name__}: {' '.join(str(exc).split())}"
                results[k] = [{"ok": False, "error": msg} for _ in chunks[k]]
            done += len(chunks[k])
            if progress is not None:
                progress(done, len(cases))
        seconds = time.perf_counter() - t0
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    rows = [r for chunk in results for r in (chunk or [])]
    name = task if isinstance(task, str) else getattr(task, "__name__", "task")
    return SweepResult(data=_table(cases, params, rows), parameters=tuple(params), task=name,
                       model_name=str(mod.MODEL_NAME), workers=nthreads, seconds=seconds,
                       options={k: v for k, v in options.items() if np.isscalar(v)})
