"""Run one evaluation case: record the rollout once, then test the three identifiers on it.

The plant of every thesis case is independent of the identifiers (the controller and the
steering programs do not use ĝ), so one recording serves all three methods, which see
bit-identical data and start from bit-identical initial weights (same seed).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from simgap.evaluation.cases import METHODS, Case, n_steps_for
from simgap.evaluation.errors import EvaluationError
from simgap.evaluation.metrics import reproducibility_metrics
from simgap.evaluation.reproducibility import (
    ReproducibilityResult,
    Transitions,
    reproducibility_test,
    transitions_from_rollout,
)

#: Metric variants: (window name, frozen-input choice). Combined with every channel map of
#: the case. ("full", "x_bar") with the case's first channel map is the primary definition.
WINDOWS: tuple[str, ...] = ("full", "settled")
FROZEN_INPUTS: tuple[str, ...] = ("x_bar", "state")

Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class CaseResult:
    """Everything one case produced.

    Attributes:
        case: the :class:`~simgap.evaluation.cases.Case`.
        quick: whether the quick (CI) settings were used.
        seed: seed of the env reset and of the identifiers' initial weights.
        duration: run length (s).
        freeze_times: freeze times (s).
        settle_time: start of the "settled" window (s).
        env_description: env and scenario settings.
        transitions: the recording in identifier coordinates.
        results: per method, the :class:`ReproducibilityResult` (absent if it diverged).
        diverged: per method that diverged, the error message.
        configs: per method, the identifier configuration (dict).
        metrics: ``{variant: {method: metrics dict}}``; variant keys are
            ``"<channels>|<window>|<frozen inputs>"``; see :func:`primary_variant`.
    """

    case: Case
    quick: bool
    seed: int
    duration: float
    freeze_times: tuple[float, ...]
    settle_time: float
    env_description: str
    transitions: Transitions
    results: dict[str, ReproducibilityResult]
    diverged: dict[str, str]
    configs: dict[str, dict[str, Any]]
    metrics: dict[str, dict[str, dict[str, Any]]]

    @property
    def primary_variant(self) -> str:
        """Key of the primary metric definition."""
        return primary_variant(self.case)


def primary_variant(case: Case) -> str:
    """``"<first channel map>|full|x_bar"``: the primary metric definition of ``case``."""
    return f"{case.channels[0].name}|full|x_bar"


def record_case(case: Case, *, quick: bool = False, seed: int = 0,
                progress: bool = False, duration: float | None = None
                ) -> tuple[Transitions, str]:
    """Record the rollout of ``case`` and convert it to identifier transitions.

    Args:
        case: the case.
        quick: use the quick run length.
        seed: env reset seed.
        progress: show the rollout's rich progress bar.
        duration: record this many seconds instead (s).

    Returns:
        (transitions, env description). ``transitions.extra`` holds ``obs`` and ``u``.
    """
    if duration is None:
        duration, _, _ = case.settings(quick)
    elif not (duration > 0):
        raise EvaluationError(f"duration must be a positive time in s, got {duration!r}")
    n_steps = n_steps_for(duration, case.dt)
    rec = case.record(n_steps, seed, progress)
    tr = transitions_from_rollout(rec.rollout, rec.model, action_low=rec.action_low,
                                  action_high=rec.action_high)
    tr.extra["u"] = tr.u
    return tr, rec.env_description


def run_case(case: Case, *, quick: bool = False, seed: int = 0,
             methods: tuple[str, ...] = METHODS, progress: Progress | None = None,
             transitions: tuple[Transitions, str] | None = None,
             preset_name: str | None = None) -> CaseResult:
    """Run the reproducibility test of every method on ``case``.

    Args:
        case: the case.
        quick: use the quick settings (shorter run, earlier freeze times).
        seed: seed of the env reset and the identifiers' initial weights.
        methods: identifier kinds to run.
        progress: callback ``progress(task, done, total)``.
        transitions: a recording from :func:`record_case` to reuse (else recorded here).
        preset_name: identifier preset (``"auto"`` or a thesis system); ``None`` = the
            case's thesis preset (``case.system``), as ``simgap reproduce`` uses.

    Returns:
        The :class:`CaseResult`.
    """
    from simgap.identifiers import IdentifierDivergedError, make_identifier, preset

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise EvaluationError(f"seed must be a non-negative integer, got {seed!r}")
    duration, freeze_times, settle = case.settings(quick)
    if progress is not None:
        progress(f"case {case.name}: recording", 0, 1)
    tr, desc = transitions if transitions is not None else record_case(case, quick=quick,
                                                                       seed=seed)
    if progress is not None:
        progress(f"case {case.name}: recording", 1, 1)
    results: dict[str, ReproducibilityResult] = {}
    diverged: dict[str, str] = {}
    configs: dict[str, dict[str, Any]] = {}
    for kind in methods:
        cfg = preset(preset_name or case.system, kind, dt=tr.dt)
        configs[kind] = cfg.to_dict()
        ident = make_identifier(kind, tr.n_states, tr.n_inputs, tr.dt, config=cfg, seed=seed)
        cb = None
        if progress is not None:
            label = f"case {case.name}: {kind}"

            def cb(done: int, total: int, _label: str = label) -> None:
                progress(_label, done, total)

        try:
            results[kind] = reproducibility_test(ident, tr, freeze_times, progress=cb)
        except IdentifierDivergedError as exc:
            diverged[kind] = str(exc)
    metrics: dict[str, dict[str, dict[str, Any]]] = {}
    for ch in case.channels:
        for window in WINDOWS:
            t_start = 0.0 if window == "full" else settle
            for inputs in FROZEN_INPUTS:
                key = f"{ch.name}|{window}|{inputs}"
                metrics[key] = {kind: reproducibility_metrics(res, ch, t_start=t_start,
                                                              frozen_inputs=inputs)
                                for kind, res in results.items()}
    return CaseResult(case=case, quick=quick, seed=seed, duration=duration,
                      freeze_times=tuple(freeze_times), settle_time=settle,
                      env_description=desc, transitions=tr, results=results,
                      diverged=diverged, configs=configs, metrics=metrics)
