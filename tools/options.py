"""Shared command-line pieces of the tools: argparse types that refuse bad values with one usage line
(exit status 2) instead of a traceback after a long run, the ``--help`` description taken from a
tool's docstring, and a check of an output path made before the run starts."""

from __future__ import annotations

import argparse
import os
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from cosim.record.output import nearest_existing, refuse_read_only
from cosim.scheduler import Simulation


def _interrupted_hook(kind: type[BaseException], value: BaseException, traceback: object) -> None:
    if issubclass(kind, KeyboardInterrupt):
        print(f"{Path(sys.argv[0]).name}: interrupted; what it had not yet written is not written",
              file=sys.stderr)
        for stream in (sys.stdout, sys.stderr):  # (what it printed before, into a pipe or a file, kept)
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        os._exit(130)
    _hook_before(kind, value, traceback)  # type: ignore[arg-type]


_hook_before = sys.excepthook
# A tool run as a program reports what its runs measured: a run cut short by Ctrl-C ends the tool,
# nothing of it written (Simulation.raise_interrupts), said in one line, exit 130 (a shell's code for
# an interruption). Not where a tool's functions are imported by another program (the tests).
_program = getattr(sys.modules.get("__main__"), "__file__", None) or "/"
if Path(_program).resolve().parent == Path(__file__).resolve().parent:
    Simulation.raise_interrupts = True
    sys.excepthook = _interrupted_hook


def description(doc: str | None) -> str:
    """The first paragraph of a tool's docstring as one line, for ``ArgumentParser(description=...)``."""
    return " ".join((doc or "").split("\n\n")[0].split())


def positive_int(text: str) -> int:
    """An argparse type: a whole number of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be at least 1")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number above 0")
    return value


def angle_deg(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse type: an angle in degrees strictly between ``lo`` and ``hi``."""

    def angle(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not lo < value < hi:
            raise argparse.ArgumentTypeError(f"{text!r}: must be an angle between {lo:g} and {hi:g} degrees")
        return value

    angle.__name__ = "angle"  # argparse names the type in its message
    return angle


def check_output(parser: argparse.ArgumentParser, path: str | Path | None, option: str,
                 *, text: bool = False, sections: tuple[str, ...] = ()) -> Path | None:
    """Refuse (``parser.error``, exit status 2) an output path that the run could not write at its end.

    The path must not be a directory; its folder must exist or be makeable (its nearest existing
    ancestor a writable directory); an existing file must be writable and, with ``text`` (a markdown
    page whose sections are rewritten), UTF-8 text, and each of its ``sections`` the tool rewrites
    replaceable (:func:`cosim.docsection.section_problem`: a lone or doubled marker was found after the
    whole run, as a traceback, the page's earlier sections already rewritten). Returns the path (None
    when not given)."""
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        parser.error(f"{option} {path}: is a directory")
    if path.exists():
        try:  # (by the permission bits too: root's writes ignore them, and a page made read-only was replaced)
            refuse_read_only(path)
        except PermissionError:
            parser.error(f"{option} {path}: not writable")
        if not os.access(path, os.W_OK):
            parser.error(f"{option} {path}: not writable")
        if text:
            try:
                page = path.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                parser.error(f"{option} {path}: not UTF-8 text")
            except OSError as exc:
                parser.error(f"{option} {path}: {exc.strerror or exc}")
            from cosim.docsection import section_problem

            for name in sections:
                problem = section_problem(page, name)
                if problem is not None:
                    parser.error(f"{option} {path}: {problem}")
        return path
    folder = nearest_existing(path.absolute().parent) or Path(path.absolute().anchor)
    if not folder.is_dir():
        parser.error(f"{option} {path}: {folder} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        parser.error(f"{option} {path}: cannot write in {folder}")
    return path


FIGURE_FORMATS = ("png", "pdf", "svg")  # what the tools' figures are written as, by their file's ending


def check_figure(parser: argparse.ArgumentParser, path: str | Path | None, option: str) -> Path | None:
    """:func:`check_output` for a figure, whose name must also end in a format it can be written as
    (FIGURE_FORMATS): matplotlib refused any other after the whole run, with a traceback, and wrote a
    name without an ending as NAME.png while the tool said it wrote NAME."""
    path = check_output(parser, path, option)
    if path is not None and path.suffix.lower().lstrip(".") not in FIGURE_FORMATS:
        endings = ", ".join(f".{f}" for f in FIGURE_FORMATS)
        parser.error(f"{option} {path}: a figure's name ends in {endings} (the format it is written as)")
    return path


def save_figure(fig: Any, path: Path) -> None:
    """Write the matplotlib figure ``fig`` to ``path``, making its folder first (:func:`check_output`
    lets one be made)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)


def figure_beside(page: str | Path, name: str) -> Path:
    """Where a page's figure goes: ``figures/NAME`` in the page's own folder (docs/validation.md ->
    docs/figures/NAME)."""
    return Path(page).parent / "figures" / name


def command_line(tool: str, argv: list[str] | None = None) -> str:
    """The command that ran a tool, as typed from the project's root: ``python tools/TOOL`` and the
    options it was given (``argv``, else this process's own arguments), quoted where a shell needs it.
    A section a tool writes names this command, so that it regenerates what the section shows."""
    given = sys.argv[1:] if argv is None else list(argv)
    return shlex.join(["python", f"tools/{tool}", *given])


def machine(load_before: float, load_after: float) -> str:
    """The machine a benchmark ran on, as measured: its cores (``os.cpu_count``) and the load
    average before and after the run (other jobs share these machines)."""
    cores = os.cpu_count()
    return (f"{cores if cores is not None else 'an unknown number of'} cores; load average "
            f"{load_before:.1f} before, {load_after:.1f} after")
