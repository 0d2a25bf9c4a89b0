"""The Monte Carlo campaign engine: runs a sweep's tasks on Dask and writes each result as it lands.

One code path for a laptop and a cluster: by default a ``distributed.LocalCluster`` with one
single-threaded worker process per core is started (no server to run); ``scheduler=ADDRESS``
connects to an existing Dask scheduler instead, and ``client=`` uses a ``distributed.Client``
the caller already holds. The client process keeps the campaign directory; workers only compute
(:func:`inmotion.evaluate.campaign.execute_task`), so no shared file system is needed.

Guarantees
----------
- A run's numbers depend on the campaign seed and its index only
  (:func:`inmotion.evaluate.campaign.run_seed_sequence`): same results on 1, 2 or 200 workers;
  :func:`rerun` reproduces one run alone.
- Each finished run is recorded at once (:mod:`inmotion.evaluate.store`: a flushed journal line,
  compacted into the Parquet dataset); an interrupted or killed campaign loses only the runs in
  flight, and ``resume=True`` runs only the missing ones.
- A run that raises is a result (``status='error'``, its error text, traceback and seed); the
  campaign goes on. So is a run that kills its worker (``KilledWorker``, see :data:`LOSS_RETRIES`).
- Every run is recorded exactly once, and the campaign cannot wait forever on a task Dask lost
  (a worker that died, a result lost with its worker): such tasks are submitted again, and a
  watchdog takes the tasks in flight as lost when nothing finishes and no worker runs anything
  for ``stall_s`` seconds (:func:`_drive`, :class:`_Watchdog`).
- At most ``max_in_flight`` Dask tasks are submitted at a time, so the client's memory does not
  grow with the number of runs. Short runs travel several to a Dask task (about 0.25 s of work
  each, :class:`_Chunker`), so the engine's cost per run stays small even for empty runs.
"""
from __future__ import annotations

import collections
import contextlib
import json
import logging
import math
import os
import platform
import sys
import time
import uuid
from pathlib import Path
from typing import Optional

from ..errors import BadInput
from .campaign import Task, _resolve, error_record, execute_task, execute_tasks
from .store import ResultStore
from .sweep import MAX_RUNS, Sweep

__all__ = ["run_campaign", "iter_tasks", "rerun", "read_results", "versions", "open_client"]

MANIFEST = "campaign.json"
TABLE = "table.parquet"
#: seconds of work a Dask task should carry when runs are short (see _Chunker)
TARGET_TASK_S = 0.25
MAX_CHUNK = 256
#: a task whose worker died (``KilledWorker``) or that Dask lost (see :class:`_Watchdog`) is
#: submitted again: a chunk of several runs split into one task per run, a run alone in its
#: task as it is until it has died alone with its workers more than this many times, then it
#: is recorded as that error. A ``KilledWorker`` counts the scheduler's own attempts
#: (``allowed_failures + 1``). Dask does not say which task of a dying worker was running (a
#: task queued on it dies too), so a death shared with another of the campaign's tasks is not
#: counted against either (up to :data:`MAX_LOSSES` losses in all). A crashing run takes down 2
#: workers on the engine's own cluster (1 more if it shared a chunk), 4 on a scheduler with
#: Dask's default allowed-failures 3 (8 if it shared a chunk).
LOSS_RETRIES = 1
#: losses of a run alone in its task, counted or not, after which it is recorded in any case
MAX_LOSSES = 6
#: seconds without a finished task while no worker of the cluster runs anything, after which
#: the tasks in flight are taken as lost by Dask (:class:`_Watchdog`)
STALL_S = 60.0
#: with no worker at all, the campaign gives up after this many times ``stall_s``
NO_WORKER_STALLS = 5
#: Dask settings while a cluster :func:`open_client` started runs: the engine, not the
#: scheduler, decides what to re-run after a worker died (allowed-failures 0: the task that was
#: running when a worker died is reported at once as ``KilledWorker``); a worker holds only the
#: task it runs (worker-saturation 1.0: no queued task dies with a crashing neighbour); and the
#: cluster never drops a worker slot whose process is being restarted. Dask's
#: lost-worker-timeout (15 s) closes a worker's nanny for good when, 15 s after one of its
#: worker's deaths, no worker of that name is registered. When runs crash one worker after
#: another, that check eventually falls between a death and the restart. The cluster then had
#: no worker left and the campaign waited forever (reproduced: 40 runs x 4 points, 2 workers,
#: load 10).
CLUSTER_CONFIG = {"distributed.scheduler.allowed-failures": 0,
                  "distributed.scheduler.worker-saturation": 1.0,
                  "distributed.deploy.lost-worker-timeout": 10 * 365 * 86400.0}
