"""Every example the README and the ``--help`` texts give is a command that works: each is run (made
shorter where it would take long) and must exit 0; the README's sample output has the shape and the
skip count of a real run of the reference skip."""

from __future__ import annotations

import argparse
import importlib.util
import re
import shlex
from collections.abc import Iterator
from pathlib import Path

import pytest

from cosim.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PLACEHOLDER = re.compile(r"\b[A-Z]{2,}\b")  # HOST, SCENE, RUN, DIR: a template, not a command

# What is added to a documented command so that it runs in seconds (the same command otherwise):
# runs end at 0.6 s (after the 0.5 s checkpoint the replay example restarts from), a restarted run
# 20 ms after its checkpoint, an animation at 0.1 s, sweeps list their points (the full sweep is the
# slow test below), a live view is unpaced on a free port and stops with the run.
SHORTER = {
    "run": ["--until", "0.6"],
    "render": ["--to", "0.1"],
    "sweep": ["--dry-run"],
}


def readme_commands(text: str) -> Iterator[str]:
    """Each ``cosim ...`` command line in the README's code blocks, without its ``$`` prompt or
    trailing comment (a ``&&`` chain gives each of its cosim commands)."""
    for block in re.findall(r"```[^\n]*\n(.*?)```", text, re.S):
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line.strip().removeprefix("$ "))
            for part in line.split("&&"):
                if part.strip().startswith("cosim "):
                    yield part.strip()


def readme_inline_commands(text: str) -> Iterator[str]:
    """Each `` `cosim ...` `` command quoted in the README's prose with arguments (`cosim fmu export`
    alone names a command, it is no example)."""
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    for command in re.findall(r"`(cosim [^`]+)`", prose):
        if not all(word.isalpha() for word in command.split()):
            yield command


def readme_set_examples(text: str) -> list[str]:
    """Each `` `--set KEY=VALUE` `` the README's prose gives (not the form `key.path=value` itself)."""
    found = re.findall(r"`--set ([^`\s]+=[^`\s]+)`", re.sub(r"```.*?```", "", text, flags=re.S))
    return [example for example in found if not example.startswith("key.path=")]


def shortened(command: str) -> list[str]:
    """The argv (after ``cosim``) of a documented command, made short by :data:`SHORTER`."""
    argv = shlex.split(command)[1:]
    extra = list(SHORTER.get(argv[0], []))
    if argv[0] == "render" and any(a.endswith(".png") for a in argv):
        extra = []  # one frame: --from and --to apply to an animation only
    if argv[0] == "replay" and "--from" in argv:
        extra = ["--until", str(float(argv[argv.index("--from") + 1]) + 0.02)]
    if "--live" in argv:
        i = argv.index("--live")
        if i + 1 == len(argv) or argv[i + 1].startswith("-"):
            argv.insert(i + 1, "127.0.0.1:0")
        extra += ["--live-speed", "0", "--live-linger", "0"]
    return [*argv, *extra, *(["-q"] if argv[0] in ("run", "replay", "render") else [])]


def test_the_readme_gives_runnable_commands():
    """The parser finds the README's commands (so the test below runs something)."""
    commands = list(readme_commands(README.read_text()))
    assert "cosim run scenarios/skip.yaml" in commands
    assert any(c.startswith("cosim replay") and "--from" in c for c in commands)
    assert any(c.startswith("cosim render") for c in commands)


def test_every_readme_command_exits_0(tmp_path, monkeypatch, capsys):
    """Run in order in a fresh folder holding the scenes, each README command exits 0; one with a
    placeholder (``tcp://HOST:8786``) is a template and is only parsed."""
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    monkeypatch.chdir(tmp_path)
    failed = []
    text = README.read_text()
    for command in [*readme_commands(text), *readme_inline_commands(text)]:
        argv = shortened(command)
        if PLACEHOLDER.search(command):
            build_parser().parse_args(argv)
            continue
        code = main(argv)
        err = capsys.readouterr().err
        if code != 0:
            failed.append(f"{command} -> exit {code}: {err.strip()[-300:]}")
    assert not failed, "\n".join(failed)
    assert (tmp_path / "runs" / "skip.mcap").is_file()


def test_the_readmes_set_examples_are_accepted_by_the_reference_scene(capsys):
    """Each `--set KEY=VALUE` the README's prose gives is a value the reference skip accepts."""
    examples = readme_set_examples(README.read_text())
    assert examples
    for example in examples:
        assert main(["validate", str(ROOT / "scenarios" / "skip.yaml"), "--set", example]) == 0, example
    capsys.readouterr()


