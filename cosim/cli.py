"""The ``cosim`` command line.

Exit codes: 0 ok, 1 the simulation failed (or was interrupted), 2 bad input (scene, recording or
arguments). Bad input is reported in plain lines on stderr, never as a traceback, and leaves no file.

:func:`main` is the one error boundary of every command, the built-in ones and those added through
the ``cosim.commands`` entry points (sweep, plot, render, bench): whatever escapes a command becomes
one line on stderr naming what went wrong and where, with exit code 1 (the run failed, or an error
inside cosim) or 2 (bad input: a scene, a recording, an argument, a missing optional extra);
``--debug`` (anywhere on the command line) shows the traceback as well.
"""

from __future__ import annotations

import signal
import sys
import warnings

try:
    import argparse
    import math
    import os
    import re
    import shlex
    from collections.abc import Callable
    from pathlib import Path
    from typing import Any

    from cosim.errors import (
        NO_ROOM,
        CosimError,
        RecordingError,
        ScenarioError,
        counted,
        ending_signals,
        one_line,
        quiet_interrupts,
    )
    from cosim.timebase import NS_PER_S, exact_seconds
except KeyboardInterrupt:  # Ctrl-C while the command line itself loads: the same one line as later
    sys.stderr.write("error: cosim: interrupted (Ctrl-C)\n")
    raise SystemExit(1) from None

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
QUIET_HELP = "no progress bar, and no notice that the kernels are being compiled"  # (run, replay)


class _Parser(argparse.ArgumentParser):
    """argparse that exits with the bad-input code 2 and a one-line message."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"error: {self.prog}: {message}\n")

    def _get_value(self, action: argparse.Action, arg_string: str) -> Any:
        # An empty value for an option that takes any text (plot -o '', replay --component '', bench
        # accuracy -o '') quietly meant its default, everything, or the working folder. Refused here,
        # for every command and plug-in (their parsers are this class); an option with its own type
        # (run -o, --until) says it in its own words.
        if action.option_strings and action.type in (None, str, Path) and not arg_string.strip():
            hint = "" if action.required else " (leave the option out for its default)"
            raise argparse.ArgumentError(action, f"expected a value, got an empty one{hint}")
        return super()._get_value(action, arg_string)


def number_arg(kind: type[int] | type[float], what: str, *, above: float | None = None,
               at_least: float | None = None, at_most: float | None = None, unit: str = "") -> Callable[[str], Any]:
    """An argparse type reading ``kind`` with an optional bound, for every subcommand's options;
    a bad value is a one-line error naming what was expected and what was given."""
    def parse(text: str) -> Any:
        try:
            if "_" in text:  # Python's 1_0 is 10; a scene's YAML numbers (and --set) refuse it
                raise ValueError(text)
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if kind is float and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"expected a finite number ({what}), got {text}")
        if above is not None and not value > above:
            raise argparse.ArgumentTypeError(f"must be > {above:g}{unit}, got {text}")
        if at_least is not None and not value >= at_least:
            raise argparse.ArgumentTypeError(f"must be >= {at_least:g}{unit}, got {text}")
        if at_most is not None and not value <= at_most:
            raise argparse.ArgumentTypeError(f"must be <= {at_most:g}{unit}, got {text}")
        return value
    return parse


positive_int = number_arg(int, "a whole number", at_least=1)
positive_number = number_arg(float, "a number", above=0)
seconds = number_arg(float, "seconds")
positive_seconds = number_arg(float, "seconds", above=0, unit=" s")
_time_since_start = number_arg(float, "seconds", at_least=0, unit=" s")


MIN_LIVE_SPEED = 1e-6  # the slowest pace --live-speed takes: a millionth of real time


def _live_speed(text: str) -> float:
    """--live-speed: 0 (unpaced) or a pace of at least MIN_LIVE_SPEED times real time (1e-300 waited
    past what a clock can say and failed the run with an internal error)."""
    value = number_arg(float, "a number", at_least=0)(text)
    if 0 < value < MIN_LIVE_SPEED:
        raise argparse.ArgumentTypeError(f"must be 0 (unpaced) or at least {MIN_LIVE_SPEED:g} (a millionth of real "
                                         f"time), got {text}")
    return value


def _seconds_arg(text: str) -> int:
    """A time [s] >= 0 as integer nanoseconds, at most the longest time a recording holds."""
    from cosim.scenario import MAX_TIME_NS
    from cosim.timebase import seconds_to_ns

    seconds = _time_since_start(text)
    if seconds * NS_PER_S > MAX_TIME_NS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_TIME_NS / NS_PER_S:.3g} s, got {text}")
    try:  # refused as a scene's times are, not rounded: 1.5 ns ran as 2 ns and was said to be 2e-09 s
        return seconds_to_ns(seconds)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number of nanoseconds, got {text} s") from None


def run_until_ns(text: str) -> int:
    """``cosim run --until``: as :func:`_seconds_arg`, and later than t = 0 (a run of no time would do
    nothing). It becomes the scene's ``until`` (an override), whose rules then hold: a time shorter than
    one base step is refused (exit 2, "until: must be at least one base step"), and one between two steps
    runs to the next whole step."""
    if not seconds(text) > 0:  # one rule for 0 and below (-1 was told "must be >= 0 s", then 0 refused)
        raise argparse.ArgumentTypeError(f"must be later than 0 s (a run of no time), got {text}")
    return _seconds_arg(text)


def _live_address(text: str) -> str:
    """``--live [HOST:]PORT`` (or ``HOST``), checked before anything runs: a port outside 0..65535
    is bad input."""
    from cosim.params import whole_digits

    if text.count(":") > 1 and not text.strip().startswith("["):
        # an IPv6 address has colons of its own: ::1 would read as host ':' and port 1
        raise argparse.ArgumentTypeError(f"write an IPv6 address in brackets, [ADDRESS]:PORT (e.g. [::1]:8765), "
                                         f"got {text!r}")
    host, sep, port = text.strip().rpartition(":")
    if not text.strip() or (sep and not whole_digits(port)):
        raise argparse.ArgumentTypeError(f"expected [HOST:]PORT, got {text!r}")
    if whole_digits(port) and not 0 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(f"the port must be in 0..65535, got {port}")
    if not sep and not whole_digits(port):
        host = port  # HOST alone
    if host and not _HOST.fullmatch(host.strip("[]")):
        raise argparse.ArgumentTypeError(f"{host!r} is not a host name or address (letters, digits, '-', '.'; "
                                         "or an IP address)")
    return text


# a host name (RFC 1123 labels), an IPv4 address, or an IPv6 one (hex digits and colons, maybe bracketed)
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?(\.[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*"
                   r"|[0-9A-Fa-f:.]+")


def file_name(text: str, example: str, empty_hint: str = "") -> str:
    """A file's name given on the command line (``example``: one to show), checked before anything
    runs: not empty, and not ending in a separator, which names a folder and would be written as a
    file of that name."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a file name, e.g. {example}, got an empty one{empty_hint}")
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text!r} names a folder; give the file's name, e.g. "
                                         f"{text}{Path(example).name}")
    return text