#: environment of local workers: one BLAS thread each, the cores are the workers
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1"}


def check_size(sweep: Sweep) -> None:
    """Refuse a campaign larger than :data:`MAX_RUNS` runs (its store and table would not fit
    a machine; split it into several campaigns)."""
    n = len(sweep.points) * sweep.runs
    if n > MAX_RUNS:
        raise BadInput(f"the campaign asks for {len(sweep.points)} point(s) x {sweep.runs} runs "
                       f"= {n:.3g} runs; at most {MAX_RUNS:.3g} (split it into several "
                       "campaigns)", file=sweep.source)


def versions() -> dict:
    """Versions of the package, Python and the libraries that shape the numbers."""
    import importlib.metadata as md
    out = {"python": sys.version.split()[0], "platform": platform.platform()}
    for name in ("inmotion", "numpy", "scipy", "numba", "pandas", "pyarrow", "dask",
                 "distributed", "matplotlib", "pydantic"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:
            out[name] = "not installed"
    return out


def iter_tasks(sweep: Sweep, skip=frozenset()):
    """The tasks of ``sweep``, run-major (run 0 of every point, then run 1, ...), so a partial
    campaign is balanced across points; within a run, points of equal affinity (see
    :class:`Task`) are adjacent. Keys in ``skip`` = ``{(point_id, run_index)}`` are left out."""
    key = getattr(_resolve(sweep.run), "affinity", None)
    affinity = {p.point_id: (str(key(p.spec)) if key else "") for p in sweep.points}
    points = sorted(sweep.points, key=lambda p: affinity[p.point_id])   # stable: grid order kept
    for k in range(sweep.runs):
        for p in points:
            if (p.point_id, k) not in skip:
                yield Task(sweep.seed, k, p.point_id, p.params, p.spec, sweep.run, p.label,
                           affinity[p.point_id])


def rerun(out_dir, point_id: int, run_index: int) -> dict:
    """Re-run one run of the campaign in ``out_dir`` alone, in this process; returns its record."""
    manifest = _read_manifest(Path(out_dir))
    points = {p["point_id"]: p for p in manifest["points"]}
    if point_id not in points:
        raise BadInput(f"no point {point_id} in this campaign", file=Path(out_dir) / MANIFEST)
    p = points[point_id]
    task = Task(manifest["seed"], run_index, point_id, p["params"], p["spec"], manifest["run"],
                p["label"])
    return execute_task(task)[0]


def read_results(out_dir):
    """The campaign's results table (pandas), from the per-run files."""
    return ResultStore(out_dir).table()


def _read_manifest(out: Path) -> dict:
    path = out / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except FileNotFoundError:
        raise BadInput("not a campaign directory (no campaign.json)", file=out) from None
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise BadInput(f"corrupt campaign manifest: {exc}", file=path) from None
    _check_manifest(manifest, path)
    return manifest


def _check_manifest(m, path) -> None:
    """The shape :func:`Sweep.manifest` writes; BadInput naming what is wrong."""
    def bad(what):
        raise BadInput(f"corrupt campaign manifest: {what}", file=path)
    if not isinstance(m, dict):
        bad(f"a JSON object expected, got {type(m).__name__}")
    for key, types in (("runs", int), ("seed", int), ("run", str), ("points", list)):
        if not isinstance(m.get(key), types) or isinstance(m.get(key), bool):
            bad(f"{key!r} missing or not {types.__name__}")
    for i, p in enumerate(m["points"]):
        if not (isinstance(p, dict) and isinstance(p.get("point_id"), int)
                and isinstance(p.get("params"), dict) and isinstance(p.get("spec"), dict)):
            bad(f"points[{i}] is not {{point_id, label, params, spec}}")


def _identity(manifest: dict) -> dict:
    """What must not change for a resumed campaign to be the same campaign (runs may grow)."""
    return {"seed": manifest["seed"], "run": manifest["run"],
            "points": [(p["point_id"], p["params"], p["spec"]) for p in manifest["points"]]}


def _prepare_dir(out: Path, sweep: Sweep, store: ResultStore, resume: bool) -> None:
    manifest = json.loads(json.dumps(sweep.manifest(), default=str))
    if (out / MANIFEST).exists():
        old = _read_manifest(out)
        if not resume and store.done():
            raise BadInput("the directory already holds campaign results; pass --resume to "
                           "complete them, or choose a new directory", file=out)
        if resume and _identity(old) != _identity(manifest):
            raise BadInput("the directory holds a different campaign (seed, run function or "
                           "points differ); resume it with its own sweep, or use a new "
                           "directory", file=out)
    out.mkdir(parents=True, exist_ok=True)
    manifest["versions"] = versions()
    manifest["written_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    tmp = out / f".{MANIFEST}.tmp"
    tmp.write_text(json.dumps(manifest, indent=1, default=str))
    os.replace(tmp, out / MANIFEST)


def _validate(sweep: Sweep) -> None:
    """Call the run function's ``validate_spec(spec)`` attribute on every point (if it has one),
    so a typo in a sweep fails before the campaign starts rather than in every run."""
    try:
        run = _resolve(sweep.run)
    except (ImportError, AttributeError) as exc:
        raise BadInput(f"run function {sweep.run!r} cannot be imported ({exc})",
                       file=sweep.source) from None
    check = getattr(run, "validate_spec", None)
    if check is None:
        return
    for p in sweep.points:
        try:
            check(p.spec)
        except BadInput as exc:
            raise BadInput(f"point {p.point_id} ({p.label}): {exc}", file=sweep.source) from None


@contextlib.contextmanager
def open_client(workers: Optional[int] = None, scheduler: Optional[str] = None, client=None):
    """A ``distributed.Client``: the one given, one connected to ``scheduler``, or one on a new
    ``LocalCluster`` of ``workers`` single-threaded processes (default: all cores) whose
    Dask settings are :data:`CLUSTER_CONFIG` (a cluster given or addressed keeps its own
    settings; the engine's re-submission of lost tasks works on any)."""
    if client is not None:
        yield client
        return
    from distributed import Client, LocalCluster
    if scheduler:
        with _connect(Client, scheduler) as c:
            yield c
        return
    n = workers or os.cpu_count() or 1
    if n < 1:
        raise BadInput(f"--workers must be at least 1, got {workers}")
    import dask
    with dask.config.set(CLUSTER_CONFIG):       # read while the cluster runs, not only at start
        with _workers_ignore_sigint():
            # the workers' own log lines silenced below CRITICAL: a run's failure reaches the
            # client as its exception (the campaign reports it), and at Ctrl-C a worker whose
            # heartbeat meets the closed scheduler logged an ERROR with a traceback (issue 15
            # session 15, seen once in CI: the one clear message was not the only one)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address="127.0.0.1:0",
                                   silence_logs=logging.CRITICAL, env=WORKER_ENV)
        try:
            with cluster, Client(cluster) as c:
                yield c
        except KeyboardInterrupt:
            _quiet_shutdown()
            raise


@contextlib.contextmanager
def _workers_ignore_sigint():
    """Ctrl-C goes to the whole terminal's process group; the worker processes started here
    inherit SIGINT ignored (kept across exec), so only this process sees it and stops the
    campaign cleanly, without a traceback from every worker."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _quiet_shutdown() -> None:
    """After Ctrl-C: no scheduler / comm error logs while the cluster is torn down."""
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


#: seconds to wait for a scheduler given by address
CONNECT_TIMEOUT_S = 5.0


def _check_address(address: str) -> None:
    import re
    if not re.match(r"^[a-z]+://[^\s]+:\d+$|^[^\s:/]+:\d+$", str(address)):
        raise BadInput(f"--scheduler {address!r}: expected an address like tcp://host:8786")


def _connect(Client, address: str):
    """A client of the scheduler at ``address``, or BadInput within CONNECT_TIMEOUT_S."""
    _check_address(address)
    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise BadInput(f"--scheduler {address}: no Dask scheduler answers there within "
                       f"{CONNECT_TIMEOUT_S:g} s ({reason})") from None


def _progress(total, initial, quiet, desc):
    from tqdm.auto import tqdm
    return tqdm(total=total, initial=initial, unit="run", desc=desc, disable=quiet,
                dynamic_ncols=True, file=sys.stderr, smoothing=0.1)


def _failed_keys(store: ResultStore) -> set:
    df = store.table()
    if df.empty or "status" not in df:
        return set()
    bad = df[df["status"] != "ok"]
    return set(zip(bad["point_id"].astype(int), bad["run_index"].astype(int)))


def run_campaign(sweep: Sweep, out_dir, *, workers: Optional[int] = None,
                 scheduler: Optional[str] = None, client=None, resume: bool = False,
                 retry_failed: bool = False, quiet: bool = False,
                 max_in_flight: Optional[int] = None, max_chunk: int = MAX_CHUNK,
                 validate: bool = True, stall_s: float = STALL_S):
    """Run every (point, run) of ``sweep`` not yet in ``out_dir``; return the full results table.

    Parameters
    ----------
    sweep : Sweep
        From :func:`inmotion.evaluate.sweep.load_sweep`.
    out_dir : path
        The campaign directory: ``campaign.json``, ``results/``, ``arrays/``, ``table.parquet``.
    workers : int, optional
        Local worker processes (default: all cores); ignored with ``scheduler`` or ``client``.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``).
    client : distributed.Client, optional
        A client to use as is (not closed here).
    resume : bool
        Complete a campaign already in ``out_dir``: only missing runs are run. Without it a
        directory holding results is refused (:class:`BadInput`).
    retry_failed : bool
        With ``resume``: also re-run the runs recorded as errors.
    quiet : bool
        No progress bar.
    max_in_flight : int, optional
        Dask tasks submitted at a time (default ``max(4, 3 * workers)``).
    max_chunk : int
        Most runs per Dask task; 1 makes every run its own task (see :class:`_Chunker`).
    stall_s : float
        Seconds without a finished task while no worker runs anything, after which the tasks
        in flight are taken as lost and submitted again (:class:`_Watchdog`); also the longest
        wait for one chunk's result once Dask reports it done.

    Returns
    -------
    pandas.DataFrame
        One row per run, sorted by ``(point_id, run_index)``; also written to ``table.parquet``.
    """
    out = Path(out_dir)
    check_size(sweep)
    if isinstance(stall_s, bool) or not (isinstance(stall_s, (int, float))
                                         and math.isfinite(stall_s) and stall_s > 0):
        raise BadInput(f"stall_s must be a positive number of seconds, got {stall_s!r}")
    if scheduler and client is None:
        _check_address(scheduler)
    store = ResultStore(out)
    if validate:
        _validate(sweep)
    _prepare_dir(out, sweep, store, resume)
    store.remove_partial()
    if resume and retry_failed:
        store.remove(_failed_keys(store))
    done = store.done()
    # counted, never listed: a campaign of 10^7 runs plans in constant memory
    pids = {p.point_id for p in sweep.points}
    total = len(pids) * sweep.runs
    n_done = sum(1 for pid, k in done if pid in pids and 0 <= k < sweep.runs)
    n_todo = total - n_done
    if n_todo > 0:
        with open_client(workers, scheduler, client) as c, store:
            _drive(c, iter_tasks(sweep, skip=done), store, total, n_done,
                   n_todo, quiet, max_in_flight, max_chunk, sweep.name, stall_s)
    df = store.table()
    from ..io.safe_write import atomic_write
    atomic_write(out / TABLE, lambda tmp: df.to_parquet(tmp, index=False))
    return df


class _Chunker:
    """How many runs to send as one Dask task: about ``TARGET_TASK_S`` of work, judged from the
    mean wall time of the runs finished so far (1 until one has finished), never more than an
    even share of what is left per worker (so the last tasks stay balanced)."""

    def __init__(self, n_workers: int, max_chunk: int):
        self.n_workers, self.max_chunk = n_workers, max(1, int(max_chunk))
        self.seconds, self.runs = 0.0, 0

    def observe(self, records) -> None:
        for r in records:
            if math.isfinite(r.get("elapsed_s", float("nan"))):
                self.seconds += r["elapsed_s"]
                self.runs += 1

    def size(self, remaining: int) -> int:
        if self.runs == 0:
            return 1
        mean = max(self.seconds / self.runs, 1e-6)
        share = max(1, remaining // (2 * self.n_workers))
        return int(max(1, min(TARGET_TASK_S / mean, self.max_chunk, share)))


def _drive(client, tasks, store, total, initial, n_todo, quiet, max_in_flight, max_chunk, name,
           stall_s=STALL_S):
    """Submit chunks of tasks with a bounded window; record each run as its chunk completes.

    Every run is recorded exactly once, as a result or an error, and the loop cannot wait
    forever on a task Dask has lost:

    - results are fetched here (``Future.result(timeout=...)``), not by
      ``as_completed(with_results=True)``: that helper's fetch dies silently, and its future is
      never handed over (the campaign hung), when the task's result is lost with its worker and
      the re-computation then fails (``distributed.Client._gather`` raises inside
      ``as_completed._track_future``);
    - a chunk lost as a whole (its worker died: a run that crashes the process, a machine going
      away; Dask reports ``KilledWorker``) is split and its runs are submitted again one per
      task; a run alone in a lost task is submitted again until it has died alone with its
      worker more than :data:`LOSS_RETRIES` times, then recorded as that error (so only the run
      that takes its worker down is marked);
    - a future that went back to pending (its result lost with its worker: Dask computes it
      again) is waited for again; one cancelled, whose result cannot be fetched, or that the
      :class:`_Watchdog` finds stalled, counts as lost the same way as a ``KilledWorker``;
      the superseded future is released and whatever it still delivers is ignored."""
    from distributed import as_completed
    n_workers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    window = max_in_flight or max(4, 3 * n_workers)
    chunker = _Chunker(n_workers, max_chunk)
    token = uuid.uuid4().hex[:8]
    in_flight = {}                 # key -> (future, chunk, (losses counted, all losses))
    died_on = collections.Counter()   # address of a dead worker -> the tasks that died with it
    serial = [0]
    remaining = [n_todo]
    tasks = _Peekable(tasks)
    pending = as_completed()
    watchdog = _Watchdog(client, stall_s)

    def submit(chunk, losses=(0, 0)):
        first = chunk[0]
        serial[0] += 1
        key = (f"inmotion-{token}-p{first.point_id}-r{first.run_index}-n{len(chunk)}"
               f"-s{serial[0]}")
        fut = client.submit(execute_tasks, chunk, pure=False, key=key)
        in_flight[fut.key] = (fut, chunk, losses)
        pending.add(fut)

    def submit_next():
        chunk = _take(tasks, chunker.size(remaining[0]))
        if not chunk:
            return
        while len(chunk) < MAX_CHUNK and _same_drive(chunk[-1], tasks.peek()):
            chunk.append(next(tasks))
        remaining[0] -= len(chunk)
        submit(chunk)

    def record(outcomes):
        for rec, arrays in outcomes:
            store.write(rec, arrays)
            counts["errors"] += rec["status"] != "ok"
        chunker.observe(r for r, _ in outcomes)
        bar.update(len(outcomes))
        if counts["errors"]:
            bar.set_postfix(errors=counts["errors"], refresh=False)

    def shared_death(fut, exc) -> bool:
        """Whether another task of the campaign died with the worker ``exc`` names (then
        either may only have been queued there)."""
        address = _dead_worker(exc)
        if address is None:
            return False
        died_on[address] += 1
        return died_on[address] > 1 or any(
            other is not fut and other.status == "error"
            and _dead_worker(_exception_now(other)) == address
            for other, _, _ in in_flight.values())

    def lost(fut, chunk, losses, exc):
        """Submit a lost chunk again (split), or record it once it has been lost too often."""
        deaths = _worker_deaths(exc)
        counted = losses[0] + (0 if shared_death(fut, exc) else deaths)
        losses = (counted, losses[1] + deaths)
        if len(chunk) > 1:
            for task in chunk:                       # find the run that killed the worker
                submit([task])
        elif counted <= LOSS_RETRIES and losses[1] <= MAX_LOSSES:
            submit(chunk, losses)
        else:
            record([(error_record(chunk[0], exc), None)])
            submit_next()

    def settle(fut, given_up=False):
        """Record (or re-submit) the chunk of a future that is done, or given up on by the
        watchdog."""
        entry = in_flight.pop(fut.key, None)
        if entry is None:                             # superseded: its chunk went again
            fut.release()
            return
        _, chunk, losses = entry
        result = _collect(fut, stall_s)
        if result is _AGAIN and not given_up:
            in_flight[fut.key] = entry               # not done after all: wait for it again
            pending.add(fut)
            return
        fut.release()
        result = _LOST if result is _AGAIN else result
        exc = _chunk_exception(result) if result is not _LOST else None
        if result is _LOST or _is_lost_worker(exc):
            lost(fut, chunk, losses, exc if exc is not None else TaskLost(len(chunk), stall_s))
        elif exc is not None and len(chunk) > 1:
            for task in chunk:                       # the chunk as a whole failed
                submit([task], losses)
        else:
            record(_outcomes(result, chunk))
            submit_next()

    counts = {"errors": 0}
    for _ in range(window):
        submit_next()
    with _progress(total, initial, quiet, name) as bar:
        while in_flight:
            done = _next_done(pending, _Watchdog.POLL_S)
            if done:
                watchdog.progress()
                for fut in done:
                    settle(fut)
            elif watchdog.stalled(in_flight):
                for fut, _, _ in list(in_flight.values()):
                    settle(fut, given_up=True)


class TaskLost(RuntimeError):
    """A run's Dask task was lost (no result, and no worker ran anything for ``stall_s``)
    more than :data:`LOSS_RETRIES` times."""

    def __init__(self, n_runs: int, stall_s: float):
        super().__init__(f"Dask lost the task of this run ({n_runs} run(s)): no result and no "
                         f"worker running anything for {stall_s:g} s, or its result could not "
                         "be fetched")


#: markers of a future whose result is gone: cancelled, or not fetched (``_LOST``); lost with
#: its worker and being computed again (``_AGAIN``)
_LOST, _AGAIN = object(), object()


def _collect(fut, timeout_s: float):
    """The chunk's result list, the exception that ended it, :data:`_AGAIN` (its result was
    lost with its worker and Dask is computing it again: wait for the future once more), or
    :data:`_LOST` (cancelled, or finished with a result that cannot be fetched)."""
    try:
        if fut.status == "finished":
            return fut.result(timeout=timeout_s)
        if fut.status == "error":
            return fut.exception(timeout=timeout_s)
    except Exception as exc:   # noqa: BLE001 - any failure to fetch is a lost or failed chunk
        if fut.status == "error":
            with contextlib.suppress(Exception):
                return fut.exception(timeout=timeout_s)
            return exc
    if fut.status in ("pending", "lost"):
        return _AGAIN
    return _LOST


def _worker_deaths(exc) -> int:
    """How many lost executions a lost task's exception stands for: a ``KilledWorker`` the
    scheduler's ``allowed_failures + 1`` (it re-ran the task that many times), else 1."""
    n = getattr(exc, "allowed_failures", None) if _is_lost_worker(exc) else None
    return int(n) + 1 if isinstance(n, int) and n >= 0 else 1


