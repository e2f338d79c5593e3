"""Running a campaign: serially in this process, on a Dask LocalCluster of processes
(127.0.0.1, no dashboard), or on an existing Dask scheduler by address.

Scenarios are batched per task; each finished task's rows are persisted at once
(:class:`~motionplc.campaign.store.ResultStore`), so a campaign interrupted at any point
resumes with the scenarios not yet stored, and a rerun of a finished one runs nothing.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motionplc.campaign.scenario import Job, run_batch
from motionplc.campaign.spec import Campaign, Scenario
from motionplc.campaign.store import ResultStore, table_digest
from motionplc.errors import MotionPlcError

__all__ = ["CampaignResult", "job_of", "output_dir", "run_campaign"]


@dataclass
class CampaignResult:
    """What :func:`run_campaign` did: the result table (one row per scenario, in order),
    how many scenarios ran now and how many were already stored, the wall time [s] and
    where the results are."""

    campaign: Campaign
    table: list[dict[str, Any]]
    ran: int
    reused: int
    seconds: float
    output: Path
    mode: str
    workers: int
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def digest(self) -> str:
        return table_digest(self.table)


def output_dir(c: Campaign, output: str | Path | None = None) -> Path:
    if output is not None:
        return Path(output)
    if c.execution.output is not None:
        return Path(c.execution.output)
    return Path("out") / "campaigns" / c.name


def job_of(c: Campaign, output: Path | None = None, trace: bool | None = None) -> Job:
    keep = c.execution.trace if trace is None else trace
    return Job(
        config_path=c.config_path,
        program_path=c.program_path,
        group=c.group,
        seconds=c.seconds,
        timeout=c.timeout,
        verdict_program=c.verdict.program,
        reaction_time=c.verdict.reaction_time,
        max_following_error=c.verdict.max_following_error,
        trace_dir=str(output / "traces") if keep and output is not None else None,
        axes=c.axes,
    )


def _batches(items: list[Scenario], size: int) -> list[list[Scenario]]:
    return [items[i : i + size] for i in range(0, len(items), size)]


def _auto_batch(n: int, workers: int) -> int:
    return max(1, min(50, math.ceil(n / (8 * max(1, workers)))))


class _Progress:
    """tqdm's bar with its ETA on a terminal; a line per 10 % otherwise (or nothing)."""

    def __init__(self, total: int, done: int, quiet: bool, label: str) -> None:
        self.total, self.n = total, done
        self.quiet = quiet
        self.bar = None
        self.next_pct = 10
        if quiet or total == 0:
            return
        if sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(
                total=total, initial=done, unit="scenario", desc=label, dynamic_ncols=True
            )
        else:
            print(f"{label}: {done}/{total} already stored", file=sys.stderr, flush=True)

    def update(self, k: int, clock: float, start: float, ran: int) -> None:
        self.n += k
        if self.bar is not None:
            self.bar.update(k)
            return
        if self.quiet or self.total == 0:
            return
        pct = 100 * self.n // self.total
        if pct >= self.next_pct or self.n == self.total:
            self.next_pct = (pct // 10 + 1) * 10
            el = clock - start
            rate = ran / el if el > 0 else 0.0
            eta = (self.total - self.n) / rate if rate > 0 else float("nan")
            print(
                f"  {self.n}/{self.total} ({pct} %), {rate:.1f} scenarios/s, ETA {eta:.0f} s",
                file=sys.stderr,
                flush=True,
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _clock() -> float:
    import time

    return time.perf_counter()  # the engine's stopwatch (progress, throughput)


def _check_scheduler(address: str) -> None:
    import re

    if not re.match(r"^tcp://(127\.0\.0\.1|localhost|\[::1\]):[0-9]{1,5}$", address):
        raise MotionPlcError(
            f"--scheduler: {address!r} (allowed: tcp://127.0.0.1:PORT, a scheduler on the "
            "loopback of this machine)"
        )


def _dask() -> Any:
    try:
        import distributed
    except ImportError:
        raise MotionPlcError(
            "campaigns run on Dask: pip install 'motionplc[campaign]' (or --workers 0: serial)"
        ) from None
    return distributed


def run_campaign(
    c: Campaign,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    batch: int | None = None,
    output: str | Path | None = None,
    trace: bool | None = None,
    quiet: bool = False,
    only: Iterable[int] | None = None,
    on_rows: Callable[[list[dict[str, Any]]], None] | None = None,
    client: Any = None,
    rerun: bool = False,
) -> CampaignResult:
    """Run the scenarios of ``c`` not yet stored under ``output`` and return the table.

    ``workers`` 0: serially in this process; else a LocalCluster of that many processes
    (default: ``execution.workers``, else one per core), unless ``scheduler`` (or
    ``execution.scheduler``) names an existing Dask scheduler, or ``client`` is a
    ``distributed.Client`` to use as is. ``only``: these scenario numbers (and the table
    holds just them). ``on_rows``: called with the rows of every finished task (after they
    are stored). ``rerun``: run them even when stored (``--only``: to look at one again,
    with its trace)."""
    out = output_dir(c, output)
    store = ResultStore(out)
    job = job_of(c, out, trace)
    indices = list(range(len(c))) if only is None else sorted(set(only))
    for i in indices:
        if not 0 <= i < len(c):
            raise MotionPlcError(f"--only {i}: the campaign has scenarios 0..{len(c) - 1}")
    scenarios = list(c.scenarios(indices))
    keys = {s.index: s.key for s in scenarios}
    done = set() if rerun else store.done(keys)
    todo = [s for s in scenarios if s.index not in done]
    scheduler = scheduler if scheduler is not None else c.execution.scheduler
    if workers is None:
        workers = c.execution.workers
    if client is not None:
        mode = "client"
    elif scheduler is not None:
        _check_scheduler(scheduler)
        mode = "scheduler"
    elif workers == 0:
        mode = "serial"
    else:
        mode = "local"
        workers = workers or os.cpu_count() or 1
    n_workers = 1 if mode == "serial" else int(workers or 0)
    start = _clock()
    progress = _Progress(len(scenarios), len(done), quiet, c.name)
    counts: dict[str, int] = {}

    def arrived(rows: list[dict[str, Any]]) -> None:
        store.write(rows)
        for r in rows:
            counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
        if on_rows is not None:
            on_rows(rows)
        progress.update(len(rows), _clock(), start, sum(counts.values()))

    try:
        if todo and mode == "serial":
            size = batch or c.execution.batch or min(10, _auto_batch(len(todo), 1))
            for b in _batches(todo, size):
                arrived(run_batch(job, b))
        elif todo:
            n_workers = _run_dask(
                job, todo, mode, workers, scheduler, client, batch or c.execution.batch, arrived
            )
    finally:
        progress.close()
    seconds = _clock() - start
    table = store.table(keys)
    if only is None and len(table) == len(c):
        store.write_table(table)
    return CampaignResult(
        c, table, len(todo), len(done), seconds, out, mode, n_workers, _count(table)
    )


def _count(table: list[dict[str, Any]]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for r in table:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    return counts


def _run_dask(
    job: Job,
    todo: list[Scenario],
    mode: str,
    workers: int | None,
    scheduler: str | None,
    client: Any,
    batch: int | None,
    arrived: Callable[[list[dict[str, Any]]], None],
) -> int:
    distributed = _dask()
    cluster = None
    own_client = client is None
    try:
        if client is None:
            if mode == "scheduler":
                client = distributed.Client(scheduler, timeout="20s")
            else:
                cluster = distributed.LocalCluster(
                    n_workers=int(workers or 1),
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address=None,
                    scheduler_kwargs={"host": "127.0.0.1"},
                    worker_dashboard_address=None,
                    silence_logs=40,
                )
                client = distributed.Client(cluster)
        n = len(client.nthreads()) or 1
        size = batch or _auto_batch(len(todo), n)
        futures = []
        for b in _batches(todo, size):
            key = f"motionplc-scenarios-{b[0].key[:12]}-{b[0].index}-{len(b)}"
            futures.append(client.submit(run_batch, job, b, key=key, pure=False, retries=1))
        by_future = dict(zip(futures, _batches(todo, size), strict=True))
        for fut in distributed.as_completed(futures):
            try:
                rows = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost task: its scenarios are error rows
                rows = [
                    {
                        "scenario": s.index,
                        "key": s.key,
                        "verdict": "error",
                        "failures": f"task failed: {type(exc).__name__}: {exc}",
                        "wall_s": 0.0,
                        "worker": os.getpid(),
                    }
                    for s in by_future[fut]
                ]
            arrived(rows)
            fut.release()
        return n
    finally:
        if own_client and client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
