"""CLI commands of the diagnosis: ``simgap diagnose`` and ``simgap record``.

Registered on the main typer app by :mod:`simgap.cli`. Bad input ends with one line on
stderr (``error: <file>: <what>``) and exit status 2; nothing is left half-written and
nothing of the user's is replaced (:mod:`simgap.outputs`: the output target is checked
before any work, written under temporary names and moved into place when complete).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from simgap.errors import SimgapError
from simgap.outputs import check_file_target, check_folder_target, output_files

EXIT_BAD_INPUT = 2


def _fail(msg: str) -> None:
    typer.echo(f"error: {msg.splitlines()[0] if msg else 'bad input'}", err=True)
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
        recording: Path = typer.Argument(..., help="Recording (.csv or .parquet)."),
        model: str = typer.Option(..., "--model", help="manipulator2dof, bicycle, or "
                                  "path/to/model.py:NAME (see examples/README.md)."),
        params: Path = typer.Option(None, "--params", help="JSON overrides of nominal "
                                    "parameters, e.g. {\"m\": 2.5}."),
        out: Path = typer.Option(None, "--out", help="Report folder (default "
                                 "./simgap-report/<recording stem>/)."),
        figures: bool = typer.Option(True, help="Write the PNG figures."),
    ) -> None:
        """Locate and name the physics a recording has and the nominal model lacks."""
        from simgap.diagnosis.custom import diagnose_custom
        from simgap.diagnosis.pipeline import default_out_dir
        from simgap.diagnosis.pipeline import diagnose as run
        from simgap.diagnosis.report import summary_lines, write_report

        overrides = _load_params(params)
        target = out or default_out_dir(recording)
        inputs = (recording, params, model.rsplit(":", 1)[0] if ":" in model else None)
        try:
            check_folder_target(target, inputs=inputs)
            if ":" in model:  # a user-defined model file (simgap.diagnosis.custom)
                if overrides:
                    _fail(f"{params}: --params applies to built-in models only; set the "
                          f"parameters in {model.rsplit(':', 1)[0]}")
                report = diagnose_custom(model, recording)
            else:
                report = run(recording, model, overrides)
            write_report(report, target, figures=figures, inputs=inputs)
        except SimgapError as err:
            _fail(str(err))
        for line in summary_lines(report.data):
            typer.echo(line)
        typer.echo(f"report: {target / 'report.md'}")

    @app.command()
    def record(
        out: Path = typer.Argument(..., help="Output recording (.csv or .parquet)."),
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
    ) -> None:
        """Generate a recording with concealed effects (closed loop or scripted steering)."""
        from simgap.diagnosis.generate import generate
        from simgap.recordings import write_recording

        if out.suffix.lower() not in (".csv", ".parquet"):
            _fail(f"{out}: unknown file type {out.suffix!r}; use .csv or .parquet")
        targets = [out, out.with_name(out.name + ".truth.json")] if truth else [out]
        kwargs: dict = {"seed": seed}
        if duration is not None:
            kwargs["duration"] = duration
        if model == "bicycle":
            kwargs.update(program=program, vx=vx)
        try:
            for t in targets:
                check_file_target(t)
            effects = [parse_effect(e) for e in effect]
            rec = generate(model, effects, name=out.name, **kwargs)
            with output_files(targets) as tmps:
                write_recording(tmps[0], rec.columns)
                if truth:
                    tmps[1].write_text(json.dumps(rec.meta, indent=2), encoding="utf-8")
        except (SimgapError, ValueError) as err:
            _fail(str(err))
        typer.echo(f"wrote {out} ({rec.n} samples, {len(effects)} hidden effect(s))")