def _dead_worker(exc):
    """The address of the worker a ``KilledWorker`` died with (None if unknown)."""
    if not _is_lost_worker(exc):
        return None
    return getattr(getattr(exc, "last_worker", None), "address", None)


def _exception_now(fut):
    """The exception of an erred future, without waiting (None if not at hand)."""
    try:
        return fut.exception(timeout=0.5)
    except Exception:   # noqa: BLE001 - only a hint
        return None


def _is_lost_worker(exc) -> bool:
    """Whether ``exc`` says the task's worker went away (not that a run raised)."""
    if exc is None:
        return False
    from distributed.scheduler import KilledWorker
    return isinstance(exc, KilledWorker) or type(exc).__name__ == "KilledWorker"


def _next_done(pending, timeout_s: float) -> list:
    """The futures of ``pending`` done so far, waiting at most ``timeout_s`` for one."""
    deadline = time.monotonic() + timeout_s
    ready = getattr(pending, "thread_condition", None)   # notified as a future completes
    while not pending.has_ready():
        left = deadline - time.monotonic()
        if left <= 0:
            return []
        if ready is None:
            time.sleep(min(left, 0.02))
        else:
            with ready:
                ready.wait(min(left, 0.1))
    return pending.next_batch(block=False)


class _Watchdog:
    """Progress watch of :func:`_drive`: the tasks in flight are stalled when no task has
    finished for ``stall_s`` while no worker of the cluster runs anything (its workers idle,
    or none there): Dask has lost them, or a worker that died took them along unnoticed. It
    asks the scheduler at most every ``stall_s / 4`` (``Client.call_stack``, within
    ``stall_s / 2``), and only when no result comes in. With no worker at all for
    ``NO_WORKER_STALLS * stall_s`` the campaign stops (``RuntimeError``; resume it later)."""

    POLL_S = 0.5

    def __init__(self, client, stall_s: float):
        self.client, self.stall_s = client, float(stall_s)
        self.quiet_since = self.last_check = self.workers_seen = time.monotonic()

    def progress(self) -> None:
        self.quiet_since = time.monotonic()

    def stalled(self, in_flight) -> bool:
        now = time.monotonic()
        if now - self.last_check < self.stall_s / 4:
            return False
        self.last_check = now
        if self.client.status not in ("running", "connecting"):
            raise RuntimeError(f"the Dask client is {self.client.status}; the runs recorded "
                               "so far are kept (resume the campaign)")
        busy, n_workers = self._cluster_state()
        if n_workers:
            self.workers_seen = now
        elif now - self.workers_seen > NO_WORKER_STALLS * self.stall_s:
            raise RuntimeError(f"the Dask cluster has had no worker for "
                               f"{now - self.workers_seen:.0f} s; the runs recorded so far "
                               "are kept (resume the campaign)")
        if busy or not n_workers:     # running, or nothing can run: not a lost task
            self.quiet_since = now
            return False
        if now - self.quiet_since < self.stall_s:
            return False
        logging.getLogger(__name__).warning(
            "no Dask task finished for %.0f s and no worker runs any: %d task(s) in flight "
            "taken as lost and submitted again", now - self.quiet_since, len(in_flight))
        self.quiet_since = now
        return True

    def _cluster_state(self):
        """(whether some worker runs a task, number of workers); unknown counts as idle."""
        try:
            ask = self.client.sync
            stacks = ask(self.client.scheduler.call_stack, keys=None,
                         callback_timeout=self.stall_s / 2)
            info = ask(self.client.scheduler.identity, n_workers=-1,
                       callback_timeout=self.stall_s / 2)
        except Exception:   # noqa: BLE001 - an unanswered question must not stop the watch
            return False, 1
        return any(bool(v) for v in (stacks or {}).values()), len(info.get("workers", {}))


