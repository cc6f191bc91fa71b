"""``cosim plot`` and ``cosim render``: registered through the ``cosim.commands`` entry points.

This module is imported whenever the ``cosim`` parser is built, so it stays light: matplotlib and
the figure code are imported only when one of these commands runs.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from cosim.cli import number_arg, positive_number, seconds

# the pictures' sizes, bounded where a figure or a video would no longer fit in memory
DPI = number_arg(int, "a resolution in dots per inch", at_least=10, at_most=1200)
WIDTH = number_arg(int, "a width in pixels", at_least=16, at_most=7680, unit=" px")
FPS = number_arg(float, "frames per second", above=0, at_most=240)

EXIT_OK, EXIT_BAD_INPUT = 0, 2


def register_plot(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "plot", help="PNG figures of a recording: trajectory by stage, speed and attack angle, energy, "
                     "contact forces (water alone: crest, volume and energy over time)")
    p.add_argument("recording", help="MCAP recording of a run")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="folder for the PNGs (default: RUN-plots/ beside the recording)")
    p.add_argument("--body", help="the body to show (default: the first, in the scene's order, that a stage "
                                  "monitor watches)")
    p.add_argument("--dpi", type=DPI, default=120, help="resolution of the PNGs (default 120; 10 to 1200)")
    p.set_defaults(func=cmd_plot)


def cmd_plot(args: argparse.Namespace) -> int:
    from components.analysis.plot import FIGURES, WATER_FIGURE, plot_run
    from cosim.record.output import beside, same_file

    out_dir = Path(args.output) if args.output else beside(Path(args.recording), "-plots")
    if out_dir.exists() and not out_dir.is_dir():
        print(f"error: {out_dir}: not a folder; cosim plot writes its PNG figures into a folder (-o DIR)",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    recording = Path(args.recording)
    for name in (*FIGURES, WATER_FIGURE):
        if same_file(out_dir / name, recording):
            print(f"error: {out_dir / name}: is the recording plotted; its figure would replace it "
                  "(choose another folder, -o DIR)", file=sys.stderr)
            return EXIT_BAD_INPUT
        # checked before any figure is drawn: a figure's name taken by a folder was found only when
        # the figures were put in place
        if (out_dir / name).exists() and not (out_dir / name).is_file():
            what = "a folder" if (out_dir / name).is_dir() else "not a regular file"
            print(f"error: {out_dir / name}: is {what}, where cosim plot writes its figure {name} "
                  "(remove it or choose another folder, -o DIR)", file=sys.stderr)
            return EXIT_BAD_INPUT
    written, skipped = plot_run(args.recording, out_dir, body=args.body, dpi=args.dpi)
    for path in written:
        print(f"wrote {path}")
    for name, reason in skipped:
        print(f"skipped {name}: {reason}")
    return EXIT_OK


def register_render(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "render", help="3D animation of the stone over the shaded water surface, or of the water alone "
                       "(GIF, MP4 or one PNG frame)")
    p.add_argument("recording", help="MCAP recording of a run")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="skip.gif, skip.mp4 (needs ffmpeg or the [video] extra) or frame.png (one frame)")
    p.add_argument("--fps", type=FPS, default=30.0,
                   help="frames per second (default 30, at most 240; a GIF's 0.00153 to 50)")
    p.add_argument("--width", type=WIDTH, default=800, help="width in pixels (default 800, 16 to 7680)")
    p.add_argument("--speed", type=positive_number, default=1.0,
                   help="simulated seconds per second of video (default 1; 0.25 is a slow motion)")
    p.add_argument("--view", choices=("follow", "fixed"), default="follow",
                   help="follow: a window around the stone (default); fixed: the whole run in view "
                        "(water alone: always the whole surface)")
    p.add_argument("--span", type=positive_number,
                   help="follow view: width of the window [m] (default 1; at least the stone's diameter, "
                        "at most where it is a pixel across)")
    p.add_argument("--from", dest="start", type=seconds, metavar="T", help="start time [s]")
    p.add_argument("--to", dest="stop", type=seconds, metavar="T", help="end time [s]")
    p.add_argument("--at", type=seconds, metavar="T",
                   help="time of the frame for a PNG [s] (default: as the stone leaves the water after its "
                        "first skip; without a skip, just after its first hit; without a hit, or water alone: mid-run)")
    p.add_argument("--body", help="the body to show (default: the first, in the scene's order, that a stage "
                                  "monitor watches)")
    p.add_argument("--water", metavar="TOPIC",
                   help="WaterField channel (default: the field of the water the body meets)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_render)


def cmd_render(args: argparse.Namespace) -> int:
    from components.analysis.render import RenderError, RenderOptions, render
    from cosim.record.output import same_file

    if args.output.endswith(("/", os.sep)):  # (a Path would drop the slash and write a file there)
        print(f"error: {args.output}: names a folder; give the file to write, e.g. {args.output}skip.gif",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    if same_file(Path(args.output), Path(args.recording)):
        print(f"error: {args.output}: is the recording rendered; it would be replaced (choose another -o)",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    if args.span is not None and args.view != "follow":  # the fixed view shows the whole run
        print(f"error: --span {args.span:g}: the width of the follow view's window; the fixed view shows "
              "the whole run (leave --span out, or use --view follow)", file=sys.stderr)
        return EXIT_BAD_INPUT
    span = {} if args.span is None else {"span": args.span}  # else RenderOptions' own default
    options = RenderOptions(fps=args.fps, width=args.width, speed=args.speed, view=args.view, start=args.start,
                            stop=args.stop, at=args.at, body=args.body, water=args.water, progress=not args.quiet,
                            **span)
    try:
        result = render(args.recording, args.output, options)
    except RenderError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    # (to the recording's step: at 0.5 ms steps a frame at 0.0745 s said 0.074)
    places = result.decimals
    print(f"wrote {result.path} ({result.frames} frame{'s' if result.frames != 1 else ''}, "
          f"{result.width} x {result.height} px, t = {result.start:.{places}f} .. {result.stop:.{places}f} s)")
    return EXIT_OK
