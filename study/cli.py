"""The ``study`` command line: list, run, plot and describe named studies.

Only argument parsing and orchestration live here; settings are resolved by ``study.settings``
into a ``study.plan`` and every run goes through ``study.execute``. Every user error is one line
``study: error: ...`` on stderr and exit status 2.

``study --help``, ``study list``, ``study info NAME``, ``study run NAME --help`` and the refusal of a bad
argument import neither numba, dask, xarray nor the studies' modules (tests/study/test_cli_info.py): the
studies' titles, settings and grids come from the catalogue (``study.catalogue``); what runs, opens or
draws a file imports them in the function that needs them.
"""

from __future__ import annotations

import argparse
import errno
import math
import pathlib
import re
import shlex
import sys
import warnings

import numpy as np

from rimroll import _messages
from rimroll.study import checks, cli_text, registry, stopping
from rimroll.study.checks import DEFAULT_TIMEOUT
from rimroll.study.registry import UserError, natural_order
from rimroll.study.setting_table import lookup

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line (no usage dump) and exit 2."""

    def error(self, message):
        match = re.fullmatch(r"argument (--[\w-]+)(?:/[\w-]+)*: expected one argument", message)
        if match:  # `--state -1.57,0,0,0`: argparse takes a value that starts with '-' for an option
            example = "-1.57,0,0,0" if match[1] == "--state" else "-VALUE"
            message += f" (a value that starts with '-' is written with '=': {match[1]}={example})"
        raise UserError(message)


def _folder(text: str) -> str:
    """An ``--out`` folder: not empty (``--out ""`` wrote into the current directory)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name; give a folder, e.g. --out results (. for here)")
    return text


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="study", description="Run and inspect rimroll's named studies.")
    p.add_argument("--version", action=_Version, nargs=0, help="show rimroll's version (and git revision) and exit")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("list", help="list the named studies")
    run = sub.add_parser("run", help="run a named study, write <out>/<name>.nc and .png")
    run.add_argument("name")
    run.add_argument("--quick", action="store_true", help="coarse settings for a fast look")
    run.add_argument("--out", default="results", type=_folder, help="output directory (default: results)")
    run.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUES",
                     help="override a setting or a physical parameter (repeatable); a list a,b,c or a "
                          "range start:stop:num of a sweepable setting becomes an axis of the cube")
    run.add_argument("--backend", default=None, choices=lookup("backend").labels(),
                     help="where solver.simulate runs (same as --set backend=...; studies that simulate only): "
                          "cpu, cuda (one GPU per worker; extra rimroll[gpu]) or auto (the GPU when usable)")
    run.add_argument("--workers", type=cli_text.integer, default=None, help="local threads (default: one per core)")
    run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="run the chunks on an existing dask.distributed cluster, e.g. tcp://host:8786 "
                          "(tls://... with the TLS settings of the dask configuration)")
    run.add_argument("--scheduler-file", default=None, metavar="PATH",
                     help="the cluster whose scheduler wrote PATH (dask scheduler --scheduler-file, dask-jobqueue, "
                          "dask-mpi)")
    run.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                     help="show chunks done/total on stderr (default: when stderr is a terminal)")
    run.add_argument("--force", action="store_true",
                     help="recompute and replace the file even if it holds this run or another one")
    run.add_argument("--timeout", type=cli_text.number, default=DEFAULT_TIMEOUT, metavar="SECONDS",
                     help="bound on waiting for a --scheduler (or its file) and for workers (default: %(default)g s)")
    plot = sub.add_parser("plot", help="re-draw the PNG of an existing results file")
    plot.add_argument("target", help="a study name (meaning <out>/NAME.nc) or a .nc file")
    plot.add_argument("--out", default="results", type=_folder, help="directory holding NAME.nc (default: results)")
    plot.add_argument("--select", action="append", default=[], metavar="DIM=VALUE",
                      help="draw the cube at the value nearest to VALUE of a swept axis DIM (repeatable, or "
                           "DIM=VALUE,DIM=VALUE), e.g. --select j=0.5,mu=1; held on every swept axis, a slice "
                           "is drawn as the section's map; the PNG is named after the selection")
    info = sub.add_parser("info", help="what a study computes, its settings, grid and run time (NAME); "
                                       "dimensions, variables and provenance of a results file (FILE)")
    info.add_argument("file", metavar="NAME|FILE")
    verify = sub.add_parser("verify", help="compare a results file with the stored reference slice of its study")
    verify.add_argument("file")
    verify.add_argument("--reference", default=None, metavar="DIR",
                        help="directory of the reference slices (default: $RIMROLL_REFERENCE_DIR, else the "
                             "slices shipped with rimroll)")
    _trace_parser(sub)
    cross = sub.add_parser("crosscheck", help="the exact reduced solver against the engine on the reference slices "
                                              "(the cells of conservative rolling-only scenes; study.crosscheck)")
    cross.add_argument("names", nargs="*", metavar="STUDY", help="studies to check (default: every study with a slice)")
    cross.add_argument("--reference", default=None, metavar="DIR", help="directory of the reference slices")
    cross.add_argument("--grid", default="default", choices=("default", "quick"), help="which slice (default: default)")
    ref = sub.add_parser("reference", help="stored reference slices (study/reference_slices): build them")
    ref.add_argument("--build", action="store_true", required=True,
                     help="compute the slices (outcome sections at rtol 1e-12, DOP853) and write them")
    ref.add_argument("--out", default=None, type=_folder,
                     help="directory to write (default: a source checkout's study/reference_slices; "
                          "required when rimroll is installed)")
    ref.add_argument("--only", action="append", default=[], metavar="STUDY", help="build only this study's slices")
    ref.add_argument("--grid", action="append", default=[], choices=("default", "quick"),
                     help="build only the slice of this grid: a sub-grid of the default grid, or the whole "
                          "--quick grid (default: both)")
    ref.add_argument("--workers", type=cli_text.integer, default=None, help="local threads (default: one per core)")
    ref.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None)
    p.set_defaults(run_parser=run)
    return p


