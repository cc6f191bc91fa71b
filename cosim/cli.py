"""The ``cosim`` command line.

Exit codes: 0 ok, 1 the simulation failed (or was interrupted), 2 bad input (scene, recording or
arguments). Bad input is reported in plain lines on stderr, never as a traceback, and leaves no file.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Callable
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from cosim.errors import CosimError, RecordingError, ScenarioError
from cosim.timebase import NS_PER_S

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse that exits with the bad-input code 2 and a one-line message."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"error: {self.prog}: {message}\n")


def number_arg(kind: type[int] | type[float], what: str, *, above: float | None = None,
               at_least: float | None = None, unit: str = "") -> Callable[[str], Any]:
    """An argparse type reading ``kind`` with an optional bound, for every subcommand's options;
    a bad value is a one-line error naming what was expected and what was given."""
    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if above is not None and not value > above:
            raise argparse.ArgumentTypeError(f"must be > {above:g}{unit}, got {text}")
        if at_least is not None and not value >= at_least:
            raise argparse.ArgumentTypeError(f"must be >= {at_least:g}{unit}, got {text}")
        return value
    return parse


positive_int = number_arg(int, "a whole number", at_least=1)
positive_number = number_arg(float, "a number", above=0)
seconds = number_arg(float, "seconds")
positive_seconds = number_arg(float, "seconds", above=0, unit=" s")
_time_since_start = number_arg(float, "seconds", at_least=0, unit=" s")


def _seconds_arg(text: str) -> int:
    """A time [s] >= 0 as integer nanoseconds."""
    return round(_time_since_start(text) * NS_PER_S)


def _default_output(scene_path: str, name: str) -> Path:
    return Path("runs") / f"{name or Path(scene_path).stem}.mcap"


def _record_overrides(args: argparse.Namespace) -> list[str]:
    sets = list(args.set or [])
    if getattr(args, "record", None):
        patterns = [p.strip() for p in args.record.split(",") if p.strip()]
        sets.append(f"record.channels=[{', '.join(repr(p) for p in patterns)}]")
    if getattr(args, "record_every", None):
        sets.append(f"record.every={args.record_every}")
    return sets


def cmd_run(args: argparse.Namespace) -> int:
    from cosim.runner import format_summary, run_scene
    from cosim.scenario import load

    scene = load(args.scene, overrides=_record_overrides(args))
    output = None if args.no_record else (Path(args.output) if args.output else
                                          _default_output(args.scene, scene.name))
    command = shlex.join(["cosim", *sys.argv[1:]]) if sys.argv[1:] else "cosim run"
    outcome = run_scene(scene, output, until_ns=args.until, command_line=command,
                        progress=not args.quiet, perf=args.perf, live=args.live, live_speed=args.live_speed)
    print(format_summary(scene, outcome))
    if outcome.failed:
        print(f"error: {outcome.result.reason}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def cmd_validate(args: argparse.Namespace) -> int:
    from cosim.scenario import load

    scene = load(args.scene, overrides=args.set or [])
    print(f"{args.scene}: ok - scene {scene.name!r}: {len(scene.components)} components, "
          f"{len(scene.connections)} connections, dt = {scene.dt:g} s, until = {scene.until_ns / NS_PER_S:g} s")
    print(f"  order within a tick: {' -> '.join(scene.order)}")
    for name in scene.order:
        cfg = scene.components[name]
        print(f"  {name}: {cfg.type_name}, every {cfg.every} ({cfg.every * scene.dt:g} s), "
              f"on_unstable {cfg.on_unstable}")
    for conn in scene.connections:
        print(f"  {conn}")
    return EXIT_OK


def cmd_inspect(args: argparse.Namespace) -> int:
    from cosim.record.describe import describe_recording
    from cosim.record.reader import Recording

    print(describe_recording(Recording(args.recording)))
    return EXIT_OK


def cmd_replay(args: argparse.Namespace) -> int:
    from cosim.record.reader import Recording
    from cosim.replay import replay_component, restart_simulation

    rec = Recording(args.recording)
    if args.from_time is None:
        names = [args.component] if args.component else rec.scene().order
        worst = EXIT_OK
        for name in names:
            report = replay_component(rec, name)
            print(report)
            if not report.ok:
                worst = EXIT_FAILED
        return worst
    from cosim.runner import format_summary, run_scene

    sim, stamp = restart_simulation(rec, args.from_time, args.set or [])
    default = rec.path.with_name(rec.path.stem + f"-from{stamp / NS_PER_S:g}s.mcap")
    output = Path(args.output) if args.output else default
    if output.resolve() == rec.path.resolve():
        raise RecordingError(f"{output}: the restarted run cannot overwrite the recording it starts from")
    print(f"restarting {rec.scene().name!r} from the checkpoint at t = {stamp / NS_PER_S:g} s")
    outcome = run_scene(sim.scene, output, until_ns=args.until,
                        command_line=shlex.join(["cosim", *sys.argv[1:]]), progress=not args.quiet,
                        simulation=sim)
    print(format_summary(sim.scene, outcome))
    return EXIT_FAILED if outcome.failed else EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cosim", description="Co-simulation of a stone skipping on water, recorded to MCAP.")
    parser.add_argument("--version", action="version", version=f"cosim {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scene_args(p: argparse.ArgumentParser) -> None:
        p.add_argument("scene", help="scene YAML file")
        p.add_argument("--set", action="append", metavar="KEY=VALUE",
                       help="override a scene value, e.g. components.stone.speed=8 (repeatable)")

    p = sub.add_parser("run", help="run a scene and record it")
    scene_args(p)
    p.add_argument("-o", "--output", help="MCAP file to write (default runs/<scene>.mcap)")
    p.add_argument("--until", type=_seconds_arg, metavar="T", help="end time [s] (default: the scene's)")
    p.add_argument("--no-record", action="store_true", help="do not write a recording")
    p.add_argument("--record", metavar="PATTERNS", help="record only these channels (comma-separated globs)")
    p.add_argument("--record-every", type=int, metavar="N", help="record every N-th message of each channel")
    p.add_argument("--perf", action="store_true", help="add wall-clock /perf channels (not deterministic)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.add_argument("--live", nargs="?", const="127.0.0.1:8765", metavar="[HOST:]PORT",
                   help="also stream to Foxglove over WebSocket (default 127.0.0.1:8765)")
    p.add_argument("--live-speed", type=float, default=1.0, metavar="S",
                   help="with --live: pace the run at S times real time (default 1; 0: unpaced)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("validate", help="check a scene without running it")
    scene_args(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("inspect", help="channels, status and stage timeline of a recording")
    p.add_argument("recording")
    p.set_defaults(func=cmd_inspect)

    p = sub.add_parser("replay", help="re-run components from a recording, or restart from a checkpoint")
    p.add_argument("recording")
    p.add_argument("--component", help="replay this component alone (default: each in turn)")
    p.add_argument("--from", dest="from_time", type=_seconds_arg, metavar="T",
                   help="restart the whole scene from the last checkpoint at or before T [s]")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="with --from: changed settings")
    p.add_argument("-o", "--output", help="with --from: MCAP file for the restarted run")
    p.add_argument("--until", type=_seconds_arg, metavar="T", help="with --from: end time [s]")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_replay)

    for ep in sorted(entry_points(group=COMMANDS_GROUP), key=lambda e: e.name):
        ep.load()(sub)
    return parser


# Packages add subcommands through these entry points: each names a register(subparsers) function
# whose module imports its heavy dependencies lazily (plotting, rendering, sweeps).
COMMANDS_GROUP = "cosim.commands"


def _version() -> str:
    from cosim import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ScenarioError, RecordingError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except CosimError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:
        return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
