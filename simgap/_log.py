"""Plain progress lines on stderr for the command line, defined once.

Every line is ``[HH:MM:SS] message`` (no Rich source suffix, no colour codes), so that a log
captured to a file reads the same as the terminal; an error is one ``error: ...`` line
(:func:`error`), never wrapped to the terminal's width. :func:`stage` reports a step that may take
a while: once it has run for ``after`` seconds a start line, then a heartbeat line every
``every`` seconds (so a 30 s diagnosis is never silent), and a line with the elapsed time
when it ends.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO

#: Seconds a :func:`stage` stays silent (quick steps print nothing).
QUIET_S = 2.0
#: Seconds between heartbeat lines of a running :func:`stage`.
HEARTBEAT_S = 10.0


def line(message: str) -> str:
    """``[HH:MM:SS] message``: the one format of every progress line."""
    return f"[{time.strftime('%H:%M:%S')}] {message}"


def error_line(message: object) -> str:
    """``error: message`` on one line: every run of whitespace (newlines too) becomes a space.

    The one format of a command-line error (exit status 2 for bad input), whatever the
    terminal width: never wrapped by a console, nothing after the first line dropped.
    """
    text = " ".join(str(message).split())
    return f"error: {text or 'bad input'}"


def error(message: object, stream: TextIO | None = None) -> None:
    """Write :func:`error_line` of ``message`` to ``stream`` (default: stderr) and flush it."""
    out = stream if stream is not None else sys.stderr
    print(error_line(message), file=out, flush=True)


def log(message: str, stream: TextIO | None = None) -> None:
    """Write one plain progress line to ``stream`` (default: stderr) and flush it."""
    out = stream if stream is not None else sys.stderr
    print(line(message), file=out, flush=True)


@contextmanager
def stage(message: str, *, after: float = QUIET_S, every: float = HEARTBEAT_S,
          stream: TextIO | None = None) -> Iterator[None]:
    """Report a step that may take seconds: a start line, heartbeats, an end line.

    A step that ends (or fails) within ``after`` seconds prints nothing, so that a quick
    command, or bad input caught at once, keeps its output to the one line that matters.

    Args:
        message: what the step does ("diagnosing run.csv against bicycle").
        after: seconds before the first line (the start line) is written.
        every: seconds between heartbeat lines after that (> 0).
        stream: where to write (default: stderr).
    """
    start = time.perf_counter()
    done = threading.Event()
    started = threading.Event()

    def beat() -> None:
        if done.wait(after):
            return
        started.set()
        log(f"{message} ... ({time.perf_counter() - start:.0f} s)", stream)
        while not done.wait(every):
            log(f"  ... still {message} ({time.perf_counter() - start:.0f} s)", stream)

    worker = threading.Thread(target=beat, daemon=True)
    worker.start()
    try:
        yield
    finally:
        done.set()
        worker.join()
    if started.is_set():
        log(f"{message}: done in {time.perf_counter() - start:.1f} s", stream)


def progress_lines(every: float = HEARTBEAT_S, stream: TextIO | None = None
                   ) -> Callable[[str, int, int], None]:
    """A ``progress(task, done, total)`` callback writing throttled plain lines.

    At most one line per ``every`` seconds, and always the line that completes a task. For
    library functions that report progress through such a callback (e.g.
    :func:`simgap.evaluation.pipeline.reproduce`) when no progress bar is wanted.
    """
    last = [-float("inf")]

    def progress(task: str, done: int, total: int) -> None:
        now = time.perf_counter()
        if done >= total or now - last[0] >= every:
            last[0] = now
            log(f"  {task}: {done}/{total} ({100.0 * done / max(total, 1):.0f} %)", stream)

    return progress