def _trace_parser(sub) -> None:
    t = sub.add_parser("trace", help="one trajectory: netCDF time series and figure (study.rim_trace)")
    t.add_argument("file", nargs="?", default=None, help="an outcome map (fig11-13, outcome-cube) to pick --at from")
    t.add_argument("--release", default=None, metavar="speed=V,angle=DEG,...",
                   help="a shot (docs/shots.md): its release, speed [m/s] and angle [degree] above the horizontal, "
                        "and any of distance, height, lateral [m], azimuth [degree], backspin, sidespin [1/s]; "
                        "--set then takes the shot's settings (e_rim, mu_rim, e_board, mu_board, v_cap, geometry, "
                        "t_max_shot, max_impacts) and the ball's parameters. A FILE of study shot: pick it with --at "
                        "speed=V,angle=DEG")
    t.add_argument("--state", default=None, metavar="BETA,OMEGA1,OMEGA2,OMEGA3",
                   help="the rolling initial state [rad, 1/s, 1/s, 1/s]; a negative beta is written "
                        "--state=-1.57,0,0,0 (with '=': after a space, argparse takes it for an option)")
    t.add_argument("--at", action="append", default=[], metavar="DIM=VALUE,...",
                   help="the point of FILE, e.g. omega1=2,beta=1.1,scene=slipping (nearest grid point; every axis "
                        "of FILE with more than one value, a swept mu, k_r, k_d, omega2 too, needs one)")
    t.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help=f"a physical parameter ({' '.join(registry.PHYSICAL_KEYS)}); repeatable")
    t.add_argument("--t-max", type=cli_text.number, default=None, help="end of the run [s] (default 20, or the map's)")
    t.add_argument("--rtol", type=cli_text.number, default=1e-10, help="relative tolerance (default 1e-10)")
    t.add_argument("--atol", type=cli_text.number, default=1e-12, help="absolute tolerance (default 1e-12)")
    t.add_argument("--samples", type=cli_text.integer, default=2000,
                   help="time samples (default 2000, plus phase ends)")
    t.add_argument("--periods", type=cli_text.integer, default=0, metavar="N",
                   help="a periodic state: follow the orbit N more periods past the second omega1 zero that "
                        "decides it, to watch it repeat (default 0: end where simulate ends)")
    t.add_argument("--out", default="results", type=_folder, help="output directory (default: results)")
    t.add_argument("--name", default="trace",
                   help="the files' name, <out>/NAME.nc and NAME.png: letters, digits, '-', '_' and '.', not starting "
                        "with '.', no folder; a trailing .nc is dropped (default: trace)")
    t.add_argument("--force", action="store_true", help="replace an existing file of that name")


