"""``cosim sweep SWEEP.yaml``: many runs of a scene in parallel, one row each in a results table.

Registered through the ``cosim.commands`` entry point. Exit codes as for every command: 0 the sweep
is complete (failed runs are rows of the table, not a failure of the sweep, unless ``--strict``),
1 interrupted or stopped by a full disk, when running or writing the table (run the command again to
resume), every point failed, or failed points with ``--strict``, 2 bad input (the sweep file, its
first point's scene, an existing table of another sweep, a table another sweep is writing now, an
unusable backend, ``--workers`` with a remote ``--dask`` (its cluster has its own workers), or, with
``--dry-run``, any point whose scene is invalid).
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from contextlib import nullcontext
from pathlib import Path
from typing import Any

from cosim.cli import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, positive_int, positive_seconds, say_notices, say_warning

SHOWN_POINTS = 10  # --dry-run lists this many points
DRY_RUN_CHECKED = 2000  # --dry-run loads this many points' scenes at most (about 10 ms each)
CORES = os.cpu_count() or 1
MAX_WORKERS_PER_CORE = 4  # --workers at most this many times the cores (a process pool, or a local Dask cluster)


def cmd_sweep(args: argparse.Namespace) -> int:
    from cosim.errors import ScenarioError, one_line
    from cosim.sweep.backends import BackendError, DaskBackend, make_backend
    from cosim.sweep.plan import TABLE_SUFFIXES, load_sweep
    from cosim.sweep.run import LateSignals, run_sweep
    from cosim.sweep.table import MachineLimit, journal_path

    if args.output is not None and args.output.suffix not in TABLE_SUFFIXES:
        print(f"error: cosim sweep: -o {args.output}: must name a .csv or .parquet file", file=sys.stderr)
        return EXIT_BAD_INPUT
    # the workers of a remote cluster are its own: --workers starts none there (it was ignored without a
    # word), so it is refused before the sweep file is read or the scheduler reached
    if args.dask not in (None, "local") and args.workers is not None:
        print(f"error: cosim sweep: --workers {args.workers} with --dask {args.dask}: the Dask cluster there runs "
              "the sweep on its own workers, which --workers does not set (it counts the workers of a process "
              "pool or of --dask local); leave out --workers", file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.dask in (None, "local") and args.workers is not None and args.workers > MAX_WORKERS_PER_CORE * CORES:
        print(f"error: cosim sweep: --workers {args.workers}: at most {MAX_WORKERS_PER_CORE * CORES} on this "
              f"machine's {CORES} cores ({MAX_WORKERS_PER_CORE} a core: each worker is a process with its own copy "
              "of the simulation)", file=sys.stderr)
        return EXIT_BAD_INPUT
    try:
        sweep = load_sweep(args.sweep, overrides=args.set or [], output=args.output)
        say_notices(sweep.notices)
        if args.record:
            sweep.record = True
        if args.run_timeout is not None:
            sweep.run_timeout_s = args.run_timeout
        if args.dry_run:
            checked, bad = _check_points(sweep, progress=not args.quiet)
            refused = _output_refused(sweep, fresh=args.fresh)
            # a point that makes no scene would be a failed row, an output the run refuses stops it at
            # once: the sweep is not ready to run as it is, and its first line does not say "ok"
            verdict = (f"{len(bad)} of {checked} points checked are invalid" if bad
                       else "its output would be refused" if refused else "ok")
            print(f"{args.sweep}: {verdict} - {sweep.describe()}")
            print(f"  scene: {sweep.scene_source}; table: {sweep.output} ({len(sweep.columns)} columns)")
            print(f"  metrics: {', '.join(sweep.metrics) or 'none'}")
            bound = "" if sweep.run_timeout_s is None else f"; stopped after {sweep.run_timeout_s:g} s of wall time"
            print(f"  every run: {' '.join(sweep.fixed) or 'the scene as it is'}{bound}")
            for point in sweep.points[:SHOWN_POINTS]:
                own = " ".join(point.overrides[len(sweep.fixed):])
                print(f"  #{point.index} {point.point_id}: {point.problem or own}")
            if len(sweep.points) > SHOWN_POINTS:
                print(f"  ... {len(sweep.points) - SHOWN_POINTS} more")
            some = f" (the first {checked} of {len(sweep.points)})" if checked < len(sweep.points) else ""
            print(f"  {checked - len(bad)} of {checked} points checked make valid scenes{some}")
            for point, why in bad[:SHOWN_POINTS]:
                print(f"  invalid #{point.index} {point.point_id}: {why}")
            if len(bad) > SHOWN_POINTS:
                print(f"  ... {len(bad) - SHOWN_POINTS} more invalid points")
            if bad:
                print(f"error: {args.sweep}: {len(bad)} of {checked} points checked make no valid scene (listed "
                      "above); each would be a failed row", file=sys.stderr)
                return EXIT_BAD_INPUT
            if refused:  # what the run would refuse at once: said now, not as "ok"
                print(f"error: {sweep.output}: {refused}", file=sys.stderr)
                return EXIT_BAD_INPUT
            return EXIT_OK
        # Dask's own log lines (tracebacks of what the sweep says in one line) only with --debug, which
        # the command line's parser takes out before the command sees its arguments
        backend = make_backend(args.dask, args.workers, quiet="--debug" not in sys.argv[1:])
    except ScenarioError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    complete = False  # every point of the sweep run, its table and figure written
    try:  # the backend is closed whatever ends this, a Ctrl-C while a Dask cluster starts included
        if isinstance(backend, DaskBackend):
            # started here, so that a cluster out of reach is said before the table is touched; a local
            # one of no more workers than the sweep has points (the pool limits itself to those left)
            backend.limit(len(sweep.points))
            try:
                backend.start()
            except BackendError as exc:
                print(f"error: {one_line(str(exc))}", file=sys.stderr)
                return EXIT_BAD_INPUT
            for line in backend.mismatched_versions():
                print(f"warning: Dask worker {line}; results may differ from a local run", file=sys.stderr)
        command = shlex.join(["cosim", *sys.argv[1:]]) if sys.argv[1:] else f"cosim sweep {args.sweep}"
        table = journal_path(sweep.output)
        resumed = table.exists() and not args.fresh

        def resuming(already: int) -> None:  # said once the table is found to be this sweep's
            if already == len(sweep.points):
                print(f"{table} holds every point of this sweep: nothing to run (--fresh runs them again)",
                      file=sys.stderr)
            else:
                print(f"resuming {table}: its {already} points are skipped (--fresh starts over)", file=sys.stderr)

        outcome = run_sweep(sweep, backend=backend, fresh=args.fresh, progress=not args.quiet,
                            figure=not args.no_figure, command_line=command,
                            on_resume=resuming if resumed else None)
        complete = outcome.complete
    except ScenarioError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except MachineLimit as exc:  # the disk full: not the input's fault, and the same command resumes
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    finally:
        # a complete sweep's workers closing, as its table's writing; any other's as before
        with LateSignals(outcome.late_signal) if complete else nullcontext() as late:
            backend.close()
    print(outcome.summary())
    late_signal = late.seen if late is not None else None
    if late_signal is not None and outcome.complete:
        print(f"  {late_signal} came as the sweep finished: it was let finish (its table"
              f"{' and figure' if outcome.figure is not None else ''} whole)")
    for notice, label in outcome.notices.items():  # a later point's (the first point's were said)
        if notice not in sweep.notices:
            say_warning(f"{notice} (point {label}, and any other like it)")
    if outcome.complete and sweep.figure is not None and outcome.figure is None and not args.no_figure:
        print("  no figure: matplotlib is not installed (pip install 'cosim[viz]')")
    if not outcome.complete:  # a script reading standard error hears of it as of any other failure
        print(f"error: cosim sweep: {outcome.stopped_line()}", file=sys.stderr)
        return EXIT_FAILED
    failed = outcome.counts.get("failed", 0)
    if outcome.total and failed == outcome.total:
        # nothing came of the sweep: a script that goes on to read its table must hear of it
        print(f"error: every one of the sweep's {outcome.total} points failed (the table's status and reason "
              "columns say why)", file=sys.stderr)
        return EXIT_FAILED
    if args.strict and outcome.failures:
        print(f"error: {len(outcome.failures)} points failed (--strict)", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _check_points(sweep: Any, progress: bool = True) -> tuple[int, list[tuple[Any, str]]]:
    """--dry-run: load each point's scene (the first DRY_RUN_CHECKED; about 10 ms each), as a run would
    find them one by one (failed rows); (how many were checked, each invalid point with why). With
    ``progress``, a bar on standard error while they are checked (2,000 took 19 s without a word)."""
    from cosim.errors import ScenarioError
    from cosim.progress import work_progress
    from cosim.scenario import loads

    checked = sweep.points[:DRY_RUN_CHECKED]
    bad = []
    shown = work_progress(len(checked), desc="checking the points' scenes", unit="point", leave=False,
                          shown=progress and len(checked) >= PROGRESS_FROM)
    for point in checked:
        why = point.problem
        if why is None:
            try:
                loads(sweep.scene_text, sweep.scene_source, list(point.overrides))
            except ScenarioError as exc:
                why = "invalid scene: " + "; ".join(exc.problems)
        if why:
            bad.append((point, why))
        shown.update(1)
    shown.close()
    return len(checked), bad


PROGRESS_FROM = 100  # points: fewer are checked within a second or so, without a bar


def _output_refused(sweep: Any, fresh: bool) -> str:
    """--dry-run: why the run would refuse its output at once ('' if it would not): a folder where the
    table goes, a file where its folder goes, side files of another table, a Parquet table without its
    journal, or a table of another sweep to resume (the dry run said ok, and the run then exited 2)."""
    import json

    from cosim.sweep.table import journal_path, meta_path, no_record, not_this_sweeps, refused_output

    output = Path(sweep.output)
    for parent in (output.parent, *output.parent.parents):
        if parent.exists():
            if not parent.is_dir():
                return f"cannot be written: {parent} is a file, not a folder"
            break
    if output.is_dir():
        return "is a folder, not a results table: give -o a .csv or .parquet file name"
    refused = refused_output(output, fresh)
    if refused or fresh or not journal_path(output).exists():
        return refused
    try:
        record = json.loads(meta_path(output).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return no_record(meta_path(output))
    foreign = not_this_sweeps(record, sweep.fingerprint(), sweep.columns) if isinstance(record, dict) else ""
    return foreign or _strangers(journal_path(output), {point.point_id for point in sweep.points})


def _strangers(journal: Path, known: set[str]) -> str:
    """Why the run would refuse to resume ``journal`` for holding rows of points this sweep has not
    (an axis that lost values: the dry run said ok and the run exited 2), read without changing it;
    '' if it holds none or cannot be read here (the run then says what is wrong with it)."""
    import csv

    from cosim.sweep.table import strangers_said

    try:
        with open(journal, newline="", encoding="utf-8") as f:
            strangers = [row.get("point_id") for row in csv.DictReader(f)
                         if row.get("point_id") and row.get("point_id") not in known]
    except (OSError, ValueError, csv.Error):
        return ""
    return strangers_said(strangers) if strangers else ""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``cosim sweep`` to the CLI."""
    p = subparsers.add_parser(
        "sweep", help="run a scene over a grid or random samples of its parameters, in parallel",
        description="Run a scene over parameter axes (a sweep file), on all cores or a Dask cluster; one "
                    "row per run in a CSV (or Parquet) table, resumed if it exists, plus a summary figure.")
    p.add_argument("sweep", help="sweep YAML file (base scene + axes)")
    p.add_argument("-o", "--output", type=Path, help="results table, .csv or .parquet (default: the file's "
                   "output:, else runs/<name>.csv)")
    p.add_argument("--workers", type=positive_int, metavar="N",
                   help="worker processes (default: all cores; with --dask local: the cluster's workers; "
                        "refused with a remote --dask, whose cluster has its own)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://HOST:PORT of its scheduler, or 'local' for a "
                        "LocalCluster on this machine (needs the dask extra)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a value of the base scene for every run (repeatable)")
    p.add_argument("--fresh", action="store_true", help="discard an existing table instead of resuming it")
    p.add_argument("--record", action="store_true", help="write an MCAP per run into <output stem>_runs/")
    p.add_argument("--run-timeout", type=positive_seconds, metavar="SECONDS",
                   help="stop a run still going after this much wall time; its row says failed, timed out "
                        "(default: the sweep file's run_timeout, else no bound)")
    p.add_argument("--no-figure", action="store_true", help="do not draw the summary figure")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 if any run failed (without it, only if every run failed)")
    p.add_argument("--dry-run", action="store_true",
                   help="validate the sweep and every point's scene (the first 2000), and list the points; run "
                        "nothing; exit 2 if any point is invalid")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)