def _same_drive(a: Task, b: Optional[Task]) -> bool:
    """Whether ``b`` should ride in ``a``'s chunk: same run index and same non-empty affinity."""
    return (b is not None and bool(a.affinity) and a.affinity == b.affinity
            and a.run_index == b.run_index)


def _chunk_exception(result):
    """The exception of a chunk lost as a whole (``None``: the chunk returned its records).
    ``as_completed(raise_errors=False)`` hands a failed future over as ``(type, exc, tb)``."""
    if (isinstance(result, tuple) and len(result) == 3
            and isinstance(result[1], BaseException)):
        return result[1]
    if isinstance(result, BaseException):
        return result
    if not isinstance(result, list):
        return TypeError(repr(result))
    return None


def _outcomes(result, chunk):
    """The chunk's (record, arrays) pairs; a chunk lost with its worker (e.g. ``KilledWorker``)
    is recorded as one error per run."""
    exc = _chunk_exception(result)
    if exc is not None:
        return [(error_record(task, exc), None) for task in chunk]
    return result


class _Peekable:
    """An iterator whose next item can be looked at (``None`` at the end)."""

    def __init__(self, it):
        self._it, self._next = iter(it), None
        self._advance()

    def _advance(self):
        try:
            self._next = next(self._it)
        except StopIteration:
            self._next = None

    def peek(self):
        return self._next

    def __iter__(self):
        return self

    def __next__(self):
        if self._next is None:
            raise StopIteration
        item = self._next
        self._advance()
        return item


def _take(it, n):
    out = []
    for _ in range(n):
        try:
            out.append(next(it))
        except StopIteration:
            break
    return out