class _Version(argparse.Action):
    """``--version``: the version and git revision, looked up only when asked for."""

    def __call__(self, parser, namespace, values, option_string=None):
        from rimroll.study.dataset import git_revision, rimroll_version

        rev = git_revision()
        print(f"study (rimroll) {rimroll_version()}" + (f", git {rev}" if rev else ""))
        parser.exit(0)


def _cmd_list(args) -> int:
    from rimroll.study import catalogue

    titles = catalogue.titles()  # without importing a studies module (None: one is not in the catalogue)
    if titles is None:
        titles = {name: registry.get(name).title for name in registry.names()}
    names = natural_order(titles)
    width = max(map(len, names), default=0)
    for name in names:
        print(f"{name:<{width}}  {titles[name]}")
    return 0


def _card(name: str) -> dict:
    """What ``study info NAME`` and ``study run NAME --help`` say about study ``name``: its card in the
    catalogue (no studies module imported), else made from the study itself."""
    from rimroll.study import catalogue
    from rimroll.study.describe import card

    return catalogue.card(name) or card(registry.get(name))


def _draw(study, nc: pathlib.Path, select: dict | None = None) -> pathlib.Path | None:
    """Re-open ``nc`` lazily and save the study's plot next to it as PNG (of a slice: ``select``)."""
    from rimroll.study import io

    if study.plot is None:
        return None
    png = nc.with_suffix(".png")
    with io.open_result(nc, lazy=True) as ds:
        missing = [v.name for v in study.variables if v.name not in ds.data_vars]
        if missing:
            raise UserError(f"cannot plot {nc}: it lacks the variable(s) {', '.join(missing)} of study "
                            f"{study.name}; recompute it with study run {study.name} --force")
        if select:
            from rimroll.study.cubeplots import select as at

            ds = at(ds, select)
            png = nc.with_name(nc.stem + "".join(f"_{k}={_value_name(ds[k].item())}" for k in select) + ".png")
        try:
            fig = study.plot(ds)
        except (ValueError, ArithmeticError, LookupError) as exc:  # a figure these settings cannot make
            raise UserError(f"{nc} holds the result, but its figure cannot be drawn: "
                            f"{' '.join(str(exc).split()) or type(exc).__name__}") from None
    return io.write_figure(fig, png)


def _value_name(value) -> str:
    """A selected value as a file name shows it: a label, or a number with %g."""
    return value if isinstance(value, str) else f"{float(value):g}"


def _selection(words: list[str], ds) -> dict:
    """``--select DIM=VALUE[,DIM=VALUE...]`` words as {dim: float}; a user error names a bad word or
    dimension (``study.cli_text``: several pairs may share one word)."""
    out = {}
    swept = str(ds.attrs.get("swept", "")).split()
    for key, value in cli_text.parse(words, "--select", "DIM=VALUE", "--select j=0.5"):
        if key in out:
            raise UserError(f"--select {key} is given twice ({out[key]:g} and {value}): one value per axis")
        if key not in swept:
            raise UserError(f"--select {key}={value}: expected DIM=VALUE with DIM one of the file's swept axes "
                            f"({', '.join(swept) or 'none: the file is not a cube'})")
        if key in ds.coords and ds[key].dtype.kind in "USO":  # a label axis (geometry): one of its labels
            labels = [str(v) for v in ds[key].values]
            if value not in labels:
                raise UserError(f"--select {key}={value}: VALUE must be one of the file's {key} labels: "
                                f"{', '.join(labels)}")
            out[key] = value
            continue
        try:
            out[key] = cli_text.number(value)
        except ValueError:
            raise UserError(f"--select {key}={value}: VALUE must be a number") from None
        if not math.isfinite(out[key]) and not (key in ds.coords and out[key] in ds[key].values):
            # inf is a value of an axis such as mu (rolling only), where the file holds it
            raise UserError(f"--select {key}={value}: VALUE must be a finite number (or inf where the axis holds it)")
        _check_near_axis(ds, key, value, out[key])
    return out


def _check_near_axis(ds, key: str, text: str, value: float) -> None:
    """A finite --select value must lie on the file's axis (``cubeplots.on_axis``: within half a grid step
    of its ends); beyond, it names no slice of the file (mu=99 drew mu=2)."""
    from rimroll.study import cubeplots

    if key not in ds.coords or not math.isfinite(value):
        return
    coord = np.asarray(ds[key].values, dtype=float)
    if value not in coord and not cubeplots.on_axis(coord, value):
        values = ", ".join(f"{v:g}" for v in coord[:8]) + (" ..." if coord.size > 8 else "")
        raise UserError(f"--select {key}={text}: outside the file's {key} axis ({values}); the nearest grid value "
                        "is taken for a value on the axis")


