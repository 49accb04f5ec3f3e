"""CLI commands of the diagnosis: ``simgap diagnose`` and ``simgap record``.

Registered on the main typer app by :mod:`simgap.cli`. Bad input ends with one line on
stderr (``error: <file>: <what>``) and exit status 2; nothing is left half-written and
nothing of the user's is replaced (:mod:`simgap.outputs`: the output target is checked
before any work, written under temporary names and moved into place when complete).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import NoReturn

import typer

from simgap._log import error
from simgap.errors import SimgapError
from simgap.outputs import check_file_target, check_folder_target, output_files

EXIT_BAD_INPUT = 2
#: Exit status of ``diagnose LOG...`` when some logs failed (the others' reports are kept).
EXIT_SOME_FAILED = 1
#: Default output folder of ``diagnose`` with several logs.
DIAGNOSE_BATCH_OUT = Path("simgap-report") / "diagnose"


def _fail(msg: str) -> NoReturn:
    """One ``error:`` line on stderr (:func:`simgap._log.error`), exit status 2."""
    error(msg)
    raise typer.Exit(EXIT_BAD_INPUT)


def _load_params(path: Path | None) -> dict | None:
    if path is None:
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        _fail(f"{path}: file does not exist")
    except (OSError, UnicodeDecodeError) as err:
        _fail(f"{path}: cannot read parameters ({err})")
    except json.JSONDecodeError as err:
        _fail(f"{path}: not valid JSON (line {err.lineno}: {err.msg})")
    if not isinstance(data, dict):
        _fail(f"{path}: expected a JSON object of parameter overrides like {{\"m\": 2.5}}")
    return data


def _diagnose_batch(out: Path, recordings: list[Path], model: str, overrides: dict | None,
                    columns: Path | None, figures: bool, jobs: int, ray: bool | str,
                    inputs: tuple, input_hold: str | None = None) -> None:
    """``diagnose LOG1 LOG2 ...``: one job per log, then OUT/summary.{json,md}."""
    from simgap._log import log
    from simgap.diagnosis.sweep import diagnose_batch
    from simgap.sweeps import progress_bar

    try:
        with progress_bar(len(recordings), "diagnose") as tick:
            res = diagnose_batch(out, recordings, model, params=overrides, columns=columns,
                                 figures=figures, jobs=jobs, ray=ray or None, inputs=inputs,
                                 progress=tick, input_hold=input_hold)
    except SimgapError as err:
        _fail(str(err))
    for f in res["failed"]:
        log(f"failed: {f['recording']}: {f['error']}")
    ok = len(recordings) - len(res["failed"])
    typer.echo(f"{ok} of {len(recordings)} recordings diagnosed; summary: {out / 'summary.md'}")
    if res["failed"]:
        raise typer.Exit(EXIT_SOME_FAILED)


def parse_effect(text: str):
    """Parse ``name[:channel][:k=v,k=v]`` (e.g. ``coulomb_friction:joint2:Fc=0.2``)."""
    from simgap.diagnosis.generate import GeneratorError, InjectedEffect

    parts = [p.strip() for p in text.split(":")]
    params: dict[str, float] = {}
    channel = None
    if parts and "=" in parts[-1]:
        for kv in parts.pop().split(","):
            if "=" not in kv:
                raise GeneratorError(f"effect {text!r}: expected k=v, got {kv!r}")
            k, v = kv.split("=", 1)
            try:
                params[k.strip()] = float(v)
            except ValueError:
                raise GeneratorError(f"effect {text!r}: {k.strip()} = {v!r} is not a "
                                     "number") from None
    if len(parts) == 2:
        channel = parts[1]
    elif len(parts) != 1 or not parts[0]:
        raise GeneratorError(f"effect {text!r}: use name[:channel][:k=v,...]")
    return InjectedEffect(effect=parts[0], channel=channel, params=params)


def register(app: typer.Typer) -> None:
    """Add ``diagnose`` and ``record`` to ``app``."""

    @app.command()
    def diagnose(
        recordings: list[Path] = typer.Argument(..., metavar="LOG...", help="Recording(s) "
                                                "(.csv or .parquet). Several: one report "
                                                "each plus OUT/summary.md (see --jobs)."),
        model: str = typer.Option(..., "--model", help="manipulator2dof, bicycle, "
                                  "path/to/model.py:NAME (see examples/README.md), or an "
                                  "MJCF robot.xml (needs the 'mujoco' extra)."),
        params: Path = typer.Option(None, "--params", help="JSON overrides of nominal "
                                    "parameters, e.g. {\"m\": 2.5}."),
        columns: Path = typer.Option(None, "--columns", help="JSON column map: canonical "
                                     "column -> file column, number or {\"source\", "
                                     "\"scale\", \"offset\", \"constant\", \"despike\"}; "
                                     "unnamed columns keep their names; \"input_hold\": "
                                     "\"zoh\"|\"sample\" says how inputs were logged."),
        input_hold: str = typer.Option(None, "--input-hold", help="How the logged inputs "
                                       "relate to the acting ones: zoh (held until the next "
                                       "sample), sample (point samples) or auto (decided "
                                       "from the data); default: the column map's, else "
                                       "the model's, else auto."),
        out: Path = typer.Option(None, "--out", help="Report folder (default "
                                 "./simgap-report/<recording stem>/; several logs: "
                                 "./simgap-report/diagnose/)."),
        figures: bool = typer.Option(True, help="Write the PNG figures."),
        jobs: int = typer.Option(1, "--jobs", min=1, help="Several logs: parallel jobs "
                                 "(local processes, or Ray CPUs with --ray)."),
        ray: bool = typer.Option(False, "--ray", help="Several logs: run on Ray (extra "
                                 "'ray'): a local instance, or the cluster in RAY_ADDRESS "
                                 "/ --ray-address."),
        ray_address: str = typer.Option(None, "--ray-address", help="Join this Ray cluster "
                                        "(implies --ray; 'auto' finds a running one)."),
    ) -> None:
        """Locate and name the physics a recording has and the nominal model lacks.

        With several LOGs (or --jobs/--ray) each is diagnosed as one job into OUT/<stem>/ and
        OUT/summary.md + summary.json tabulate them (default OUT ./simgap-report/diagnose/).
        Exit status: 0 all diagnosed, 1 some logs failed (each named with its error in the
        summary and on stderr; the others' reports are kept), 2 bad options or a log that
        is missing or not a readable file (nothing run).
        """
        # checked before the numerical modules are imported (seconds), one line each
        from simgap.limits import check_recording_file

        batch = len(recordings) > 1 or jobs > 1 or ray or ray_address is not None
        recording = recordings[0]
        try:  # missing, a folder, a FIFO or device, an overlong header: refused unopened
            for rec in recordings:
                check_recording_file(rec)
        except SimgapError as err:
            _fail(str(err))
        if ":" in model and not Path(model.rsplit(":", 1)[0]).is_file():
            _fail(f"{model.rsplit(':', 1)[0]}: model file not found (--model path.py:NAME)")
        if model.lower().endswith(".xml") and not Path(model).is_file():
            _fail(f"{model}: MJCF file not found (--model robot.xml)")
        from simgap._log import stage
        from simgap.diagnosis.pipeline import default_out_dir

        target = out or (DIAGNOSE_BATCH_OUT if batch else default_out_dir(recording))
        model_file = (model.rsplit(":", 1)[0] if ":" in model
                      else model if model.lower().endswith(".xml") else None)
        inputs = (*recordings, params, columns, model_file)
        try:
            check_folder_target(target, inputs=inputs)
        except SimgapError as err:
            _fail(str(err))
        if input_hold is not None and input_hold not in ("auto", "zoh", "sample"):
            _fail(f"--input-hold must be auto, zoh or sample, got {input_hold!r}")
        overrides = _load_params(params)
        if overrides and model_file is not None:
            _fail(f"{params}: --params applies to built-in models only; set the "
                  f"parameters in {model_file}")
        if batch:
            _diagnose_batch(target, recordings, model, overrides, columns, figures, jobs,
                            ray_address or ray, (params, columns, model_file), input_hold)
            return
        from simgap.diagnosis.report import summary_lines, write_report
        from simgap.diagnosis.sweep import diagnose_any

        try:
            with stage(f"diagnosing {recording.name} against {model}"):
                report = diagnose_any(recording, model, overrides, columns, input_hold)
            with stage(f"writing the report to {target}"):
                write_report(report, target, figures=figures, inputs=inputs)
        except SimgapError as err:
            _fail(str(err))
        except OSError as err:
            _fail(f"{target}: cannot write the report ({err.strerror or err})")
        for line in summary_lines(report.data):
            typer.echo(line)
        if "mjcf" in report.data:
            for line in report.data["mjcf"]["changes"]:
                typer.echo(f"MJCF: {line}")
            typer.echo(f"corrected MJCF: {target / 'augmented_model.xml'}")
        typer.echo(f"report: {target / 'report.md'}")

    @app.command()
    def record(
        out: Path = typer.Argument(None, help="Output recording (.csv or .parquet)."),
        model: str = typer.Option("manipulator2dof", "--model",
                                  help="manipulator2dof or bicycle."),
        effect: list[str] = typer.Option(
            [], "--effect", help="Hidden effect name[:channel][:k=v,...], repeatable, e.g. "
            "coulomb_friction:joint2:Fc=0.2 or tire_saturation:mu=0.7."),
        duration: float = typer.Option(None, help="Length (s); default 20 (arm), 40 (car)."),
        seed: int = typer.Option(0, help="Seed of excitation and noise."),
        program: str = typer.Option("random", help="Bicycle steering: random, slalom, "
                                    "chirp, step."),
        vx: float = typer.Option(20.0, help="Bicycle mean speed (m/s)."),
        truth: bool = typer.Option(True, help="Also write OUT.truth.json with what was "
                                   "injected (the diagnosis never reads it)."),
        list_effects: bool = typer.Option(False, "--list-effects", help="List the effects "
                                          "of --model (channels, parameters with units and "
                                          "defaults) and exit."),
    ) -> None:
        """Generate a recording with concealed effects (closed loop or scripted steering)."""
        from simgap.errors import GeneratorError

        if list_effects:
            from simgap.diagnosis.catalog import effect_table_lines

            try:
                typer.echo("\n".join(effect_table_lines(model)))
            except GeneratorError as err:
                _fail(str(err))
            return
        if out is None:
            _fail("missing the output recording OUT.csv (or use --list-effects)")
        if out.suffix.lower() not in (".csv", ".parquet"):
            _fail(f"{out}: unknown file type {out.suffix!r}; use .csv or .parquet")
        if not out.parent.exists():
            _fail(f"{out.parent}: folder does not exist")
        from simgap.diagnosis.catalog import generator_options, injectable_effects

        try:  # the model name is looked up in the system registry (imports the models)
            injectable_effects(model)
        except GeneratorError as err:
            _fail(str(err))
        targets = [out, out.with_name(out.name + ".truth.json")] if truth else [out]
        kwargs: dict = {"seed": seed}
        if duration is not None:
            kwargs["duration"] = duration
        # options the registered system's generator takes (the bicycle's program and vx)
        kwargs.update(generator_options(model, program=program, vx=vx))
        try:
            for t in targets:
                check_file_target(t)
            effects = [parse_effect(e) for e in effect]
        except SimgapError as err:
            _fail(str(err))
        from simgap._log import stage
        from simgap.diagnosis.generate import generate
        from simgap.recordings import write_recording

        try:
            with stage(f"recording {out.name} ({model}, {len(effects)} hidden effect(s))"):
                rec = generate(model, effects, name=out.name, **kwargs)
                with output_files(targets) as tmps:
                    write_recording(tmps[0], rec.columns, overwrite=True)  # our temp
                    if truth:
                        tmps[1].write_text(json.dumps(rec.meta, indent=2), encoding="utf-8")
        except (SimgapError, ValueError) as err:
            _fail(str(err))
        typer.echo(f"wrote {out} ({rec.n} samples, {len(effects)} hidden effect(s))")