@pytest.mark.slow
def test_the_readme_sweep_of_20_throws_runs(tmp_path, monkeypatch):
    """`cosim sweep scenarios/sweeps/skip_grid.yaml` as the README gives it: 20 throws, a table and a figure."""
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "scenarios/sweeps/skip_grid.yaml"]) == 0
    assert (tmp_path / "runs" / "skip_grid.csv").is_file() and (tmp_path / "runs" / "skip_grid.png").is_file()


# --- the examples in the --help texts -------------------------------------------------------------

def help_examples() -> list[tuple[tuple[str, ...], str | None, str]]:
    """(command path, option or None for a positional, example value) of every ``e.g. VALUE`` in
    the help of every command and subcommand."""
    found = []

    def walk(parser: argparse.ArgumentParser, path: tuple[str, ...]) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, (*path, name))
            elif action.help:
                for value in re.findall(r"e\.g\.\s+([^\s)]+)", action.help):
                    found.append((path, action.option_strings[0] if action.option_strings else None, value))

    walk(build_parser(), ())
    return found


# What each command needs besides the example itself, to run briefly ({tmp}: the test's folder).
HELP_BASES = {
    ("run",): ["scenarios/skip.yaml", "--until", "0.05", "--no-record", "-q"],
    ("validate",): ["scenarios/skip.yaml"],
    ("bench", "accuracy"): ["--quick", "--until", "0.12", "-o", "{tmp}/accuracy", "-q"],  # through the first hit
    ("fmu", "export"): ["scenarios/skip.yaml", "-o", "{tmp}/skip.fmu"],
}
NEEDS = {("fmu", "export"): "pythonfmu"}  # an optional extra the command needs


def test_the_help_texts_have_examples():
    """There are examples to check, among them the run/validate --set example."""
    paths = {path for path, _, _ in help_examples()}
    assert ("run",) in paths and ("validate",) in paths


@pytest.mark.parametrize(("path", "option", "value"), help_examples(),
                         ids=lambda v: " ".join(v) if isinstance(v, tuple) else str(v))
def test_every_help_example_works(path, option, value, tmp_path, monkeypatch, capsys):
    """Each ``e.g.`` in a help text, given to its command, is accepted and the command exits 0."""
    assert path in HELP_BASES, f"no way to run the example of `cosim {' '.join(path)}` (add it to HELP_BASES)"
    if path in NEEDS and importlib.util.find_spec(NEEDS[path]) is None:
        pytest.skip(f"{NEEDS[path]} is not installed")
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    monkeypatch.chdir(tmp_path)
    base = [arg.format(tmp=tmp_path) for arg in HELP_BASES[path]]
    example = [value] if option is None else [option, value]
    assert main([*path, *example, *base]) == 0, capsys.readouterr().err


# --- the README's sample output -------------------------------------------------------------------

NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")


def readme_run_block() -> list[str]:
    """The lines the README shows `cosim run scenarios/skip.yaml` printing (without `...` lines)."""
    text = README.read_text()
    block = re.search(r"\$ cosim run scenarios/skip\.yaml\n(.*?)\n\$ ", text, re.S).group(1)
    return [line for line in block.splitlines() if line.strip() not in ("...", "")]


def shape(line: str) -> str:
    """A summary line with its numbers taken out (and the README's trailing `...` of a line it cuts,
    and the note of a first run that compiled the kernels)."""
    line = re.sub(r", of which [^;]* compiling kernels once[^;]*;", ";", line).replace(" (compiling left out)", "")
    return NUMBER.sub("#", line.removesuffix(" ..."))


def test_the_readme_run_output_is_what_the_reference_skip_prints(tmp_path, monkeypatch, capsys):
    """Each line the README shows is, numbers aside, a line the real run prints, in the same order;
    the skip count and the final stage are the run's, and each skip shown is the run's within 10%."""
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    monkeypatch.chdir(tmp_path)
    assert main(["run", "scenarios/skip.yaml", "-q"]) == 0
    printed = capsys.readouterr().out.splitlines()
    shown = readme_run_block()
    shapes = [shape(line) for line in printed]
    at = 0
    for line in shown:  # a line the README cuts short with `...` is the start of the printed one
        match = next((k for k in range(at, len(shapes)) if shapes[k].startswith(shape(line))), None)
        assert match is not None, f"the README shows a line the run does not print (in this order): {line!r}"
        at = match + 1
    summary = {line.split(":")[0].strip(): line for line in printed}
    real = re.search(r"skips: (\d+);.*final stage: (\S+)", "\n".join(printed)).groups()
    claimed = re.search(r"skips: (\d+);.*final stage: (\S+)", "\n".join(shown)).groups()
    assert claimed == real
    for line in shown:
        key = line.split(":")[0].strip()
        if key.startswith("skip ") and key in summary:
            for a, b in zip(NUMBER.findall(line), NUMBER.findall(summary[key]), strict=True):
                assert abs(float(a) - float(b)) <= 0.1 * max(abs(float(b)), 1.0), (line, summary[key])
