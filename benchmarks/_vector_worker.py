"""Persistent timing worker of ``bench_vector.py`` (runs against whichever ``simgap`` it imports).

``bench_vector.py --filed TREE`` starts this script with ``PYTHONPATH=TREE`` (a checkout of
the commit issue 17 was filed against), so the vector envs it times are that code's, with
that checkout's own numba caches. It reads one request per line on stdin and answers each
on stdout:

* ``time ENV_ID MODE N BUDGET``: env-steps per wall second and per CPU second of
  ``gym.make_vec(ENV_ID, N)`` (``MODE`` ``sync``: ``vectorization_mode="sync"``; ``native``:
  the registered ``vector_entry_point``) stepped with zero actions for about ``BUDGET`` s
  (the env is made, reset with seed 0 and warmed on first use, then kept);
* ``close``: close every env made so far (answers ``ok``);
* ``where``: the imported ``simgap`` package's path.

:func:`rate` is also the in-process timer of ``bench_vector.py``, so both sides time the
same loop.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np


def rate(env: Any, n: int, budget: float) -> tuple[float, float]:
    """(env-steps per wall s, per CPU s) of ``env.step`` with zero actions for ~budget s.

    Args:
        env: a vector env (or anything with ``action_space`` and ``step``).
        n: number of sub-envs (env-steps per ``step`` call).
        budget: wall time to spend stepping (s); one untimed warm-up step comes first.

    Returns:
        The two rates, in env-steps/s.
    """
    a = np.zeros(env.action_space.shape, dtype=np.float32)
    env.step(a)  # warm-up (compilation, first-call costs)
    steps = 0
    w0, c0 = time.perf_counter(), time.process_time()
    while True:
        for _ in range(4):
            env.step(a)
        steps += 4
        wall = time.perf_counter() - w0
        if wall >= budget:
            break
    cpu = time.process_time() - c0
    return steps * n / wall, steps * n / max(cpu, 1e-9)


def serve() -> None:
    """Answer requests from stdin until it closes (see the module docstring)."""
    import gymnasium as gym

    import simgap

    envs: dict[tuple[str, str, int], Any] = {}
    for line in sys.stdin:
        words = line.split()
        if words[0] == "where":
            print(simgap.__file__, flush=True)
        elif words[0] == "close":
            for env in envs.values():
                env.close()
            envs.clear()
            print("ok", flush=True)
        else:
            _, env_id, mode, n_text, budget = words
            key = (env_id, mode, int(n_text))
            if key not in envs:
                kw = {} if mode == "native" else {"vectorization_mode": mode}
                env = gym.make_vec(env_id, num_envs=key[2], **kw)
                env.reset(seed=0)
                envs[key] = env
            wall, cpu = rate(envs[key], key[2], float(budget))
            print(wall, cpu, flush=True)


if __name__ == "__main__":
    serve()