def _cmd_run(args, command: str) -> int:
    checks.check_workers(args.workers)  # the refusals that need no study first, then a misspelt name: at once
    if args.scheduler and args.scheduler_file:
        raise UserError("give --scheduler ADDRESS or --scheduler-file PATH, not both")
    if args.workers is not None and (args.scheduler or args.scheduler_file):
        raise UserError("--workers is for local runs; a --scheduler cluster has its own workers")
    if not (0 < args.timeout <= 86400):
        raise UserError(f"--timeout must be > 0 and <= 86400 s; got {args.timeout}")
    study = registry.get(args.name)
    from rimroll.study import execute, fanout, run_notices
    from rimroll.study.plan import make_plan

    fanout.check_address(args.scheduler)
    values = cli_text.setting_values(study, list(args.sets) + ([f"backend={args.backend}"] if args.backend else []))
    if args.backend and "backend" not in study.settings:
        raise UserError(f"--backend: study {study.name} does not run solver.simulate (no backend setting)")
    remote = bool(args.scheduler or args.scheduler_file)
    plan = make_plan(study, args.quick, values, local=not remote)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    cluster = execute.Cluster(None, args.workers, args.scheduler, args.scheduler_file, args.timeout)
    outcome = execute.run_to_file(plan, args.out, command, cluster, force=args.force, progress=progress)
    nc, stats = outcome.path, outcome.stats
    if stats is None:
        return _exists(study, nc)
    try:
        png = _draw(study, nc)
    except KeyboardInterrupt as stop:  # the result is complete: say so, not only "interrupted"
        what, status = registry.stopped_by(stop)
        raise run_notices.RunInterrupted(f"{what} while drawing the figure; {nc} is complete ({stats.total} of "
                                      f"{stats.total} chunks); the same command draws the figure", status) from None
    resumed = f" ({stats.resumed} of {stats.total} chunks resumed)" if stats.resumed else ""
    print(f"wrote {nc}" + (f" and {png}" if png else "") + resumed)
    warning = run_notices.status_summary(nc)
    if warning:
        print(f"study: warning: {warning}", file=sys.stderr)
    return 0


def _exists(study, nc: pathlib.Path) -> int:
    png = nc.with_suffix(".png")
    redrawn = _draw(study, nc) if not png.exists() else None
    print(f"study: {nc} exists, not recomputing (use --force to recompute)"
          + (f"; re-drew {redrawn}" if redrawn else ""))
    return 0


def _cmd_plot(args) -> int:
    target = pathlib.Path(args.target)
    if target.suffix == ".nc" or target.is_file():
        nc = target
    else:
        nc = pathlib.Path(args.out) / f"{registry.get(args.target).name}.nc"
    from rimroll.study import io

    ds = io.open_result(nc)
    if ds.attrs["study"] in ("trace", "shot-trace"):
        from rimroll.study import rim_trace as trace

        if ds.attrs["study"] == "shot-trace":
            from rimroll.study import shot_trace as trace
        png = io.write_figure(trace.figure(ds), nc.with_suffix(".png"))
        print(f"wrote {png}")
        return 0
    png = _draw(registry.get(ds.attrs["study"]), nc, _selection(args.select, ds))
    print(f"wrote {png}" if png else f"study {ds.attrs['study']!r} has no plot")
    return 0


