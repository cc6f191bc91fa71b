"""``cosim fmu``'s command line (cosim.fmi.command): its help and its one-line errors."""

from __future__ import annotations

import pytest

from cosim.cli import main
from tests.cli_toys import one_error_line


def _exit_code(argv: list[str]) -> int:
    """main's exit code, argparse's SystemExit included."""
    try:
        return main(argv)
    except SystemExit as exit_:
        return int(exit_.code or 0)


def test_the_export_help_is_plain_text(capsys):
    """The description is the module's docstring, whose reST literals (``--step``) were printed with
    their backticks: it reads --step."""
    assert _exit_code(["fmu", "export", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "``" not in text
    assert "By default the FMU shows what the throw preset finds in the scene" in text
    assert "--step is the default communication step written into the FMU" in text


@pytest.mark.parametrize(("argv", "said"), [
    (["fmu"], "error: cosim fmu: the following arguments are required: command"),
    (["fmu", "import"], "error: cosim fmu: argument command: invalid choice: 'import' (choose from 'export')"),
])
def test_fmu_without_its_command_names_what_is_missing_as_cosim_does(capsys, argv, said):
    """``cosim fmu`` alone said "required: fmu_command", a variable's name; it says "command", as
    ``cosim`` alone does, and a wrong one lists the choice."""
    assert _exit_code(argv) == 2
    assert one_error_line(capsys.readouterr().err) == said
    assert _exit_code([]) == 2
    assert one_error_line(capsys.readouterr().err) == "error: cosim: the following arguments are required: command"
