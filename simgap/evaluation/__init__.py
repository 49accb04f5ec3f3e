"""The thesis' evaluation (Chapter 4): reproducibility test, cases, metrics, timing, report.

Public API::

    from simgap.evaluation import (reproducibility_test, transitions_from_rollout,
                                   reproducibility_metrics, Channels, get_case, run_case,
                                   reproduce)

    tr = transitions_from_rollout(rollout, env.unwrapped.nominal_model)   # any env
    res = reproducibility_test(identifier, tr, freeze_times=[180.0, 220.0])
    reproducibility_metrics(res, channels)   # accuracy, consistency(T_f), frozen-vs-online

    run_case(get_case("1"))                    # a thesis case, all three methods
    reproduce("out", case="all", quick=True)   # = ``simgap reproduce``: results.json, report.md

Modules: :mod:`~simgap.evaluation.reproducibility` (the test, Sec. 4.1),
:mod:`~simgap.evaluation.metrics` (the RMSE definitions), :mod:`~simgap.evaluation.cases`
(Cases 1, 2-1, 2-2 and ablations, thesis Table 4.5), :mod:`~simgap.evaluation.runner`,
:mod:`~simgap.evaluation.claims`, :mod:`~simgap.evaluation.timing` (Table 4.6),
:mod:`~simgap.evaluation.figures`, :mod:`~simgap.evaluation.report`,
:mod:`~simgap.evaluation.pipeline` (the command's pipeline).
Heavy modules (matplotlib, envs) are imported lazily.
"""

from __future__ import annotations

from simgap._lazy import lazy_exports

_LAZY = {
    "Transitions": "simgap.evaluation.reproducibility",
    "ReproducibilityResult": "simgap.evaluation.reproducibility",
    "FrozenModel": "simgap.evaluation.reproducibility",
    "reproducibility_test": "simgap.evaluation.reproducibility",
    "transitions_from_rollout": "simgap.evaluation.reproducibility",
    "Channels": "simgap.evaluation.metrics",
    "rmse": "simgap.evaluation.metrics",
    "reproducibility_metrics": "simgap.evaluation.metrics",
    "Case": "simgap.evaluation.cases",
    "get_case": "simgap.evaluation.cases",
    "CaseResult": "simgap.evaluation.runner",
    "record_case": "simgap.evaluation.runner",
    "run_case": "simgap.evaluation.runner",
    "run_timing": "simgap.evaluation.timing",
    "reproduce": "simgap.evaluation.pipeline",
    "EvaluationError": "simgap.evaluation.errors",
}

__all__, __getattr__, __dir__ = lazy_exports("simgap.evaluation", _LAZY)