def _cmd_info(args) -> int:
    target = pathlib.Path(args.file)
    is_file = target.is_file() or target.suffix == ".nc"
    if not is_file and args.file in registry.known_names():
        from rimroll.study.describe import render

        print("\n".join(render(_card(args.file))))
        return 0
    if not is_file:
        raise UserError(f"{args.file!r} is neither a results file nor a study; "
                        f"studies: {', '.join(natural_order(registry.known_names()))}")
    from rimroll.study import io

    ds = io.open_result(target)
    print(f"{args.file}: {ds.attrs.get('title', '')} [study {ds.attrs['study']}]")
    print("dimensions: " + ", ".join(f"{k}={v}" for k, v in ds.sizes.items()))
    print("coordinates:")
    for name, c in ds.coords.items():
        units = f" [{c.attrs['units']}]" if "units" in c.attrs else ""
        if c.ndim == 0:  # a scalar setting of the run
            values = f"{c.item():.6g}" if c.dtype.kind in "iuf" else str(c.item())
        elif c.dtype.kind in "iuf" and name not in ds.dims and 1 < c.size <= 12:  # one value per scene: each
            values = ", ".join(f"{v:g}" for v in c.values.ravel()) + f" (per {', '.join(c.dims)})"
        elif c.dtype.kind in "iuf":
            values = f"{float(c.min()):.4g} .. {float(c.max()):.4g}"
        else:  # labels (scene, integrator)
            values = ", ".join(str(v) for v in c.values.ravel()[:12]) + (", ..." if c.size > 12 else "")
        print(f"  {name}{units} {c.attrs.get('long_name', '')}: {values}" + (f" ({c.size} points)" if c.ndim else ""))
    print("variables:")
    for name, v in ds.data_vars.items():
        line = f"  {name}({', '.join(v.dims)}) {v.dtype} [{v.attrs.get('units', '?')}] {v.attrs.get('long_name', '')}"
        if "flag_values" in v.attrs:
            pairs = zip(list(v.attrs["flag_values"]), v.attrs["flag_meanings"].split())
            line += "; flags: " + ", ".join(f"{int(k)} {m}" for k, m in pairs)
        print(line)
    if ds.attrs.get("swept"):
        for name in str(ds.attrs["swept"]).split():
            values = ", ".join(f"{v:g}" for v in ds[name].values) if name in ds.coords else "?"
            print(f"swept: {name} = {values}")
    # a parameter that is a coordinate along a dimension (a scene's mu, k_r, k_d) has its values above
    params = [f"{k[6:]}={v}" for k, v in ds.attrs.items() if k.startswith("param_")
              and not (k[6:] in ds.coords and ds[k[6:]].ndim)]
    recorded = [f"{k[8:]}={v}" for k, v in ds.attrs.items() if k.startswith("setting_")]
    print("parameters: " + " ".join(params))
    print("settings: " + " ".join(recorded))
    for key in ("rimroll_version", "git_revision", "created", "history"):
        if key in ds.attrs:
            print(f"{key}: {ds.attrs[key]}")
    return 0


def _cmd_verify(args) -> int:
    """Exit 0: agrees with the reference within tolerance; 1: it does not (or nothing is
    common); 2 (UserError): not a readable rimroll result, or no reference for its study.

    A study has a slice of its default grid and one of its ``--quick`` grid; the file is compared
    with the one sharing the most points with it (the default slice on a tie)."""
    from rimroll.study import compare, io, reference

    ds = io.open_result(pathlib.Path(args.file))
    name = str(ds.attrs["study"])
    paths = reference.candidates(name, args.reference)
    if not paths:
        where = reference.reference_path(name, args.reference).parent
        known = sorted(p.stem for p in where.glob("*.nc"))
        raise UserError(f"no reference slice for study {name!r} in {where} (slices: {', '.join(known) or 'none'})")
    reports = [(compare.compare(ds, io.open_result(path)), path) for path in paths]
    # the slice with most points in common; of slices with none, the one whose settings differ least
    # (a --quick file is told what differs from the quick slice, not the default grid's box size)
    report, path = max(reports, key=lambda rp: (rp[0].n_common, -rp[0].mismatches))  # max keeps the first of equals
    for line in compare.format_report(report, args.file, str(path)):
        print(line)
    return 0 if report.ok else 1


def _cmd_reference(args, command: str) -> int:
    from rimroll.study import reference

    checks.check_workers(args.workers)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    grids = args.grid or reference.GRIDS
    for path in reference.build(args.out, args.only or None, args.workers, command, progress, grids):
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")
    return 0


def _study_help(words: list[str]) -> bool:
    """``study run NAME --help``: the run options, then NAME's settings; True if it printed."""
    if not words or words[0] != "run" or not {"-h", "--help"} & set(words):
        return False
    names = [w for w in words[1:] if not w.startswith("-")]
    if not names or names[0] not in registry.known_names():
        return False
    study = _card(names[0])
    name = study["name"]
    run = _parser().get_default("run_parser")
    print(run.format_help().replace("study run [-h]", f"study run {name} [-h]", 1).rstrip())
    print(f"\nsettings of {name} ({study['title']}); default, --quick value, units (--set KEY=VALUE):")
    print("\n".join(study["settings"]))
    print(f"\nsweepable: {', '.join(study['sweepable']) or 'none'}; `study info {name}` adds the grid and run time")
    return True


