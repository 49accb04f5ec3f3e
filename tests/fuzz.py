"""Seeded fuzz cases over the input categories of issue 15, and the runner that judges them.

Each case gets a fresh folder holding the user's files (a short arm or bicycle recording,
notes, a parameter file ...), runs one CLI command (in-process, typer's CliRunner) or one
API call under a time limit, and is classified:

* ``rejected``: exit status 2 with exactly one output line (CLI) or a ``SimgapError`` (API);
* ``accepted``: exit 0 with a finite ``report.json`` (diagnose) / a readable recording
  (record) / finite observations (env) / a loaded identifier;
* ``traceback``: anything else (another exit code, several lines, another exception);
* ``hang``: the time limit was hit.

After every case the folder is compared with its snapshot: any pre-existing entry changed or
removed, or any new entry besides the case's declared output, counts as a user file touched.
``python -m tests.fuzz`` is not provided; :mod:`benchmarks.bench_fuzz` runs the full set and
``tests/test_fuzz.py`` a quick subset (and the full set with ``SIMGAP_SLOW=1``).
"""

from __future__ import annotations

import json
import math
import os
import signal
import tempfile
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

CATEGORIES = ("structure", "dtypes", "nan_inf", "magnitudes", "time", "units", "paths",
              "options", "sizes", "encodings", "api_actions", "identifier_files")
#: Seconds a single case may run before it counts as a hang.
CASE_TIMEOUT = 60.0


@dataclass
class Case:
    """One fuzz case: files to create, then a CLI argv or an API callable."""

    category: str
    name: str
    files: dict[str, bytes] = field(default_factory=dict)
    argv: list[str] | None = None
    api: Callable[[Path], str] | None = None  # returns "accepted"; raises to reject
    output: str | None = None  # the path (relative) the case may create
    fifo: str | None = None


@contextmanager
def time_limit(seconds: float):
    """Raise TimeoutError in the main thread after ``seconds`` (SIGALRM)."""
    def _raise(*_):
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


_BASE: dict[str, str] = {}


def base_csv(model: str) -> str:
    """A short clean recording as CSV text (arm 2 s at 500 Hz, bicycle 5 s at 100 Hz)."""
    if model not in _BASE:
        from simgap.diagnosis.generate import InjectedEffect, generate

        if model == "bicycle":
            rec = generate("bicycle", [], duration=5.0, seed=3)
        else:
            eff = InjectedEffect(effect="coulomb_friction", channel="joint2", params={"Fc": 0.3})
            rec = generate("manipulator2dof", [eff], duration=2.0, seed=1)
        _BASE[model] = rec.to_frame().to_csv(index=False, float_format="%.9g")
    return _BASE[model]


def _table(text: str) -> tuple[list[str], list[list[str]]]:
    lines = text.strip("\n").split("\n")
    return lines[0].split(","), [ln.split(",") for ln in lines[1:]]


def _join(header: list[str], rows: list[list[str]]) -> bytes:
    return ("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n").encode()


def _scaled(header, rows, col: str, f: Callable[[float], float]):
    j = header.index(col)
    return [r[:j] + [repr(float(f(float(r[j]))))] + r[j + 1:] for r in rows]


def _diag(model: str, data: bytes, name: str = "rec.csv", out: str = "rep",
          extra: tuple[str, ...] = ()) -> tuple[dict[str, bytes], list[str], str]:
    return ({name: data, "notes.txt": b"my notes\n"},
            ["diagnose", name, "--model", model, "--out", out, "--no-figures", *extra], out)