def _output_path(text: str) -> str:
    """``-o FILE`` of a recording: an empty name would silently mean the default one."""
    return file_name(text, "runs/run.mcap", " (leave -o out for the default)")


def _markdown_path(text: str) -> Path:
    """``cosim components --markdown FILE``: a .md file, as the page replaces whatever FILE held (a
    scene's YAML, a recording)."""
    name = file_name(text, "docs/components.md")
    if Path(name).suffix.lower() != ".md":
        raise argparse.ArgumentTypeError(f"{text!r} is not a .md file; the reference page replaces the file it is "
                                         "written to, so it must be one named *.md, e.g. docs/components.md")
    return Path(name)


def _until_override(until_ns: int) -> str:
    """``--until`` as the scene override ``until=T``: a run's end is then kept with its recording
    (among its overrides), and a restart from it (``replay --from``) runs to that end, not to the
    scene file's own until."""
    return f"until={until_ns / NS_PER_S!r}"


def _default_output(scene_path: str, name: str, overrides: list[str]) -> Path:
    """runs/<scene>.mcap; a run with --set (or --until, --record, --record-every, --perf: what the CLI
    turns into ``overrides``) gets its own name (runs/<scene>-set-<hash>.mcap, the hash of its
    overrides), so that a variant never replaces the scene's own recording."""
    stem = name or Path(scene_path).stem
    if overrides:
        stem = f"{stem}-set-{_overrides_digest(overrides)}"
    return Path("runs") / f"{stem}.mcap"


def _overrides_digest(overrides: list[str]) -> str:
    """Eight hex digits naming a list of overrides: a variant's recording is named by them."""
    import hashlib

    return hashlib.sha256("\n".join(overrides).encode()).hexdigest()[:8]


def _record_overrides(args: argparse.Namespace) -> list[str]:
    sets = list(args.set or [])
    if getattr(args, "record", None) is not None:
        patterns = [p.strip() for p in args.record.split(",") if p.strip()]
        if not patterns:  # ',,' or '': no channel named, which would record none without a word
            raise ScenarioError([f"--record {args.record!r}: names no channel (give comma-separated "
                                 "globs such as '/stone/*,/coupler/*')"], "cosim")
        sets.append(f"record.channels=[{', '.join(repr(p) for p in patterns)}]")
    if getattr(args, "record_every", None):
        sets.append(f"record.every={args.record_every}")
    return sets


def _prestart_writer(command: str | None, argv: list[str]) -> None:
    """``cosim run`` that records: start the recording's writer process before anything else loads,
    so that it starts, and imports what it makes the viewer channels with, while this process
    imports, loads the scene and its kernels (:func:`cosim.record.writer.prestart`); a short run
    would otherwise wait for it at its end. Not for ``--no-record`` or ``--help``."""
    # (argparse takes an unambiguous abbreviation, --no-rec, as the option itself)
    if command != "run" or any(a in ("-h", "--help") or (len(a) > 5 and "--no-record".startswith(a)) for a in argv):
        return
    from cosim.record.writer import prestart
    from cosim.view.channels import RECIPE_MODULE

    prestart(preloads=(RECIPE_MODULE,))