def main(argv=None) -> int:
    """Entry point of ``study`` / ``python -m rimroll.study``; returns the exit status."""
    words = sys.argv[1:] if argv is None else list(argv)
    command = shlex.join(["study", *words])
    _ignore_file_size_signal()
    previous = stopping.install()  # SIGTERM: one stop, one line, exit 143 (study.stopping)
    shown = warnings.showwarning
    warnings.showwarning = _one_line_warning
    try:
        with _messages.command_line():  # notices (logging) on stderr, whatever logging the caller set up
            return _main(words, command)
    finally:
        warnings.showwarning = shown
        stopping.restore(previous)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A Python warning during a command (numpy's overflow at extreme settings, a library's deprecation)
    as one line, ``study: warning: RuntimeWarning: overflow encountered in square (steady.py:100)``,
    not Python's two lines with the source."""
    where = f" ({pathlib.Path(filename).name}:{lineno})" if filename else ""
    text = " ".join(str(message).split())
    print(f"study: warning: {category.__name__}: {text}{where}", file=file or sys.stderr)


def _main(words: list[str], command: str) -> int:
    try:
        if _study_help(words):
            return 0
        status = _dispatch(_parser().parse_args(words), command)
        sys.stdout.flush()  # here, so that a closed pipe is caught below, not at exit
        return status
    except (UserError, _backend_error()) as exc:
        message = " ".join(str(exc).split())
        print(f"study: error: {message}", file=sys.stderr)
        return getattr(exc, "exit_status", EXIT_USAGE)
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM (registry.Terminated), a run's (run_notices.RunInterrupted)
        what, status = registry.stopped_by(exc)
        print(f"study: {' '.join(str(exc).split()) or what}", file=sys.stderr)
        return getattr(exc, "exit_status", status)
    except ImportError as exc:  # a lazy import (the figure's backend) that Ctrl-C broke
        if not registry.interrupted(exc):
            raise
        print("study: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `study info FILE | head`: the reader has what it wanted
        _quiet_stdout()
        return 0
    except OSError as exc:
        if exc.errno not in _WRITE_ERRNOS:
            raise
        # e.g. the file size limit or a full disk between the netCDF (written) and its PNG
        where = f" {exc.filename}" if exc.filename else ""
        print(f"study: error: cannot write{where}: {exc.strerror or exc}; free space (or raise the limit) "
              "and run the command again", file=sys.stderr)
        return EXIT_USAGE


_WRITE_ERRNOS = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO}
"""Failures of a write outside a run's own guard (``run_notices.saved_on_stop``): one line, exit 2."""


def _backend_error():
    """``solver.engine.backends.BackendUnavailable``: a missing GPU extra or device, also when a worker of a
    --scheduler cluster reports it (one line, like a UserError)."""
    from rimroll.solver.engine.backends import BackendUnavailable

    return BackendUnavailable


def _traces_a_shot(args) -> bool:
    """Whether ``study trace`` traces a shot (study.shot_trace): ``--release`` given, or FILE is a map of
    study ``shot``."""
    if args.release is not None:
        return True
    if args.file is None or not pathlib.Path(args.file).is_file():
        return False
    try:
        import xarray as xr

        with xr.open_dataset(args.file) as ds:
            return ds.attrs.get("study") == "shot"
    except (OSError, ValueError):
        return False  # study trace says what is wrong with the file


def _dispatch(args, command: str) -> int:
    if args.command == "list":
        return _cmd_list(args)
    if args.command == "run":
        return _cmd_run(args, command)
    if args.command == "plot":
        return _cmd_plot(args)
    if args.command == "verify":
        return _cmd_verify(args)
    if args.command == "reference":
        return _cmd_reference(args, command)
    if args.command == "crosscheck":
        from rimroll.study import crosscheck

        return crosscheck.main(args.names, args.reference, args.grid)
    if args.command == "trace":
        from rimroll.study import rim_trace as trace

        if _traces_a_shot(args):
            from rimroll.study import shot_trace as trace
        return trace.run(args, command)
    return _cmd_info(args)


def _ignore_file_size_signal() -> None:
    """Beyond ``ulimit -f`` a write then fails with EFBIG (reported in one line) instead of SIGXFSZ
    killing the process with a core dump."""
    import signal

    if hasattr(signal, "SIGXFSZ"):
        try:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        except ValueError:  # not the main thread
            pass


def _quiet_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush raises nothing."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