def make_case(category: str, rng: np.random.Generator, i: int) -> Case:  # noqa: C901
    """Case number ``i`` of ``category`` (deterministic given the generator's state)."""
    model = "bicycle" if rng.random() < 0.3 else "manipulator2dof"
    sub = np.random.default_rng(rng.integers(2**32))  # API cases draw from their own stream
    header, rows = _table(base_csv(model))
    data_cols = [c for c in header if c != "t"]
    col = str(rng.choice(data_cols))
    r = int(rng.integers(len(rows)))

    def diag(data: bytes, **kw) -> Case:
        files, argv, out = _diag(model, data, **kw)
        return Case(category, f"{category}-{i}", files, argv, output=out)

    if category == "structure":
        k = int(rng.integers(10))
        if k == 0:
            j = header.index(col)
            return diag(_join(header[:j] + header[j + 1:], [x[:j] + x[j + 1:] for x in rows]))
        if k == 1:
            return diag(_join(header[:-1] + [header[1]], rows))
        if k == 2:
            return diag(b"")
        if k == 3:
            return diag(_join(header, []))
        if k == 4:
            return diag(_join(header, [x + [""] for x in rows]))
        if k == 5:
            rows[r] = rows[r][:-2]
            return diag(_join(header, rows))
        if k == 6:
            raw = _join(header, rows)
            return diag(raw[: int(rng.integers(1, len(raw)))])
        if k == 7:
            return diag(rng.bytes(int(rng.integers(1, 5000))))
        if k == 8:
            return diag(_join(header, rows).replace(b",", b";"))
        perm = rng.permutation(len(header))
        return diag(_join([header[p] for p in perm], [[x[p] for p in perm] for x in rows]))
    if category == "dtypes":
        j = header.index(col)
        rows[r][j] = str(rng.choice(["abc", "", "True", "0x1F", "1+2j", "1,5", "--1", "1e",
                                     " ", "NULL", "[1]"]))
        return diag(_join(header, rows))
    if category == "nan_inf":
        j = header.index(str(rng.choice(header)))
        rows[r][j] = str(rng.choice(["nan", "inf", "-inf", "1e400", "-1e400", "NaN"]))
        return diag(_join(header, rows))
    if category == "magnitudes":
        if rng.random() < 0.5:
            j = header.index(col)
            rows[r][j] = str(rng.choice(["1e300", "-1e300", "1e-300", "1e15", "1e308"]))
            return diag(_join(header, rows))
        f = 10.0 ** float(rng.choice([-300, -40, -12, -3, -1, 1, 3, 12, 40, 300]))
        return diag(_join(header, _scaled(header, rows, col, lambda v: v * f)))
    if category == "time":
        k = int(rng.integers(7))
        if k == 0:
            f = 10.0 ** float(rng.choice([-9, -7, -4, 3, 6]))
            return diag(_join(header, _scaled(header, rows, "t", lambda v: v * f)))
        if k == 1:
            rows[r][0] = rows[max(r - 1, 0)][0]
            return diag(_join(header, rows))
        if k == 2:
            return diag(_join(header, rows[::-1]))
        if k == 3:  # epoch time stamps: accepted
            return diag(_join(header, _scaled(header, rows, "t", lambda v: v + 1.7e9)))
        if k == 4:  # a gap (resampled)
            return diag(_join(header, rows[: len(rows) // 2] + rows[len(rows) // 2 + 7:]))
        if k == 5:
            jit = rng.normal(0, 0.2, len(rows))
            ts = [float(x[0]) for x in rows]
            dt = ts[1] - ts[0]
            for x, e, t0 in zip(rows, jit, ts, strict=True):
                x[0] = repr(float(t0 + e * dt))
            return diag(_join(header, rows))
        return diag(_join(header, _scaled(header, rows, "t", lambda v: -v)))
    if category == "units":
        if model == "bicycle":
            c, f = [("vx", 3.6 * 4), ("delta_f", 180 / math.pi), ("r", 180 / math.pi),
                    ("delta_f", -1.0), ("vy", 1.0)][int(rng.integers(5))]
            return diag(_join(header, _scaled(header, rows, c, lambda v: v * f)))
        k = int(rng.integers(5))
        if k == 0:
            for c in ("q1", "q2"):
                rows = _scaled(header, rows, c, math.degrees)
        elif k == 1:
            for c in ("q1", "q2", "dq1", "dq2"):
                rows = _scaled(header, rows, c, math.degrees)
        elif k == 2:
            rows = _scaled(header, rows, str(rng.choice(["tau1", "tau2"])), lambda v: v * 1e3)
        elif k == 3:
            rows = _scaled(header, rows, str(rng.choice(["tau1", "tau2"])), lambda v: -v)
        else:
            rows = _scaled(header, rows, "t", lambda v: v * 1e3)
        return diag(_join(header, rows))
    if category == "paths":
        data = _join(header, rows)
        k = int(rng.integers(11))
        files = {"data/rec.csv": data, "data/notes.txt": b"x\n", "out": b"mine\n"}
        outs = ["data", "data/rec.csv", "out", ".", "", "out/sub", "new/deeper/rep", "rep",
                "data/..", "/", "rep"]
        out = outs[k]
        if k == 10:  # a previous simgap report: replaced
            files["rep/report.json"] = b"{}"
            files["rep/.simgap-output.json"] = json.dumps(
                {"tool": "simgap", "kind": "diagnose", "files": ["report.json"]}).encode()
        rec = "data/rec.csv" if rng.random() < 0.8 else str(rng.choice(
            ["data", "missing.csv", "data/notes.txt", "pipe.csv"]))
        c = Case(category, f"{category}-{i}", files,
                 ["diagnose", rec, "--model", model, "--out", out, "--no-figures"],
                 output=out if out not in ("", ".", "data", "data/..", "/") else None,
                 fifo="pipe.csv" if rec == "pipe.csv" else None)
        if k == 10:
            c.output = "rep"
        return c
    if category == "options":
        k = int(rng.integers(4))
        if k == 0:
            m = str(rng.choice(["", " ", "tank", ":", "x.py:", "../", "manipulator2dof:",
                                "notes.txt:NAME", "BICYCLE", "bicycle "]))
            files, argv, out = _diag(model, _join(header, rows))
            argv[3] = m
            return Case(category, f"{category}-{i}", files, argv, output=out)
        if k == 1:
            body = str(rng.choice(['{"m": 1e300}', '{"Iz": 1e-300}', '{"m": -1}', '{"m": "x"}',
                                   "[]", '{"m": NaN}', '{"l": 0.3}', '{"m": [1, 2]}', "{",
                                   '{"mu": 0.8}', '{"m": 1e-9}', '{"g": 0}']))
            files, argv, out = _diag(model, _join(header, rows), extra=("--params", "p.json"))
            files["p.json"] = body.encode()
            return Case(category, f"{category}-{i}", files, argv, output=out)
        if k == 2:
            dur = str(rng.choice(["1e9", "nan", "inf", "-1", "0", "1e-9", "1e400", "0.5",
                                  "abc", "1"]))
            return Case(category, f"{category}-{i}", {"notes.txt": b"x"},
                        ["record", "new.csv", "--model", model, "--duration", dur,
                         "--no-truth"], output="new.csv")
        eff = str(rng.choice(["warp:k=1", "coulomb_friction:joint9:Fc=1", ":::",
                              "coulomb_friction:joint1:Fc=nan", "coulomb_friction:joint1:Fc=1e300",
                              "tire_saturation:mu=0.7", "coulomb_friction:joint1:Fc=0.2", "=",
                              "viscous_friction:joint1:b=-5"]))
        return Case(category, f"{category}-{i}", {"notes.txt": b"x"},
                    ["record", "new.csv", "--model", model, "--duration", "1", "--effect", eff,
                     "--no-truth"], output="new.csv")
    if category == "sizes":
        k = int(rng.integers(6))
        if k == 0:
            return diag(_join(header, rows[: int(rng.choice([0, 1, 3, 49, 50, 60]))]))
        if k == 1:
            return diag(_join(header + [f"x{j}" for j in range(3000)], rows))
        if k == 2:
            return diag(b"a," * int(rng.integers(40_000, 200_000)))
        if k == 3:
            rows[r][header.index(col)] = "1" * int(rng.integers(1000, 1_000_000))
            return diag(_join(header, rows))
        if k == 4:
            return diag(_join(header, rows) * 2)
        return diag(_join(header + ["note"], [x + ["y" * 500] for x in rows]))
    if category == "encodings":
        k = int(rng.integers(6))
        raw = _join(header + ["comment"], [x + ["ok"] for x in rows])
        if k == 0:  # latin-1 in an ignored column: accepted
            return diag(raw.replace(b",ok\n", b",caf\xe9\n", 7))
        if k == 1:
            return diag(raw.replace(b"\n", b"\n\xe9", 1))
        if k == 2:
            return diag(raw.decode().encode("utf-16"))
        if k == 3:
            return diag(b"\xef\xbb\xbf" + raw)
        if k == 4:
            return diag(raw.replace(b",ok", b",\x00", 3))
        return diag(raw.replace(b"\n", b"\r\n"))
    if category == "api_actions":
        env_id = str(rng.choice(["simgap/ManipulatorFriction-v0", "simgap/BicycleTire-v0",
                                 "simgap/PacejkaLaneKeeping-v0",
                                 "simgap/YawRateResidualRL-v0"]))
        kind = int(rng.integers(12))
        return Case(category, f"{category}-{i}", api=lambda _d: _env_case(env_id, kind, sub))
    kind = int(rng.integers(8))
    return Case(category, f"{category}-{i}", api=lambda d: _identifier_case(d, kind, sub),
                output="work")


def _env_case(env_id: str, kind: int, rng: np.random.Generator) -> str:
    import gymnasium as gym

    import simgap  # noqa: F401 - registers the ids

    if "Pacejka" in env_id:
        import importlib.util

        if importlib.util.find_spec("highway_env") is None:
            return "accepted"
    env = gym.make(env_id)
    shape = env.action_space.shape
    if kind == 0:
        env.step(np.zeros(shape, dtype=np.float32))  # before reset
    env.reset(seed=int(rng.integers(100)))
    bad = [None, 0.1, "left", np.zeros((1, *shape)), np.zeros(shape, dtype=int),
           np.zeros(shape, dtype=complex), np.full(shape, np.nan), [[0.0] * shape[0]],
           None, np.zeros(shape, dtype=bool), np.full(shape, -np.inf),
           np.zeros((3, 1), dtype=object)][kind]
    for _ in range(3):
        a = rng.uniform(-2, 2, shape).astype(np.float32) if bad is None else bad
        obs = env.step(a)[0]
        if bad is not None:  # every listed bad action must be refused (an EnvError)
            raise AssertionError(f"{env_id} accepted the bad action {a!r:.60}")
        state = obs["state"] if isinstance(obs, dict) else obs
        if not np.all(np.isfinite(np.asarray(state, dtype=float))):
            raise AssertionError(f"non-finite observation after action {a!r}")
    return "accepted"


def _identifier_case(folder: Path, kind: int, rng: np.random.Generator) -> str:
    from simgap.identifiers import load_identifier, make_identifier

    folder = folder / "work"
    folder.mkdir()
    ident = make_identifier(str(rng.choice(["instantaneous", "integral", "minibatch"])), 4, 2,
                            0.002, seed=0)
    p = ident.save(folder / "id.npz")
    with np.load(p, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    names = [k for k in arrays if k != "meta"]
    name = str(rng.choice(names))
    if kind == 0:
        arrays[name] = np.array(["x"] * arrays[name].size)
    elif kind == 1:
        arrays[name] = arrays[name].astype(complex)
    elif kind == 2:
        arrays[name] = np.zeros(int(rng.integers(1, 5)))
    elif kind == 3:
        arrays["meta"] = np.array(str(rng.choice(["[]", "{", "1", '{"format": 3}'])))
    elif kind == 4:
        meta = json.loads(str(arrays["meta"]))
        key = str(rng.choice(sorted(meta)))
        meta[key] = [None, "x", -1, 1e300, [1], {}][int(rng.integers(6))]
        arrays["meta"] = np.array(json.dumps(meta))
    elif kind == 5:
        raw = p.read_bytes()
        p.write_bytes(raw[: int(rng.integers(1, len(raw)))])
        load_identifier(p)
        return "accepted"
    elif kind == 6:
        arrays[name] = np.full_like(arrays[name], np.nan) if arrays[name].dtype.kind == "f" \
            else arrays[name]
    p2 = folder / "id2.npz"
    np.savez(p2, **arrays)
    load_identifier(p2)
    return "accepted"


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every entry under ``root``: file bytes, or None for folders (hidden ones included)."""
    out: dict[str, bytes | None] = {}
    for dirpath, dirs, files in os.walk(root):
        for d in dirs:
            out[os.path.relpath(os.path.join(dirpath, d), root)] = None
        for f in files:
            p = os.path.join(dirpath, f)
            if os.path.islink(p) or not os.path.isfile(p):
                out[os.path.relpath(p, root)] = b"<special>"
                continue
            with open(p, "rb") as fh:
                out[os.path.relpath(p, root)] = fh.read()
    return out


def _touched(before: dict, after: dict, output: str | None) -> list[str]:
    allowed = os.path.normpath(output) if output else None

    def mine(p: str) -> bool:
        return allowed is not None and (p == allowed or p.startswith(allowed + os.sep))

    bad = [p for p, v in before.items() if not mine(p) and after.get(p, "<gone>") != v]
    bad += [p for p in after if p not in before and not mine(p)
            and not (allowed and allowed.startswith(p + os.sep))]
    return bad


def _report_finite(folder: Path, output: str) -> bool:
    p = folder / output / "report.json"
    if not p.is_file():
        return False
    data = json.loads(p.read_text())
    fit = data["fit"]
    vals = fit["nominal"]["rollout_rmse"] + fit["augmented"]["rollout_rmse"]
    return all(v is not None and math.isfinite(v) for v in vals)


def run_case(case: Case, runner, app, timeout: float = CASE_TIMEOUT) -> dict:
    """Run one case in a fresh folder; return its classification and details."""
    from simgap.errors import SimgapError

    with tempfile.TemporaryDirectory(prefix="simgap-fuzz-") as tmp:
        folder = Path(tmp) / "user"
        folder.mkdir()
        for rel, data in case.files.items():
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / rel).write_bytes(data)
        if case.fifo:
            os.mkfifo(folder / case.fifo)
        before = snapshot(folder)
        cwd = os.getcwd()
        os.chdir(folder)
        outcome, detail = "traceback", ""
        try:
            with time_limit(timeout):
                if case.api is not None:
                    try:
                        outcome = case.api(folder)
                    except SimgapError as err:
                        outcome, detail = "rejected", str(err)
                        if "\n" in detail.strip():
                            outcome = "traceback"
                else:
                    res = runner.invoke(app, case.argv)
                    lines = [ln for ln in res.output.strip().splitlines() if ln]
                    detail = lines[-1] if lines else repr(res.exception)
                    if res.exit_code == 2 and len(lines) == 1 and lines[0].startswith(
                            "error:"):
                        outcome = "rejected"
                    elif res.exit_code == 0:
                        if case.argv[0] == "diagnose":
                            out = case.argv[case.argv.index("--out") + 1]
                            ok = _report_finite(folder, out)
                        else:
                            ok = (folder / case.output).is_file()
                        outcome = "accepted" if ok else "traceback"
                    else:
                        detail = f"exit {res.exit_code}: {detail} ({res.exception!r})"[:300]
        except TimeoutError:
            outcome, detail = "hang", f"over {timeout} s"
        except Exception as err:  # noqa: BLE001 - an unexpected exception is the finding
            outcome, detail = "traceback", f"{type(err).__name__}: {err}"[:300]
        finally:
            os.chdir(cwd)
        after = snapshot(folder)
        touched = _touched(before, after, case.output)
        leftovers = [p for p in after if ".simgap-" in os.path.basename(p)
                     and p not in before and not p.endswith(".simgap-output.json")]
    return {"case": case.name, "category": case.category, "outcome": outcome,
            "detail": detail, "touched": touched, "leftovers": leftovers}


def cases(n: int, seed: int = 0) -> list[Case]:
    """``n`` cases cycling over :data:`CATEGORIES` (seeded)."""
    rng = np.random.default_rng(seed)
    return [make_case(CATEGORIES[i % len(CATEGORIES)], rng, i) for i in range(n)]


def summarize(results: list[dict]) -> dict:
    """Counts: cases, rejected, accepted, tracebacks, hangs, user files touched, per category."""
    def count(rs, what):
        return sum(r["outcome"] == what for r in rs)

    per = {c: {k: count([r for r in results if r["category"] == c], k)
               for k in ("rejected", "accepted", "traceback", "hang")} for c in CATEGORIES}
    return {"cases": len(results), "rejected": count(results, "rejected"),
            "accepted": count(results, "accepted"), "tracebacks": count(results, "traceback"),
            "hangs": count(results, "hang"),
            "user_files_touched": sum(len(r["touched"]) for r in results),
            "leftover_temp_files": sum(len(r["leftovers"]) for r in results),
            "per_category": per}
