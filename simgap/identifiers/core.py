"""Shared machinery of ``Identifier`` and ``BatchIdentifier``.

N identifiers of one kind live in flat arrays (layout in :mod:`simgap.identifiers.kernels`)
and are advanced by one numba kernel call.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from simgap.identifiers import kernels as K
from simgap.identifiers.config import KIND_CODES, IdentifierConfig, check_kind, preset
from simgap.identifiers.errors import IdentifierDivergedError, IdentifierError
from simgap.identifiers.minibatch import DUE, FILLED
from simgap.identifiers.network import init_weights

#: Format tag written into saved files.
FORMAT = "simgap-identifier/1"


def _check_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int | np.integer) or int(v) < 1:
        raise IdentifierError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


def sampling_rng(seed: int) -> np.random.Generator:
    """Return the Generator baseline 2 draws its mini-batch indices from.

    It is independent of the weight initialisation stream, ``default_rng(seed)``.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1,)))


class IdentifierBase:
    """N identifiers of one kind sharing hyper-parameters; not used directly."""

    def __init__(self, kind: str, n_states: int, n_inputs: int, dt: float, *,
                 config: IdentifierConfig | None = None, seed: int = 0,
                 n_envs: int = 1) -> None:
        self.kind = check_kind(kind)
        self.n_states = n = _check_int("n_states", n_states)
        self.n_inputs = m = _check_int("n_inputs", n_inputs)
        self.n_envs = _check_int("n_envs", n_envs)
        dt = float(dt)
        if not np.isfinite(dt) or dt <= 0:
            raise IdentifierError(f"dt must be a finite positive number of seconds, got {dt!r}")
        self.dt = dt
        if config is None:
            config = preset("manipulator", kind)
        if not isinstance(config, IdentifierConfig):
            raise IdentifierError(f"config must be an IdentifierConfig, got {type(config)}")
        self.config = config
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise IdentifierError(f"seed must be a non-negative integer, got {seed!r}")
        self.seed = int(seed)
        self.n_hidden = h = config.n_hidden
        self.n_in = p = n + m
        self._nw = n * h
        self._nv = h * p
        self._o = K.out_offsets(n, h, p)
        size_p, size_q = K.layout_sizes(n, h, m)
        nn = self.n_envs
        self._theta = np.zeros((nn, size_p))
        self._out = np.zeros((nn, size_q))
        hp = np.zeros(K.HP_SIZE)
        hp[K.HP_DT] = dt
        hp[K.HP_AD] = config.a_d
        hp[K.HP_ETA1] = config.eta1
        hp[K.HP_ETA2] = config.eta2
        hp[K.HP_RHO1] = config.rho1
        hp[K.HP_RHO2] = config.rho2
        hp[K.HP_LAM] = config.lam
        hp[K.HP_MAXN] = config.max_weight_norm
        hp[K.HP_H] = h
        hp[K.HP_MODE] = KIND_CODES[kind]
        hp[K.HP_PERIOD] = config.update_period
        hp[K.HP_N] = n
        hp[K.HP_M] = m
        self._hp = hp
        self._minibatch = kind == "minibatch"
        if self._minibatch:
            self._buf = np.zeros((nn, config.buffer_size, p + n))
            self._cnt = np.zeros((nn, K.N_COUNTERS), dtype=np.int64)
        else:
            self._buf = np.zeros((nn, 1, p + n))
            self._cnt = np.zeros((nn, K.N_COUNTERS), dtype=np.int64)
        self._active = np.full(nn, 2, dtype=np.int8)
        self.reset()

    # ------------------------------------------------------------------ lifecycle
    def reset(self) -> None:
        """Go back to the state right after construction.

        Initial weights from the seed, x̂ uninitialised, z = 0, empty buffer, sampling
        Generator re-seeded, not frozen.
        """
        w0, v0 = init_weights(self.seed, self.n_states, self.n_hidden, self.n_in,
                              self.config.w0_scale, self.config.v0_scale)
        self._theta[:] = 0.0
        self._theta[:, :self._nw] = w0.ravel()
        self._theta[:, self._nw:self._nw + self._nv] = v0.ravel()
        self._out[:] = 0.0
        self._buf[:] = 0.0
        self._cnt[:] = 0
        self._rng = sampling_rng(self.seed)
        self._frozen = False
        self._active[:] = 2
        self.n_steps = 0
        self.n_updates = 0

    @property
    def frozen(self) -> bool:
        """True while weights, buffer and z are held (x̂ keeps running)."""
        return self._frozen

    def freeze(self) -> None:
        """Stop every weight, buffer and z update; the observer x̂ keeps running."""
        self._frozen = True
        self._active[:] = 1

    def unfreeze(self) -> None:
        """Resume learning."""
        self._frozen = False
        self._active[:] = 2

    # ------------------------------------------------------------------ kernel calls
    def _run(self, x: np.ndarray, u: np.ndarray, f: np.ndarray, x_next: np.ndarray,
             active: np.ndarray) -> None:
        """Advance all rows; raise a typed error naming the failed rows (which are unchanged)."""
        try:
            if self._minibatch:
                r, due = K.minibatch_step(self._theta, self._out, x, u, f, x_next, self._hp,
                                          active, self._buf, self._cnt)
            else:
                r = K.observer_step(self._theta, self._out, x, u, f, x_next, self._hp, active)
                due = 0
        except TypeError:  # not float64 C-contiguous 1-D: convert once and retry
            x, u, f, x_next = (self._coerce(a, name) for a, name in
                               ((x, "x"), (u, "u"), (f, "f"), (x_next, "x_next")))
            return self._run(x, u, f, x_next, active)
        if r != 0:
            self._raise(r, x, u, f, x_next)
        if due:
            self._burst()

    def _burst(self) -> None:
        """Baseline 2: draw the mini-batches of the due rows and take the SGD steps.

        Eq. 4.3-4.4; indices uniform with replacement over each row's filled buffer.
        """
        rows = np.flatnonzero(self._cnt[:, DUE])
        filled = self._cnt[rows, FILLED]
        idx = self._rng.integers(0, filled[:, None], size=(rows.size, self.config.batch_size))
        nfail = K.minibatch_sgd(self._theta, self._out, self._hp, self._buf, self._cnt,
                                np.ascontiguousarray(idx, dtype=np.int64), rows.astype(np.int64))
        self.n_updates += 1
        if nfail:
            bad = [int(i) for i in rows if self._out[i, -1] == K.STATUS_DIVERGED]
            raise IdentifierDivergedError(
                f"{self.kind} identifier: the SGD update of row(s) {bad} would give a weight "
                f"norm above max_weight_norm={self.config.max_weight_norm:g} or non-finite; "
                f"weights kept (lower eta1/eta2)")

    def _coerce(self, a: Any, name: str) -> np.ndarray:
        arr = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
        return arr

    def _raise(self, r: int, x: np.ndarray, u: np.ndarray, f: np.ndarray,
               x_next: np.ndarray) -> None:
        nn, n, m = self.n_envs, self.n_states, self.n_inputs
        if r < 0:
            raise IdentifierError(
                f"{self.kind} identifier: expected x, f, x_next with {nn * n} values "
                f"({nn}×{n}) and u with {nn * m} ({nn}×{m}); got sizes x={np.size(x)}, "
                f"u={np.size(u)}, f={np.size(f)}, x_next={np.size(x_next)}")
        status = self._out[:, -1]
        bad_in = np.flatnonzero(status == K.STATUS_BAD_INPUT)
        if bad_in.size:
            raise IdentifierError(f"{self.kind} identifier: non-finite value in x, u, f or "
                                  f"x_next (row(s) {bad_in.tolist()}); identifier unchanged")
        bad = np.flatnonzero((status == K.STATUS_DIVERGED) | (status == K.STATUS_STATE_DIVERGED))
        raise IdentifierDivergedError(
            f"{self.kind} identifier diverged in row(s) {bad.tolist()}: the update would make "
            f"x̂ non-finite or a weight norm exceed max_weight_norm="
            f"{self.config.max_weight_norm:g}; last good state kept (lower eta1/eta2 or dt)")

    # ------------------------------------------------------------------ views
    def _W(self) -> np.ndarray:  # noqa: N802
        return self._theta[:, :self._nw].reshape(self.n_envs, self.n_states, self.n_hidden)

    def _V(self) -> np.ndarray:  # noqa: N802
        return self._theta[:, self._nw:self._nw + self._nv].reshape(
            self.n_envs, self.n_hidden, self.n_in)

    def _field(self, which: str) -> np.ndarray:
        n, p = self.n_states, self.n_in
        o = self._o
        start, size = {"g": (o[0], n), "x_bar": (o[1], p), "x_hat": (o[2], n),
                       "x_tilde": (o[3], n), "e": (o[4], n)}[which]
        return self._out[:, start:start + size]

    def _z(self) -> np.ndarray:
        a = self._nw + self._nv + self.n_states
        return self._theta[:, a:a + self.n_states]

    def _initialised(self) -> np.ndarray:
        return self._theta[:, -1] != 0.0

    def _predict_row(self, row: int, x_bar: Any) -> np.ndarray:
        xb = np.ascontiguousarray(x_bar, dtype=np.float64)
        single = xb.ndim == 1
        xb2 = xb.reshape(1, -1) if single else xb
        if xb2.ndim != 2 or xb2.shape[1] != self.n_in:
            raise IdentifierError(f"x_bar must have shape ({self.n_in},) or (K, {self.n_in}) "
                                  f"= [state; input], got {xb.shape}")
        if not np.all(np.isfinite(xb2)):
            raise IdentifierError("x_bar contains non-finite values")
        res = np.empty((xb2.shape[0], self.n_states))
        K.predict_rows(self._theta[row], self.n_states, self.n_hidden, self.n_in, xb2, res)
        return res[0] if single else res

    # ------------------------------------------------------------------ persistence
    def _meta(self) -> dict[str, Any]:
        return {"format": FORMAT, "kind": self.kind, "n_states": self.n_states,
                "n_inputs": self.n_inputs, "dt": self.dt, "seed": self.seed,
                "n_envs": self.n_envs, "config": self.config.to_dict(),
                "frozen": self._frozen, "n_steps": self.n_steps, "n_updates": self.n_updates,
                "rng_state": self._rng.bit_generator.state}

    def _arrays(self) -> dict[str, np.ndarray]:
        return {"theta": self._theta.copy(), "out": self._out.copy(),
                "buffer": self._buf.copy(), "counters": self._cnt.copy()}

    def _load_arrays(self, meta: dict[str, Any], arrays: dict[str, np.ndarray],
                     source: str) -> None:
        for key, dst in (("theta", self._theta), ("out", self._out), ("buffer", self._buf),
                         ("counters", self._cnt)):
            if key not in arrays:
                raise IdentifierError(f"{source}: missing array {key!r}")
            a = np.asarray(arrays[key])
            if a.shape != dst.shape:
                raise IdentifierError(f"{source}: array {key!r} has shape {a.shape}, expected "
                                      f"{dst.shape} for this identifier")
            if key != "counters" and not np.all(np.isfinite(a)):
                raise IdentifierError(f"{source}: array {key!r} contains non-finite values")
        self._theta[:] = arrays["theta"]
        self._out[:] = arrays["out"]
        self._buf[:] = arrays["buffer"]
        self._cnt[:] = arrays["counters"]
        rng = sampling_rng(self.seed)
        try:
            rng.bit_generator.state = meta["rng_state"]
        except (KeyError, TypeError, ValueError) as exc:
            raise IdentifierError(f"{source}: bad rng_state ({exc})") from None
        self._rng = rng
        if meta.get("frozen", False):
            self.freeze()
        else:
            self.unfreeze()
        self.n_steps = int(meta.get("n_steps", 0))
        self.n_updates = int(meta.get("n_updates", 0))

    def state_dict(self) -> dict[str, Any]:
        """Return everything needed for an identical continuation.

        ``meta`` (JSON-able dict: kind, sizes, dt, seed, config, frozen, counters,
        sampling-Generator state) and the raw arrays ``theta``, ``out``, ``buffer``,
        ``counters`` (copies; layout in :mod:`simgap.identifiers.kernels`).
        """
        d: dict[str, Any] = {"meta": json.loads(json.dumps(self._meta()))}
        d.update(self._arrays())
        return d

    def load_state_dict(self, d: dict[str, Any]) -> None:
        """Restore a :meth:`state_dict` taken from an identifier of the same kind and sizes."""
        if "meta" not in d:
            raise IdentifierError("state dict has no 'meta' entry")
        meta = d["meta"]
        for key in ("kind", "n_states", "n_inputs", "n_envs"):
            if meta.get(key) != getattr(self, key):
                raise IdentifierError(f"state dict is for {key}={meta.get(key)!r}, this "
                                      f"identifier has {key}={getattr(self, key)!r}")
        if meta.get("config") != self.config.to_dict():
            raise IdentifierError("state dict was saved with a different IdentifierConfig")
        self._load_arrays(meta, d, "state dict")
