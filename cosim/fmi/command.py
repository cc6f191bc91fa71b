"""``cosim fmu export SCENE.yaml -o NAME.fmu``: a scene as an FMI 2.0 co-simulation FMU.

By default the FMU shows what the ``throw`` preset finds in the scene (the throw's speed, angles and
spin as parameters; the stone's position and velocity, the stage and the skip count as outputs);
``--parameter`` and ``--output-var`` add scene values and port fields, ``--preset none`` drops the
preset. ``--step`` is the default communication step written into the FMU: a whole multiple of the
scene's base step, or the export is refused.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from cosim.cli import EXIT_OK, file_name, positive_seconds
from cosim.errors import ScenarioError
from cosim.timebase import NS_PER_S

if TYPE_CHECKING:
    from cosim.fmi.spec import ExportSpec
    from cosim.scenario import Scene

DEFAULT_PRESET = "throw"


def build_spec(args: argparse.Namespace, scene: Scene) -> ExportSpec:
    """The export spec of the command line's options for ``scene``."""
    from cosim.fmi.spec import (
        ExportSpec,
        check_output,
        check_parameter_keys,
        check_step,
        load_preset,
        parse_output,
        parse_parameter,
        unique,
    )

    parameters, outputs, preset, derives = [], [], None, []
    if args.preset != "none":
        module = load_preset(args.preset)
        parameters, outputs = list(module.parameters(scene)), [check_output(o, scene) for o in module.outputs(scene)]
        if parameters or outputs:
            preset = args.preset
        elif args.preset != DEFAULT_PRESET or not (args.parameter or args.output_vars):
            raise ScenarioError(f"--preset {args.preset}: finds nothing to show in this scene; name what the FMU "
                                "shows with --parameter NAME=key.path and --output-var NAME=component.port.field",
                                scene.source)
        # the keys the preset writes from its derived parameters, asked of the preset itself
        starts = {p.name: p.start for p in parameters if p.key is None}
        derives = [line.partition("=")[0].strip() for line in module.overrides(scene, starts)] if starts else []
    named = [parse_parameter(text, scene) for text in args.parameter or []]
    check_parameter_keys(parameters + named, named, preset, derives, scene.source)
    parameters += named
    outputs += [parse_output(text, scene) for text in args.output_vars or []]
    if not outputs:
        raise ScenarioError("the FMU would have no outputs: add --output-var NAME=component.port.field", scene.source)
    step_ns = 0
    if args.step is not None:
        from cosim.scenario import MAX_TIME_NS

        if args.step * NS_PER_S > MAX_TIME_NS:  # a number of nanoseconds no clock here holds
            raise ScenarioError(f"--step {args.step:g} s: must be at most {MAX_TIME_NS / NS_PER_S:.3g} s",
                                scene.source)
        step_ns = round(args.step * NS_PER_S)
        check_step(step_ns, scene, given=args.step)
    return unique(ExportSpec(tuple(parameters), tuple(outputs), preset, step_ns, scene.base_dir,
                             tuple(scene.overrides), scene.dt_ns, scene.until_ns), scene.source)


def fmu_path(text: str) -> str:
    """``-o NAME.fmu``, checked before the scene is loaded and the FMU built (a minute's work): a file
    name whose folder exists or can be made (no file in the way)."""
    path = Path(file_name(text, "out/skip.fmu"))
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give the FMU's file name, e.g. {path / 'skip.fmu'}")
    from cosim.record.output import nearest_existing

    folder = nearest_existing(path.parent)
    if folder is not None and not folder.is_dir():
        raise argparse.ArgumentTypeError(f"{folder} is a file, so the folder of {text} cannot be made")
    return text


def cmd_export(args: argparse.Namespace) -> int:
    from cosim.scenario import load

    scene = load(args.scene, overrides=args.set or [])
    spec = build_spec(args, scene)
    path = _export_naming_the_output(scene, spec, args.output)
    names = lambda items: ", ".join(i.name for i in items) or "none"
    print(f"{path}: FMI 2.0 co-simulation FMU of scene {scene.name!r} ({path.stat().st_size / 1e6:.2g} MB)")
    print(f"  parameters: {names(spec.parameters)}")
    print(f"  outputs: {names(spec.outputs)}")
    default = (spec.step_ns or spec.dt_ns) / NS_PER_S  # the default experiment's step size
    print(f"  communication step: any whole multiple of dt = {scene.dt:g} s (default experiment: {default:g} s); "
          f"runs the Python of {sys.executable} (with cosim installed)")
    return EXIT_OK


def _export_naming_the_output(scene: Scene, spec: ExportSpec, output: str) -> Path:
    """:func:`cosim.fmi.export.export_scene`, with a write refused for want of room (a full disk, a
    quota, a file-size limit) said of ``output``, the file asked for: it was said as an internal
    error naming a file in the build's temporary folder, deleted by then."""
    from cosim.fmi.build import NO_ROOM
    from cosim.fmi.export import export_scene

    try:
        return export_scene(scene, spec, output)
    except OSError as exc:
        if exc.errno not in NO_ROOM:
            raise
        raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), output) from None


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``cosim fmu export`` to the CLI."""
    fmu = subparsers.add_parser("fmu", help="FMI: export a scene as a co-simulation FMU")
    # named as cosim's own choice of command is: "the following arguments are required: command" (it
    # said fmu_command, a variable's name); it replaces the top-level value, which nothing reads (each
    # command runs its parser's func)
    actions = fmu.add_subparsers(dest="command", required=True, parser_class=type(fmu))
    # the module's reST made plain for the terminal (its ``--step`` printed with the backticks)
    description = __doc__.split("\n\n", 1)[1].replace("``", "") if __doc__ else None
    p = actions.add_parser("export", help="build an FMI 2.0 co-simulation FMU that runs the scene",
                           description=description)
    p.add_argument("scene", help="scene YAML file")
    p.add_argument("-o", "--output", required=True, type=fmu_path, metavar="NAME.fmu", help="the FMU file to write")
    p.add_argument("--step", type=positive_seconds, metavar="S",
                   help="default communication step [s] (a whole multiple of the scene's dt; default: the dt)")
    p.add_argument("--preset", default=DEFAULT_PRESET,
                   help=f"default parameters and outputs (default {DEFAULT_PRESET}; none: only those named)")
    p.add_argument("--parameter", action="append", metavar="NAME=KEY.PATH",
                   help="a number of the scene as an FMU parameter, e.g. density=components.stone.density")
    p.add_argument("--output-var", action="append", dest="output_vars", metavar="NAME=COMPONENT.PORT.FIELD[i]",
                   help="a port field as an FMU output, e.g. wz=stone.state.angular_velocity[2]")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    p.set_defaults(func=cmd_export)
