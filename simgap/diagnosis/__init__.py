"""simgap.diagnosis: where a recording differs from a nominal simulator, and why.

The public API, in one place (submodules are imported on first use, so ``import simgap``
and ``import simgap.diagnosis`` stay cheap)::

    from simgap.diagnosis import diagnose, write_report, ColumnMap, Column

    report = diagnose("log.csv", "bicycle",
                      columns=ColumnMap.of(delta_f=Column(source="wheel_deg", scale=1e-3)))
    write_report(report, "report/")

* :func:`diagnose` -> :class:`Report`: the one entry point, for built-in systems
  (``"manipulator2dof"``, ``"bicycle"``), user models (``"path.py:NAME"`` or the object)
  and ready adapters; :func:`write_report`, :func:`summary_lines` present it;
  :func:`load_augmented` reads the saved ``augmented_model.json`` of any model.
* :func:`generate` and :class:`InjectedEffect`: synthetic recordings with concealed effects.
* :class:`ColumnMap`, :class:`Column`, :class:`RecordingSchema`: how a user's file maps onto
  a system's canonical columns (defined in :mod:`simgap.recordings`);
  :func:`with_columns` attaches a map to a model, :func:`load_model_file` loads
  ``path.py:NAME``.
* :class:`ResidualForm` and :class:`Prepared`: the interface of a residual form and the
  immutable data its ``prepare`` returns (``Report.prepared``).
"""

import sys
import types

from simgap._lazy import lazy_exports

_LAZY = {
    "diagnose": "simgap.diagnosis.pipeline",
    "Report": "simgap.diagnosis.pipeline",
    "make_system": "simgap.diagnosis.pipeline",
    "write_report": "simgap.diagnosis.report",
    "summary_lines": "simgap.diagnosis.report",
    "load_augmented": "simgap.diagnosis.model_io",
    "InjectedEffect": "simgap.diagnosis.generate",
    "ColumnMap": "simgap.recordings",
    "Column": "simgap.recordings",
    "RecordingSchema": "simgap.recordings",
    "with_columns": "simgap.diagnosis.user_models",
    "load_model_file": "simgap.diagnosis.user_models",
    "ResidualForm": "simgap.diagnosis.forms",
    "Prepared": "simgap.diagnosis.forms",
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _LAZY, eager=("generate",))


class _Facade(types.ModuleType):
    """The package's module type: ``simgap.diagnosis.generate`` is the *function*.

    The submodule of the same name would otherwise replace the facade function as soon as it
    is imported (the import system sets the package attribute); the submodule stays
    reachable as ``sys.modules["simgap.diagnosis.generate"]`` and through ``from
    simgap.diagnosis.generate import ...``.
    """

    @property
    def generate(self):  # noqa: D401 - the facade function
        """:func:`simgap.diagnosis.generate.generate` (imported on first use)."""
        import importlib

        return importlib.import_module("simgap.diagnosis.generate").generate

    @generate.setter
    def generate(self, module) -> None:  # the import system binding the submodule
        pass


sys.modules[__name__].__class__ = _Facade