def cmd_run(args: argparse.Namespace) -> int:
    from cosim.runner import format_summary, run_scene
    from cosim.scenario import load

    if args.no_record:
        _refuse_recording_options(args)
    overrides = _record_overrides(args)
    if args.until is not None:
        overrides.append(_until_override(args.until))
    scene = load(args.scene, overrides=overrides)
    say_notices(scene.notices)
    # a variant (--set, --until, --record, --record-every, --perf) never replaces the scene's own recording
    variant = [*overrides, *(["--perf"] if args.perf else [])]
    output = None if args.no_record else (Path(args.output) if args.output else
                                          _default_output(args.scene, scene.name, variant))
    command = shlex.join(["cosim", *sys.argv[1:]]) if sys.argv[1:] else "cosim run"
    if args.live is None and (args.live_speed is not None or args.live_linger is not None):
        given = "--live-speed" if args.live_speed is not None else "--live-linger"
        raise ScenarioError([f"{given} without --live: it paces or keeps a live view, and there is none; "
                             "add --live [HOST:]PORT"], "cosim run")
    live_speed = 1.0 if args.live_speed is None else args.live_speed
    linger = (math.inf if args.live_linger is None else args.live_linger) if args.live is not None else 0.0
    outcome = run_scene(scene, output, until_ns=args.until, command_line=command,
                        progress=not args.quiet, perf=args.perf, live=args.live, live_speed=live_speed,
                        keep_live=linger > 0, before_run=_run_begins)
    print(format_summary(scene, outcome), flush=True)
    if outcome.live is not None:  # the finished run stays on the server until Ctrl-C (or --live-linger)
        if outcome.result.status == "interrupted":  # a Ctrl-C during the run meant: stop
            outcome.live.close()
        else:
            outcome.live.linger(linger)
    if outcome.failed:
        print(f"error: {one_line(outcome.result.reason)}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _refuse_recording_options(args: argparse.Namespace) -> None:
    """``--no-record`` with an option that shapes the recording (its file, channels, thinning, /perf):
    the option would be dropped without a word; bad input, said in one line."""
    if args.output and not (args.record is not None or args.record_every or args.perf):
        raise ScenarioError([f"--no-record and -o {args.output}: a run either records into a file or does not; "
                             "give one of them"], "cosim run")
    given = [(f"-o {args.output}", "names the recording's file") if args.output else None,
             (f"--record {args.record}", "chooses the recorded channels") if args.record is not None else None,
             (f"--record-every {args.record_every}", "thins the recorded messages") if args.record_every else None,
             ("--perf", "adds the wall-clock /perf/tick channel to the recording") if args.perf else None]
    given = [g for g in given if g is not None]
    if given:
        flags = ", ".join(flag for flag, _ in given)
        what = "; ".join(f"{flag} {why}" for flag, why in given)
        raise ScenarioError([f"--no-record and {flags}: a run either records or does not, and {what}; "
                             "give one or the other"], "cosim run")


def say_notices(notices: list[str]) -> None:
    """A loaded scene's notices (``Scene.notices``), one warning line each."""
    for notice in notices:
        say_warning(notice)


def say_warning(text: str, file: Any = None) -> None:
    """``warning: TEXT`` on one line, on stderr (or ``file``), at once."""
    print(f"warning: {_one_line(text)}", file=sys.stderr if file is None else file, flush=True)


def cmd_validate(args: argparse.Namespace) -> int:
    from cosim.scenario import load

    scene = load(args.scene, overrides=args.set or [])
    say_notices(scene.notices)
    if scene.record.channels is not None:
        from cosim.runner import check_channel_patterns

        check_channel_patterns(scene, perf=True)  # (a run may add /perf/tick with --perf)
    print(f"{one_line(args.scene)}: ok - scene {scene.name!r}: {counted(len(scene.components), 'component')}, "
          f"{counted(len(scene.connections), 'connection')}, dt = {exact_seconds(scene.dt_ns)} s, "
          f"until = {exact_seconds(scene.until_ns)} s")
    print(f"  order within a tick: {' -> '.join(scene.order)}")
    for name in scene.order:
        cfg = scene.components[name]
        print(f"  {name}: {cfg.type_name}, every {cfg.every} ({exact_seconds(cfg.every * scene.dt_ns)} s), "
              f"on_unstable {cfg.on_unstable}")
    for conn in scene.connections:
        print(f"  {conn}")
    return EXIT_OK


def cmd_components(args: argparse.Namespace) -> int:
    from cosim.record.output import written_whole
    from cosim.registry import project_types, registered, type_info, type_text, types_page

    unknown = [info.problem for info in map(type_info, args.types) if info.problem and info.target not in registered()]
    if unknown:
        raise ScenarioError(unknown, "cosim components")
    if args.markdown is not None:
        chosen = args.types or project_types()
        with written_whole(args.markdown) as tmp:
            tmp.write_text(types_page(chosen), encoding="utf-8")
        print(f"wrote {args.markdown}: {len(chosen)} component type{'' if len(chosen) == 1 else 's'}")
        return EXIT_OK
    if not args.types:
        for names in sorted(registered().values()):
            also = f" (also: {', '.join(names[1:])})" if names[1:] else ""
            info = type_info(names[0])
            print(f"{names[0]}{also}: {info.summary or 'unavailable: ' + one_line(info.problem)}")
        print("`cosim components TYPE` lists a type's parameters, ports and messages")
        return EXIT_OK
    infos = [type_info(name) for name in args.types]
    print("\n\n".join("\n".join(type_text(info)) for info in infos))
    return EXIT_OK


def cmd_inspect(args: argparse.Namespace) -> int:
    from cosim.record.describe import describe_recording
    from cosim.record.reader import Recording

    print(describe_recording(Recording(args.recording)))
    return EXIT_OK


def cmd_repair(args: argparse.Namespace) -> int:
    from cosim.record.repair import repair

    done = repair(args.recording, args.output)
    # what the written recording holds, read back from it (its status is kept when only the summary
    # was cut off)
    if done.status is None:
        ending = "no final status (the run's end was cut off: cosim inspect says where it stops)"
    else:
        ending = (f"the run's final status: {done.status.status} at t = "
                  f"{exact_seconds(round(done.status.time * NS_PER_S))} s")
    how = "was cut short" if done.cut_short else "is damaged"
    if done.damage and done.cut_short:  # damaged besides: each stretch left out was said in a warning above
        how += f", with {counted(len(done.damage), 'damaged stretch', 'damaged stretches')} left out (above),"
    print(f"wrote {done.path}: {done.messages} messages, up to t = {exact_seconds(done.end_ns)} s, with {ending}; "
          f"{args.recording} {how} and is left as it was")
    return EXIT_OK


def cmd_replay(args: argparse.Namespace) -> int:
    from cosim.record.output import beside
    from cosim.record.reader import Recording
    from cosim.replay import check_replayable, replay_component, restart_simulation

    if args.from_time is None:
        given = [flag for flag, value in (("--set", args.set), ("-o", args.output), ("--until", args.until))
                 if value]
        if given:
            verb = "change" if len(given) > 1 else "changes"
            raise ScenarioError(f"{', '.join(given)} {verb} a restarted run: give --from T as well (without "
                                "--from, each component is re-run on its recorded inputs, unchanged)",
                                f"cosim replay {args.recording}")
    if args.from_time is not None and args.component:
        raise ScenarioError(f"--component {args.component} and --from: --component re-runs one component on its "
                            "recorded inputs, --from restarts the whole scene from a checkpoint; give one of them",
                            f"cosim replay {args.recording}")
    if args.from_time is not None and args.until is not None and args.until <= args.from_time:
        raise ScenarioError(f"--until {exact_seconds(args.until)} s must be after --from "
                            f"{exact_seconds(args.from_time)} s",
                            f"cosim replay {args.recording}")
    rec = Recording(args.recording)
    if args.from_time is None:
        check_replayable(rec, args.component)  # (what fails every component: said once)
        names = [args.component] if args.component else rec.scene().order
        status = rec.status()
        if status is not None and status.status == "failed":  # replayed up to where it failed: say so
            print(f"the recorded run failed at t = {exact_seconds(round(status.time * NS_PER_S))} s "
                  f"({one_line(status.reason)}): each component "
                  "is replayed up to it")
        worst = EXIT_OK
        for name in names:
            try:
                report = replay_component(rec, name)
            except RecordingError as gap:  # this component's inputs have a gap: said, and the others replayed
                said = str(gap)
                if f"cannot replay {name!r}" not in said:  # (a message it reads, shared by several: whose)
                    said = f"cannot replay {name!r}: {said}"
                print(f"error: {_one_line(said)}", file=sys.stderr, flush=True)
                worst = EXIT_BAD_INPUT
                continue
            print(report, flush=True)
            if not report.ok and worst == EXIT_OK:
                worst = EXIT_FAILED
        return worst
    from cosim.runner import format_summary, run_scene

    overrides = [*(args.set or []), *([_until_override(args.until)] if args.until is not None else [])]
    sim, stamp = restart_simulation(rec, args.from_time, overrides)
    end_ns = args.until if args.until is not None else sim.scene.until_ns
    if end_ns <= args.from_time:  # (an explicit --until was checked above) a restart of no time: no file
        status = rec.status()
        went_on = round(status.time * NS_PER_S) if status is not None else rec.end_ns
        beyond = f" (the recorded run went on to t = {exact_seconds(went_on)} s)" if went_on > end_ns else ""
        raise ScenarioError(f"--from {exact_seconds(args.from_time)} s is not before the restarted run's end, the "
                            f"scene's until = {exact_seconds(end_ns)} s{beyond}: give --until T, later than "
                            f"{exact_seconds(args.from_time)} s", f"cosim replay {args.recording}")
    # a restart with --set or --until is a variant: named by its overrides as `cosim run` names one,
    # so that one variant never silently replaces another (or the plain restart)
    variant = f"-set-{_overrides_digest(overrides)}" if overrides else ""
    default = beside(rec.path, f"-from{exact_seconds(stamp)}s{variant}.mcap")
    output = Path(args.output) if args.output else default
    def restarting() -> None:  # said once the output is accepted and the run about to begin
        print(f"restarting {rec.scene().name!r} from the checkpoint at t = {exact_seconds(stamp)} s", flush=True)
        _run_begins()

    outcome = run_scene(sim.scene, output, until_ns=args.until,
                        command_line=shlex.join(["cosim", *sys.argv[1:]]), progress=not args.quiet,
                        simulation=sim, inputs=(rec.path,), before_run=restarting)
    print(format_summary(sim.scene, outcome), flush=True)
    if outcome.failed:  # said on stderr as `cosim run` says it, not only in the summary
        print(f"error: {one_line(outcome.result.reason)}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def build_parser(command: str = "") -> argparse.ArgumentParser:
    """The command line's parser. ``command``: the command asked for, when known: a built-in one
    loads no plug-in, a plug-in's loads only its own; empty (or unknown) loads them all (for help)."""
    parser = _Parser(prog="cosim", description="Co-simulation of a stone skipping on water, recorded to MCAP.")
    parser.add_argument("--version", action="version", version=f"cosim {_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an error (also accepted after the command)")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scene_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("scene", help="scene YAML file")
        p.add_argument("--set", action="append", metavar="KEY=VALUE",
                       help="override a scene value, e.g. components.stone.tilt_deg=15 (repeatable)")

    p = sub.add_parser("run", help="run a scene and record it")
    scene_args(p)
    p.add_argument("-o", "--output", type=_output_path,
                   help="MCAP file to write (default runs/<scene>.mcap, <scene> the scene's name:, else its file's "
                        "name; with --set, --until, --record, --record-every or --perf, runs/<scene>-set-<hash>.mcap)")
    p.add_argument("--until", type=run_until_ns, metavar="T", help="end time [s] (default: the scene's)")
    p.add_argument("--no-record", action="store_true", help="do not write a recording")
    p.add_argument("--record", metavar="PATTERNS", help="record only these channels (comma-separated globs)")
    p.add_argument("--record-every", type=positive_int, metavar="N",
                   help="keep every N-th message of each component output channel (every stage change and skip "
                        "is kept; the viewer channels and checkpoints are not thinned)")
    p.add_argument("--perf", action="store_true",
                   help="add a wall-clock channel, /perf/tick: the wall time and real-time factor of every 100 "
                        "ticks and of the run's last ones (not deterministic)")
    p.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    p.add_argument("--live", nargs="?", const="127.0.0.1:8765", metavar="[HOST:]PORT", type=_live_address,
                   help="also stream to Foxglove over WebSocket (default 127.0.0.1:8765)")
    p.add_argument("--live-speed", type=_live_speed, default=None, metavar="S",
                   help="with --live: pace the run at S times real time (default 1; 0: unpaced)")
    p.add_argument("--live-linger", type=number_arg(float, "seconds", at_least=0), default=None, metavar="T",
                   help="with --live: keep serving the finished run T seconds of wall time (default: until "
                        "Ctrl-C; 0: stop with the run)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("validate", help="check a scene without running it")
    scene_args(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("components", help="the component types a scene can name, or a type's parameters, "
                                          "ports and messages")
    p.add_argument("types", nargs="*", metavar="TYPE", help="the types to describe (default: list them all)")
    p.add_argument("--markdown", type=_markdown_path, metavar="FILE.md",
                   help="write the reference page of the types (default: this project's own types, of "
                        "cosim and components, not another installed package's) to FILE.md")
    p.set_defaults(func=cmd_components)

    p = sub.add_parser("inspect", help="channels, status and stage timeline of a recording")
    p.add_argument("recording", help="MCAP recording of a run")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("repair", help="make a recording left cut short (a killed run's NAME.<random>.part) "
                                      "a valid one, up to its last whole record")
    p.add_argument("recording", help="the cut-short file (it is left as it was)")
    p.add_argument("-o", "--output", type=_output_path,
                   help="MCAP file to write (default: the recording the private file was meant to become, "
                        "or STEM-repaired.mcap)")
    p.set_defaults(func=cmd_repair)

    p = sub.add_parser("replay", help="re-run components from a recording, or restart from a checkpoint")
    p.add_argument("recording", help="MCAP recording of a run")
    p.add_argument("--component", help="replay this component alone (default: each in turn)")
    p.add_argument("--from", dest="from_time", type=_seconds_arg, metavar="T",
                   help="restart the whole scene from the last checkpoint at or before T [s]")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="with --from: changed settings")
    p.add_argument("-o", "--output", type=_output_path,
                   help="with --from: MCAP file for the restarted run (default RECORDING-fromCs.mcap beside the "
                        "recording, C the time of the checkpoint it restarts from; with --set or --until, "
                        "RECORDING-fromCs-set-<hash>.mcap)")
    p.add_argument("--until", type=_seconds_arg, metavar="T", help="with --from: end time [s]")
    p.add_argument("-q", "--quiet", action="store_true", help=QUIET_HELP)
    p.set_defaults(func=cmd_replay)

    if command in sub.choices:
        return parser  # a built-in command: no plug-in needs loading (each costs imports at start-up)
    from importlib.metadata import entry_points  # here, not at import: Ctrl-C at start-up finds main() sooner

    plugins = sorted(entry_points(group=COMMANDS_GROUP), key=lambda e: e.name)
    if any(ep.name == command for ep in plugins):
        plugins = [ep for ep in plugins if ep.name == command]  # only the one asked for
    for ep in plugins:
        try:
            ep.load()(sub)
        except Exception as exc:  # one broken plug-in must not take the other commands with it
            _unavailable(sub, ep.name, f"cannot load {ep.value} ({type(exc).__name__}: {exc})", exc)
    return parser


def _unavailable(sub: argparse._SubParsersAction, name: str, why: str, exc: Exception) -> None:
    """A command whose plug-in failed to load: using it says why (a missing extra is bad input)."""
    if name in sub.choices:
        return

    def fail(args: argparse.Namespace) -> int:
        if isinstance(exc, ModuleNotFoundError) and (exc.name or "").partition(".")[0] in EXTRAS:
            raise exc  # an optional extra not installed: said as such
        raise CosimError(f"cosim {name} is unavailable: {why}")

    p = sub.add_parser(name, help=f"(unavailable: {why})", add_help=False)
    p.add_argument("rest", nargs=argparse.REMAINDER)
    p.set_defaults(func=fail)


# Packages add subcommands through these entry points: each names a register(subparsers) function
# whose module imports its heavy dependencies lazily (plotting, rendering, sweeps).
COMMANDS_GROUP = "cosim.commands"


def _version() -> str:
    from cosim import __version__

    return __version__


# an optional dependency (its import name, top package) -> the extra that installs it
EXTRAS = {"matplotlib": "viz", "mpl_toolkits": "viz", "PIL": "viz", "foxglove_schemas_protobuf": "viz",
          "mcap_protobuf": "viz", "google": "viz", "imageio_ffmpeg": "video", "dask": "dask",
          "distributed": "dask", "fmpy": "fmi", "pythonfmu": "fmi", "pyarrow": "viz"}


def _where(exc: BaseException) -> str:
    """The innermost frame of a traceback, as ``file:line in function``."""
    import traceback

    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return "cosim"
    last = frames[-1]
    path = last.filename
    try:
        path = os.path.relpath(path)
    except ValueError:
        pass
    if path.startswith(".."):
        path = last.filename
    return f"{path}:{last.lineno} in {last.name}"


def _one_line(text: str) -> str:
    return one_line(str(text).strip()) or "(no message)"


def report(exc: BaseException, command: str) -> int:
    """Print ``exc`` as one line on stderr (a ScenarioError: one line per problem); its exit code."""
    what = f"cosim {command}" if command else "cosim"
    if isinstance(exc, ScenarioError):  # one line per problem, each made one line by the error itself
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(exc, RecordingError):
        print(f"error: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(exc, CosimError):  # a failure, unless the error says it is the input's (exit_code)
        print(f"error: {_one_line(str(exc))}", file=sys.stderr)
        return getattr(exc, "exit_code", EXIT_FAILED)
    if isinstance(exc, KeyboardInterrupt):
        how = exc.args[0] if exc.args in (("SIGTERM",), ("SIGHUP",)) else "Ctrl-C"
        print(f"error: {what}: interrupted ({how})", file=sys.stderr)
        return EXIT_FAILED
    if isinstance(exc, ModuleNotFoundError) and (exc.name or "").partition(".")[0] in EXTRAS:
        extra = EXTRAS[(exc.name or "").partition(".")[0]]
        print(f"error: {what} needs {exc.name}, which is not installed: pip install 'cosim[{extra}]'",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(exc, MemoryError):
        print(f"error: {what}: out of memory (at {_where(exc)})", file=sys.stderr)
        return EXIT_FAILED
    if isinstance(exc, OSError) and (exc.errno in NO_ROOM or exc.filename == STDOUT_NAME):
        # the machine's limits, or standard output that takes nothing (closed, >&-): not the user's input
        where = _one_line(exc.filename) if exc.filename is not None else f"{what}: its output"
        print(f"error: {where}: cannot be written ({_one_line(exc.strerror or str(exc))})", file=sys.stderr)
        return EXIT_FAILED
    if isinstance(exc, OSError) and exc.filename is not None:
        print(f"error: {_one_line(exc.filename)}: {_one_line(exc.strerror or str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"error: {what}: internal error {type(exc).__name__}: {_one_line(str(exc))} (at {_where(exc)}; "
          "--debug shows the traceback)", file=sys.stderr)
    return EXIT_FAILED


class _CtrlC:
    """Remembers a Ctrl-C (or a SIGTERM or SIGHUP, the terminal closed, which end a command the same
    way: its files cleaned up, one line, exit code 1) while a command runs: whatever error follows it
    (an import the signal cut short reports an ImportError, numpy's among them) is then told as the
    interruption it is.

    The KeyboardInterrupt the handler raises can land where Python cannot pass it on: in a callback
    the interpreter runs itself (importlib's module locks are freed by one while a module loads),
    where it is printed as "Exception ignored" with a traceback and dropped. Such a drop is not
    printed here (the interrupt is remembered), and :func:`_run_begins` turns a remembered one into
    the interruption before a run starts; a SIGTERM dropped so still ends the command when it
    returns (:func:`_main`), and a second SIGTERM ends the process at once, as it always did. A
    SIGTERM or SIGHUP that the process was started ignoring (``nohup``) stays ignored."""

    active: _CtrlC | None = None  # the one watching this command

    def __init__(self) -> None:
        self.seen = False
        self.signum = signal.SIGINT  # the signal seen
        self._old: Any = None
        self._old_term: dict[int, Any] = {}  # SIGTERM's and SIGHUP's handlers before, where replaced
        self._old_hook: Any = None

    def _handler(self, signum: int, frame: Any) -> None:
        self.seen = True
        self.signum = signum
        if signum != signal.SIGINT:  # the next one is not caught: it ends the process, whatever runs
            signal.signal(signum, signal.SIG_DFL)
        raise self.interruption()

    def interruption(self) -> KeyboardInterrupt:
        """The KeyboardInterrupt that tells the signal seen (a SIGTERM's or SIGHUP's says so)."""
        if self.signum != signal.SIGINT:
            return KeyboardInterrupt(signal.Signals(self.signum).name)
        return KeyboardInterrupt()

    def _unraisable(self, unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and self.seen:
            return  # our own interrupt, dropped by the interpreter: remembered in self.seen
        self._old_hook(unraisable)

    def __enter__(self) -> _CtrlC:
        try:
            self._old = signal.signal(signal.SIGINT, self._handler)
        except ValueError:  # not the main thread: its Ctrl-C is not ours to see
            self._old = None
            return self
        for signum in ending_signals():
            self._old_term[signum] = signal.signal(signum, self._handler)
        self._old_hook, sys.unraisablehook = sys.unraisablehook, self._unraisable
        _CtrlC.active = self
        return self

    def __exit__(self, *exc: object) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
            for signum, old in self._old_term.items():
                signal.signal(signum, old)
            sys.unraisablehook = self._old_hook
            _CtrlC.active = None


def _run_begins() -> None:
    """Just before a run's first step: the start-up is over (:func:`start_up_done`), and a Ctrl-C
    during it that Python dropped (see :class:`_CtrlC`) interrupts the run now, before it starts."""
    start_up_done()
    watcher = _CtrlC.active
    if watcher is not None and watcher.seen:
        raise watcher.interruption()


def main(argv: list[str] | None = None) -> int:
    """Run the command in ``argv`` (default: this program's arguments) and return its exit code.

    Run as the program (no ``argv``), a command of :data:`STARTS_WITHOUT_COLLECTION` starts up
    without the cyclic garbage collector (see ``_collection``; a run turns it back on as it begins),
    and every command ends the process as soon as it has returned (:func:`_end_process`), without the
    interpreter's teardown."""
    as_program = argv is None
    argv = list(sys.argv[1:] if argv is None else argv)
    if as_program:
        warnings.showwarning = _one_line_warning
    if as_program and _command(argv) in STARTS_WITHOUT_COLLECTION:
        _pause_collection()
    stdout, stderr = sys.stdout, sys.stderr
    # a stream the process was started without (``>&-``: Python makes it None) is one that cannot be
    # written: stdout's said as /dev/full's is, stderr's taken as read by no one (its None was an
    # internal error, and turned a bad scene's exit 2 into 1)
    sys.stdout = _ReaderMayLeave(_ClosedStream() if stdout is None else stdout)
    sys.stderr = _ReaderMayLeave(_ClosedStream() if stderr is None else stderr, names_stdout=False)
    try:
        with _CtrlC() as ctrl_c:
            code = _main(argv, ctrl_c)
    finally:
        if isinstance(sys.stdout, _ReaderMayLeave):
            sys.stdout = stdout
        if isinstance(sys.stderr, _ReaderMayLeave):
            sys.stderr = stderr
        start_up_done()
        if as_program:  # the command has said all it has to: a Ctrl-C as the process ends adds nothing
            sys.unraisablehook = quiet_interrupts(sys.unraisablehook)
    if as_program:
        _end_process(code)
    return code


def _hold_signals_until_exit(code: int) -> None:
    """The command is done, ``code`` decided and the process about to end: a Ctrl-C, SIGTERM or SIGHUP
    now lets the exit handlers finish (a second one ends the process at once, with ``code``), and
    changes no exit code (one in the teardown this skips killed a plot that had written and said
    everything: exit 143)."""
    seen = []

    def handler(signum: int, frame: Any) -> None:
        if seen:
            os._exit(code)
        seen.append(signum)

    try:
        for signum in (signal.SIGINT, *ending_signals()):
            if signal.getsignal(signum) is not signal.SIG_IGN:  # (one started ignored, under nohup, stays so)
                signal.signal(signum, handler)
    except ValueError:  # not the main thread: its signals are not ours
        pass


def _one_line_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                      file: Any = None, line: str | None = None) -> None:
    """A warning as the program shows it: ``warning: TEXT``, one line, without the Python file and
    line that issued it (those are for --debug and the tests)."""
    say_warning(str(message), file)


# The cyclic garbage collector while a process starts up: importing and starting numba leaves about
# 85,000 objects that every full collection walks again, and loading a scene and its recording's viewer
# modules made the collector run often enough to cost 60-90 ms of a 1 ms run (a bare `import numba`
# pays 15 ms). Start-up makes next to no garbage (under a thousand unreachable objects when the run
# begins), so it runs without the collector; when the run begins (start_up_done) everything built
# so far is frozen, never to be walked again, and the collector is back on for what the run allocates.
# A start-up that compiled kernels (a fresh checkout's first run) leaves tens of thousands of
# unreachable objects: those are collected first (a full collection there costs 30-120 ms).
_collection = {"paused": False}


def _pause_collection() -> None:
    import gc

    if gc.isenabled():
        gc.disable()
        _collection["paused"] = True


def start_up_done() -> None:
    """The start-up is over (the run begins): the collector, if paused for it, runs again, leaving
    out what was built so far."""
    if _collection["paused"]:
        import gc

        from cosim.jit_time import may_have_compiled

        _collection["paused"] = False
        if may_have_compiled():
            gc.collect()
        gc.freeze()
        gc.enable()


# The commands that start up without the collector (a run's start-up makes next to no garbage).
STARTS_WITHOUT_COLLECTION = frozenset({"run", "validate"})


def _command(argv: list[str]) -> str:
    """The command named in ``argv`` (its first word that is not an option), or ''."""
    return next((a for a in argv if not a.startswith("-")), "")


def _end_process(code: int) -> None:
    """Exit with ``code`` now: the exit handlers run and the output is flushed as at a normal exit;
    only the teardown of the interpreter's objects is left out. Every command's work is finished and
    on disk once it returns (a recording complete under its final name, a figure or a page moved
    into place whole); the teardown after compiled kernels or matplotlib costs 0.13-0.3 s (freeing
    numba's, LLVM's and the figures' objects one by one), more than a short run itself, and restores
    the default signal handlers first: a Ctrl-C or SIGTERM then killed a plot or a render that had
    written and said everything (exit 130 or 143). A thread still running that is not a
    daemon (one the interpreter would wait for), or a profiler or tracer watching (``python -m
    cProfile``, a debugger: they report once the program has returned), means a normal exit instead."""
    import threading

    if sys.getprofile() is not None or sys.gettrace() is not None:
        return
    if any(t is not threading.main_thread() and not t.daemon and t.is_alive() for t in threading.enumerate()):
        return
    import atexit

    code = code if isinstance(code, int) else 0  # (a plug-in command that returned None: as sys.exit(None))
    _hold_signals_until_exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # closed, gone (a reader that left), or replaced
            pass
    os._exit(code)


def _main(argv: list[str], ctrl_c: _CtrlC) -> int:
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    command = _command(argv)
    try:
        _prestart_writer(command, argv)
        parser = build_parser(command)
        args = parser.parse_args(argv)
        code = args.func(args)
        if ctrl_c.seen and ctrl_c.signum == signal.SIGTERM:  # one Python dropped (see _CtrlC): still the end
            return report(ctrl_c.interruption(), command)
        return code
    except SystemExit:  # argparse: --help, --version, bad arguments (already said, exit 2)
        raise
    except BrokenPipeError as exc:  # a pipe other than stdout gone (stdout's reader leaving is _ReaderMayLeave's)
        _quiet_stdout()
        print(f"error: cosim {command}: a pipe it wrote to was closed by its reader ({exc.strerror or exc})",
              file=sys.stderr)
        return EXIT_FAILED
    except BaseException as exc:  # the one error boundary: one line, never a traceback
        if not isinstance(exc, Exception | KeyboardInterrupt):
            raise
        if debug:
            import traceback

            traceback.print_exc()
        if isinstance(exc, KeyboardInterrupt):
            # CPython marks a KeyboardInterrupt raised inside exec() of a string (dataclasses does
            # that while a module is being imported) as unhandled even once caught, and the process
            # would then end by SIGINT instead of with this exit code; the next exec() clears the mark
            exec("pass")
        return report(ctrl_c.interruption() if ctrl_c.seen else exc, command)


class _ClosedStream:
    """A standard stream the process was started without: writing to it fails as to a closed
    descriptor (:class:`_ReaderMayLeave` says it of stdout, and lets standard error's go nowhere)."""

    def write(self, text: str) -> int:
        raise _closed()

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False

    def fileno(self) -> int:
        raise _closed()


def _closed() -> OSError:
    """The error of a write to a closed descriptor."""
    import errno
    import os

    return OSError(errno.EBADF, os.strerror(errno.EBADF))


class _ReaderMayLeave:
    """A standard stream whose reader may leave (``cosim replay RUN.mcap | head -1``, ``cosim validate
    bad.yaml 2>&1 | head -1``): from then on what is written goes nowhere, and the command goes on to
    its end and its own exit code. The pipe's error ended the command where it printed, with exit 0:
    a replay that had found a divergence, or a restart that never ran, said success; on stderr,
    raised while a bad scene's problems were said, it turned exit 2 (bad input) into 1 (the run
    failed). Another error of standard output (a full disk under ``> out.txt``) is said of it, not
    of "its output" (``names_stdout``)."""

    def __init__(self, stream: Any, *, names_stdout: bool = True):
        self._stream = stream
        self._names_stdout = names_stdout

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            _quiet(self._stream)
            return len(text)
        except OSError as exc:
            if not self._names_stdout:  # standard error that takes nothing: nothing can be said there
                # (its error, raised as a bad scene was said, turned exit 2 into 1)
                _quiet(self._stream)
                return len(text)
            raise _named_stdout(exc) from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            _quiet(self._stream)
        except OSError as exc:
            if not self._names_stdout:
                _quiet(self._stream)
                return
            raise _named_stdout(exc) from None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


STDOUT_NAME = "standard output"  # the file an error of writing to stdout names


def _named_stdout(exc: OSError) -> OSError:
    """``exc``, a write to stdout failing, with "standard output" as its file when it names none (the
    error said "cosim run: its output: cannot be written", which reads as the recording)."""
    if exc.filename is None:
        exc.filename = STDOUT_NAME
    return exc


def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so the interpreter's own flush at exit does not fail again."""
    _quiet(sys.stdout)


def _quiet(stream: Any) -> None:
    """Point ``stream``'s file at /dev/null (its reader gone): what is still written goes nowhere."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, stream.fileno())
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    sys.exit(main())
