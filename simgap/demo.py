"""The demo job (``simgap demo`` / ``make demo``): roll out both envs and plot the ground truth.

The demo shows what the envs provide: states, inputs and the true residual g(x, u) (as joint
friction torques and axle-force deviations) for the thesis' scenarios, plus one rendered frame
of each env; then it diagnoses a generated arm recording with a concealed Coulomb friction
(``simgap record`` + ``simgap diagnose`` into ``<out>/diagnosis``) and runs the quick variant
of ``simgap reproduce --case all`` into ``<out>/reproduce`` (report.md, results.json,
figures). ``<out>/index.html`` shows every figure with one line saying what it shows.
Figures are matplotlib PNGs (Agg). Needs only the core install (no torch).
"""

from __future__ import annotations

import html
import json
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from simgap._log import log, progress_lines, stage
from simgap._plotting import legend_outside
from simgap.envs.bicycle import BicycleTireEnv
from simgap.envs.manipulator import ManipulatorFrictionEnv
from simgap.envs.rollout import Rollout, rollout
from simgap.envs.scenarios import (
    FeedbackLinearizationController,
    QuinticReference,
    RandomWaypointReference,
    SteeringProgram,
    chirp,
    slalom,
    step_steer,
)
from simgap.outputs import output_folder, write_file

#: Seconds of simulated manipulator motion per scenario (two back-and-forth thesis cycles).
MANIPULATOR_SECONDS = 8.0
#: The effect concealed in the demo's diagnosed recording (vocabulary name, channel, SI value).
DEMO_HIDDEN_EFFECT = {"effect": "coulomb_friction", "channel": "joint2", "params": {"Fc": 0.3}}
#: Seconds of the demo's diagnosed recording (at the generator's 500 Hz).
DEMO_RECORDING_SECONDS = 20.0

#: One line per figure for index.html: (pattern of the path below ``out``, caption). The
#: first match wins; ``{case}`` is filled from the pattern's group.
FIGURE_CAPTIONS: tuple[tuple[str, str], ...] = (
    (r"manipulator_thesis\.png", "Arm tracking the thesis' periodic quintic reference under "
     "feedback linearisation; bottom: the true friction torque the identifiers must learn."),
    (r"manipulator_waypoints\.png", "Arm on a random-waypoint reference: the same friction "
     "seen over a wider range of joint speeds."),
    (r"bicycle_(step_steer|slalom|chirp)\.png", "Bicycle, {case} steering: states, lateral "
     "acceleration, steering and the true axle-force residual (Magic Formula − linear tires)."),
    (r"bicycle_tire_residual\.png", "Axle-force residual against slip angle over the three "
     "manoeuvres: the saturation curve the identifiers learn."),
    (r"env_frames\.png", "What env.render() draws for each env (rgb_array)."),
    (r"diagnosis/residual_time\.png", "Diagnosis: residual per joint over time against the "
     "noise floor, with the fitted effects' contribution (the concealed Coulomb friction at "
     "joint 2)."),
    (r"diagnosis/residual_vs_variable\.png", "Diagnosis: residual against the variable it "
     "depends on (joint speed for friction), with the fitted effect's curve."),
    (r"diagnosis/simulation\.png", "Diagnosis: held-out simulation from the recorded inputs, "
     "recorded vs nominal vs augmented (nominal + named effect) model."),
    (r"reproduce/case(\w+)_online\.png", "Thesis reproduction, Case {case}: the identifiers' "
     "online estimate against the true residual while they adapt (quick variant)."),
    (r"reproduce/case(\w+)_consistency\.png", "Thesis reproduction, Case {case}: frozen "
     "models' estimate after the freeze time, the thesis' consistency test (quick variant)."),
    (r"reproduce/timing\.png", "Thesis reproduction: time per identifier step of the three "
     "methods (Table 4.6, quick variant)."),
)


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=110)
    return path


