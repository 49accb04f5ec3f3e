"""Run many independent jobs (seeds, recordings) serially, on a local process pool, or on Ray.

One function, three backends, the same results in the same order:

* ``jobs=1`` (default): in this process, one after the other;
* ``jobs=N``: a local :class:`concurrent.futures.ProcessPoolExecutor` with the ``spawn``
  start method (numba's and OpenMP's threads do not survive ``fork``); no extra needed;
* ``ray=True`` or ``ray="ADDRESS"``: Ray (extra ``ray``). ``True`` starts a local instance
  with ``jobs`` CPUs (or joins the cluster named by ``RAY_ADDRESS``), an address joins that
  cluster (``"auto"`` finds a running one); each job asks for one CPU.

A job is ``fn(*args)`` with a picklable module-level ``fn``; results are identical to the
serial run whenever ``fn`` is deterministic in its arguments (every simgap job takes its
seed as an argument). A job that raises is reported (:attr:`JobResult.error`, one line) and
the others are kept. ``progress(done, total)`` is called as jobs finish.
"""

from __future__ import annotations

import multiprocessing
import os
import traceback
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from simgap.errors import SimgapError


class SweepError(SimgapError):
    """Bad sweep options (job count, Ray address) or Ray missing."""


@dataclass(frozen=True)
class JobResult:
    """Outcome of one job.

    Attributes:
        index: position of the job in the input list.
        args: the job's arguments.
        value: what ``fn`` returned (None if it failed).
        error: one line ``Type: message`` if it raised, else None.
    """

    index: int
    args: tuple
    value: Any = None
    error: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the job finished without raising."""
        return self.error is None


def _call(fn: Callable[..., Any], index: int, args: tuple) -> JobResult:
    try:
        return JobResult(index=index, args=args, value=fn(*args))
    except Exception as exc:  # noqa: BLE001 - a failed job is reported, the sweep goes on
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return JobResult(index=index, args=args, error=last.splitlines()[0])


def parse_seeds(text: str) -> list[int]:
    """Parse ``"0-99"``, ``"3"`` or ``"0,2,5-7"`` into a sorted list of distinct seeds.

    Raises:
        SweepError: on anything else (negative numbers, reversed ranges, non-integers).
    """
    seeds: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise SweepError(f"--seeds: {part!r} is not N or N-M") from None
        if a < 0 or b < a:
            raise SweepError(f"--seeds: {part!r} is not a non-empty range of seeds >= 0")
        if b - a >= 100_000:
            raise SweepError(f"--seeds: {part!r} has more than 100000 seeds")
        seeds.update(range(a, b + 1))
    return sorted(seeds)


def run_jobs(fn: Callable[..., Any], jobs: Sequence[tuple], *, workers: int = 1,
             ray: bool | str | None = None,
             progress: Callable[[int, int], None] | None = None) -> list[JobResult]:
    """Run ``fn(*args)`` for every ``args`` in ``jobs``; results in input order.

    Args:
        fn: a picklable (module-level) function.
        jobs: one argument tuple per job.
        workers: local processes (or Ray CPUs for a local Ray instance); 1 = serial.
        ray: None/False for local execution, True for a local Ray instance (or the
            cluster in ``RAY_ADDRESS``), or a cluster address.
        progress: called with (done, total) after each finished job.

    Returns:
        One :class:`JobResult` per job, in the order of ``jobs``.

    Raises:
        SweepError: ``workers`` < 1, or Ray requested but not installed.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepError(f"--jobs must be an integer >= 1, got {workers!r}")
    jobs = [tuple(a) for a in jobs]
    total = len(jobs)
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    if ray not in (None, False):
        return _run_ray(fn, jobs, workers, ray, tick)
    if workers == 1 or total <= 1:
        out = []
        for i, a in enumerate(jobs):
            out.append(_call(fn, i, a))
            tick()
        return out
    results: list[JobResult | None] = [None] * total
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(workers, total), mp_context=ctx) as pool:
        futures = {pool.submit(_call, fn, i, a): i for i, a in enumerate(jobs)}
        for fut in as_completed(futures):
            results[futures[fut]] = fut.result()
            tick()
    return [r for r in results if r is not None]


def _run_ray(fn: Callable[..., Any], jobs: list[tuple], workers: int, address: bool | str,
             tick: Callable[[], None]) -> list[JobResult]:
    try:
        import ray as ray_mod
    except ImportError:
        raise SweepError("--ray needs the extra 'ray' (pip install 'simgap[ray]')") from None
    started = False
    if not ray_mod.is_initialized():
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                  "configure_logging": False}
        if isinstance(address, str):
            kwargs["address"] = address
        elif os.environ.get("RAY_ADDRESS"):
            kwargs["address"] = os.environ["RAY_ADDRESS"]
        else:
            kwargs["num_cpus"] = workers
        try:
            ray_mod.init(**kwargs)
        except Exception as exc:  # noqa: BLE001 - Ray raises a bare Exception on start-up
            # time-outs (an overloaded machine), ConnectionError/RuntimeError otherwise
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise SweepError(f"--ray: cannot start or join Ray ({first})") from None
        started = True
    try:
        remote = ray_mod.remote(num_cpus=1)(_call)
        refs = [remote.remote(fn, i, a) for i, a in enumerate(jobs)]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[JobResult | None] = [None] * len(jobs)
        pending = list(refs)
        while pending:
            ready, pending = ray_mod.wait(pending, num_returns=1)
            for ref in ready:
                i = index[ref]
                try:
                    results[i] = ray_mod.get(ref)
                except Exception as exc:  # noqa: BLE001 - worker died: report, keep others
                    results[i] = JobResult(index=i, args=jobs[i],
                                           error=f"{type(exc).__name__}: worker failed")
                tick()
        return [r for r in results if r is not None]
    finally:
        if started:
            ray_mod.shutdown()


@contextmanager
def progress_bar(total: int, label: str = "sweep") -> Iterator[Callable[[int, int], None]]:
    """A progress bar over all jobs on stderr (rich); yields the ``progress`` callback."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn(label), BarColumn(),
                  TextColumn("{task.completed}/{task.total} jobs"), TimeElapsedColumn(),
                  console=Console(stderr=True)) as bar:
        task = bar.add_task(label, total=total)
        yield lambda done, _total: bar.update(task, completed=done)