def _plot_manipulator(ro: Rollout, title: str, path: Path) -> Path:
    fig = Figure(figsize=(10, 8), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    t = ro.t + (ro.t[1] - ro.t[0] if len(ro.t) > 1 else 0.0)  # time after each step
    ref = ro.info["reference"]
    for j, c in ((0, "tab:blue"), (1, "tab:orange")):
        axes[0].plot(t, ro.next_obs[:, j], color=c, label=f"q{j + 1}")
        axes[0].plot(t, ref[:, j], "--", color=c, alpha=0.7, label=f"q{j + 1} reference")
        axes[1].plot(t, ro.next_obs[:, 2 + j], color=c, label=f"dq{j + 1}")
        axes[2].plot(ro.t, ro.action[:, j], color=c, label=f"tau{j + 1}")
        axes[3].plot(ro.t, ro.info["physical_residual_true"][:, j], color=c,
                     label=f"tau_d{j + 1} = -g[p{j + 1}]")
    axes[0].set_ylabel("joint angle (rad)")
    axes[1].set_ylabel("joint speed (rad/s)")
    axes[2].set_ylabel("applied torque (N·m)")
    axes[3].set_ylabel("true residual\ntau_d (N·m)")
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        legend_outside(ax)
    fig.suptitle(title)
    return _save(fig, path)


def _plot_bicycle(ro: Rollout, env: BicycleTireEnv, title: str, path: Path) -> Path:
    fig = Figure(figsize=(10, 8), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    t_next = ro.t + env.dt
    axes[0].plot(t_next, ro.next_obs[:, 0], label="vy (m/s)")
    axes[0].plot(t_next, ro.next_obs[:, 1], label="r (rad/s)")
    axes[0].set_ylabel("state (m/s, rad/s)")
    ay = env.vx * ro.next_obs[:, 1] + np.gradient(ro.next_obs[:, 0], env.dt)
    axes[1].plot(t_next, ay, color="tab:green", label="a_y = dvy/dt + vx·r")
    axes[1].set_ylabel("lateral accel. (m/s²)")
    axes[2].plot(ro.t, np.degrees(ro.action[:, 0]), label="delta_f")
    axes[2].plot(ro.t, np.degrees(ro.action[:, 1]), "--", label="delta_r")
    axes[2].set_ylabel("steering (deg)")
    res = ro.info["axle_force_residual_true"]
    axes[3].plot(ro.t, res[:, 0], label="Delta_f")
    axes[3].plot(ro.t, res[:, 1], label="Delta_r")
    axes[3].set_ylabel("true residual\naxle force (N)")
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        legend_outside(ax)
    fig.suptitle(f"{title} (vx = {env.vx:g} m/s, mu = {env.true_params.mu:g}, Magic Formula "
                 f"truth vs linear nominal)")
    return _save(fig, path)


def _plot_tire_map(runs: dict[str, tuple[Rollout, BicycleTireEnv]], path: Path) -> Path:
    """Axle-force residual against the nominal slip angle: the curve the identifiers learn."""
    fig = Figure(figsize=(10, 4.5), layout="constrained")
    axes = fig.subplots(1, 2)
    for name, (ro, env) in runs.items():
        p = env.nominal_params
        vy, r = ro.obs[:, 0], ro.obs[:, 1]
        alpha_f = ro.action[:, 0] - (vy + p.lf * r) / env.vx
        alpha_r = ro.action[:, 1] - (vy - p.lr * r) / env.vx
        res = ro.info["axle_force_residual_true"]
        axes[0].plot(np.degrees(alpha_f), res[:, 0], ".", ms=2, label=name)
        axes[1].plot(np.degrees(alpha_r), res[:, 1], ".", ms=2, label=name)
    for ax, axle in zip(axes, ("front", "rear"), strict=True):
        ax.set_xlabel(f"{axle} slip angle (deg)")
        ax.set_ylabel(f"Delta_{axle[0]} (N)")
        ax.set_title(f"{axle} axle: Magic Formula − linear force")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, markerscale=4, loc="best")
    fig.suptitle("True tire-force residual over the manoeuvres")
    return _save(fig, path)


def _plot_frames(frames: list[tuple[str, np.ndarray]], path: Path) -> Path:
    fig = Figure(figsize=(4.2 * len(frames), 4.4), layout="constrained")
    axes = fig.subplots(1, len(frames))
    for ax, (name, img) in zip(np.atleast_1d(axes), frames, strict=True):
        ax.imshow(img)
        ax.set_title(name)
        ax.set_axis_off()
    fig.suptitle("env.render() (render_mode='rgb_array')")
    return _save(fig, path)


def _demo_diagnosis(out: Path, seed: int, duration: float) -> list[Path]:
    """``simgap record`` + ``simgap diagnose`` on an arm recording with a concealed effect."""
    from simgap.diagnosis.generate import InjectedEffect, generate_manipulator
    from simgap.diagnosis.pipeline import diagnose
    from simgap.diagnosis.report import summary_lines, write_report
    from simgap.recordings import write_recording

    hidden = InjectedEffect(**DEMO_HIDDEN_EFFECT)
    with stage(f"diagnosis: recording {duration:g} s of the arm with a concealed "
               f"{hidden.effect} at {hidden.channel}"):
        rec = generate_manipulator([hidden], duration=duration, seed=seed)
    target = out / "diagnosis"
    with stage("diagnosis: simgap diagnose recording.csv --model manipulator2dof"):
        report = diagnose(rec, "manipulator2dof")
        write_report(report, target)
        write_recording(target / "recording.csv", rec.columns)
        truth = json.dumps(rec.meta, indent=2)
        write_file(target / "recording.csv.truth.json",
                   lambda tmp: tmp.write_text(truth, encoding="utf-8"))
    for text in summary_lines(report.data):
        log(f"diagnosis: {text.strip()}")
    return sorted(target.glob("*.png"))


def caption(relpath: str) -> str:
    """The one-line explanation of a demo figure (path relative to the output folder).

    Raises:
        KeyError: no caption matches (every figure the demo writes must have one).
    """
    for pattern, text in FIGURE_CAPTIONS:
        m = re.fullmatch(pattern, relpath)
        if m:
            case = m.group(1).replace("_", "-") if m.groups() else ""
            return text.format(case=case)
    raise KeyError(f"no caption for demo figure {relpath!r}")


def write_index(out: Path, figures: list[Path], *, overwrite: bool = False) -> Path:
    """``out/index.html``: every figure, in order, under its one-line explanation.

    An existing ``index.html`` is replaced only with ``overwrite=True``.
    """
    items = []
    for p in figures:
        rel = Path(p).resolve().relative_to(Path(out).resolve()).as_posix()
        items.append(f'<figure><figcaption><code>{html.escape(rel)}</code>: '
                     f'{html.escape(caption(rel))}</figcaption>'
                     f'<img src="{html.escape(rel)}" alt="{html.escape(rel)}"></figure>')
    links = [(r, t) for r, t in (("diagnosis/report.md", "diagnosis report"),
                                 ("reproduce/report.md", "thesis reproduction report"))
             if (Path(out) / r).exists()]
    page = "\n".join([
        "<!doctype html>", '<html lang="en"><head><meta charset="utf-8">',
        "<title>simgap demo</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
        "figure{margin:2em 0}img{max-width:100%;border:1px solid #ddd}"
        "figcaption{margin-bottom:.5em}</style></head><body>",
        "<h1>simgap demo</h1>",
        "<p>Written by <code>simgap demo</code> (<code>make demo</code>). "
        + " · ".join(f'<a href="{r}">{t}</a>' for r, t in links) + "</p>",
        *items, "</body></html>", ""])
    path = Path(out) / "index.html"
    write_file(path, lambda tmp: tmp.write_text(page, encoding="utf-8"), overwrite=overwrite)
    return path


def run_demo(out: Path, seed: int = 0, *, duration_scale: float = 1.0,
             reproduce: bool = True, diagnosis: bool = True) -> list[Path]:
    """Roll out both envs, diagnose a recording, reproduce the thesis; write PNGs and index.

    Args:
        out: output folder: new, empty, or a previous simgap output (which is replaced);
            written transactionally by :func:`simgap.outputs.output_folder`.
        seed: seed of the env resets, the random-waypoint reference and the recording.
        duration_scale: fraction of each scenario (and of the diagnosed recording) to
            simulate (1 = full; tests use less).
        reproduce: also run ``simgap reproduce --case all --quick`` into ``out/reproduce``
            (its report.md and results.json are written there too).
        diagnosis: also diagnose a generated arm recording with a concealed Coulomb friction
            into ``out/diagnosis`` (report.md, report.json, figures, the recording).

    Returns:
        Paths of the written PNG files (all shown in ``out/index.html``).
    """
    if not 0 < duration_scale <= 1:
        raise ValueError(f"duration_scale must be in (0, 1], got {duration_scale!r}")
    with output_folder(out, kind="demo") as tmp:
        written = _demo(tmp, seed, duration_scale, reproduce, diagnosis)
    final = [Path(out) / p.relative_to(tmp) for p in written]
    for p in final:
        log(f"wrote {p}")
    log(f"wrote {Path(out) / 'index.html'} (open it in a browser: every figure with one line "
        "of explanation)")
    return final


def _demo(out: Path, seed: int, duration_scale: float, reproduce: bool,
          diagnosis: bool) -> list[Path]:
    """The demo's work, written into ``out`` (the temporary folder of :func:`run_demo`)."""
    written: list[Path] = []
    frames: list[tuple[str, np.ndarray]] = []

    manip_cases: list[tuple[str, str, Callable[[], object]]] = [
        ("manipulator_thesis.png", "Arm, thesis quintic reference (T = 2 s), friction eq. 4.7",
         QuinticReference),
        ("manipulator_waypoints.png", f"Arm, random-waypoint reference (seed {seed})",
         lambda: RandomWaypointReference(seed)),
    ]
    n_manip = max(2, int(round(duration_scale * MANIPULATOR_SECONDS / 0.002)))
    for fname, title, make_ref in manip_cases:
        log(f"manipulator: {title} ({n_manip} steps)")
        env = ManipulatorFrictionEnv(render_mode="rgb_array", reference=make_ref())
        ctl = FeedbackLinearizationController(env.nominal_model, env.reference)
        ro = rollout(env, ctl, n_manip, seed=seed, progress=True)
        written.append(_plot_manipulator(ro, title + f", FL control Kp = {ctl.Kp[0]:g}, "
                                         f"Kd = {ctl.Kd[0]:g}", out / fname))
        if not frames:
            frames.append((f"arm at t = {env.t:.1f} s", env.render()))
        env.close()

    programs: list[SteeringProgram] = [step_steer(), slalom(), chirp()]
    runs: dict[str, tuple[Rollout, BicycleTireEnv]] = {}
    for prog in programs:
        n = max(2, int(math.ceil(duration_scale * prog.duration / 0.01)))
        log(f"bicycle: {prog.name} ({n} steps)")
        env = BicycleTireEnv(render_mode="rgb_array")
        ro = rollout(env, prog.act, n, seed=seed, progress=True)
        runs[prog.name] = (ro, env)
        written.append(_plot_bicycle(ro, env, f"Bicycle, {prog.name}",
                                     out / f"bicycle_{prog.name.replace('-', '_')}.png"))
        if prog.name == "step-steer":
            # a frame in the step's hold phase shows saturated (red) vs linear (gray) forces
            env.reset(seed=seed)
            for k in range(min(500, n)):
                env.step(prog(k * env.dt))
            frames.append((f"car at t = {env.t:.1f} s (step-steer)", env.render()))
        env.close()
    written.append(_plot_tire_map(runs, out / "bicycle_tire_residual.png"))
    written.append(_plot_frames(frames, out / "env_frames.png"))
    if diagnosis:
        written.extend(_demo_diagnosis(out, seed, max(4.0, duration_scale
                                                      * DEMO_RECORDING_SECONDS)))
    if reproduce:
        # the quick thesis reproduction (simgap reproduce --case all --quick) into out/reproduce
        from simgap.evaluation.pipeline import reproduce as run_reproduce

        log("reproduce --case all --quick (thesis Tables 4.5/4.6, quick variant)")
        rep = run_reproduce(out / "reproduce", case="all", quick=True, seed=seed, log=log,
                            progress=progress_lines())
        written.extend(Path(p) for p in rep["files"] if str(p).endswith(".png"))
    write_index(out, written)
    return written
