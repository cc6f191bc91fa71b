"""Failures said as what they are (docs/reliability.md): a component module that fails as it is
imported is the scene's bad component type, a text where a message holds a number is the
component's failure, and an FMU that cannot be unpacked or built for want of room is the machine's
limit, said of the file that could not be written, with nothing half-written left.

Before: an import failing with anything but an ImportError was an internal error (``sys.exit(3)``:
no word at all, exit 3); ``Number("abc")`` was an internal TypeError from the finiteness check; an
FMU unpacked into a full ``$TMPDIR`` was bad input naming no file and left its half-unpacked folder
at each try; ``fmu export`` on a full disk was an internal error naming a deleted temporary file,
and the FMU cache kept an empty key folder of each failed build.
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from cosim.cli import main
from cosim.component import Component, Port
from cosim.examples import Number
from tests.cli_toys import one_error_line
from tests.fmu_toys import GUST_MODEL, fmu_cache, gust_scene  # noqa: F401

ROOT = Path(__file__).resolve().parents[1]
TOO_LARGE = os.strerror(27)  # EFBIG, "File too large": what a file-size limit refuses a write with
FILE_LIMIT = 30 << 10  # [bytes] a file-size limit below the unpacked gust FMU's files and any built FMU
WAIT_S = 300  # longest wait for a command of its own process (an FMU build takes seconds; never a measured time)

PING_PONG = """
dt: 0.001
until: 0.01
components:
  ping: {{type: "cosim.examples:Ping"}}
  pong: {{type: "{pong}"}}
connections:
  - ping.out -> pong.inp
  - {{from: pong.out, to: ping.inp, delay: 1, initial: {{value: 0.0}}}}
"""


class TextOut(Component):
    """Publishes the text "abc" in its Number's float field from t = 5 ms on."""

    inputs: ClassVar[dict[str, Port]] = {"inp": Port(Number, "x", required=True)}
    outputs: ClassVar[dict[str, Port]] = {"out": Port(Number)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"out": Number("abc" if t >= 0.005 else 1.0)}


def _limited() -> None:
    """In the child process: a file-size limit standing in for a full disk."""
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT, FILE_LIMIT))


def _cosim(args: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess:
    """``cosim ARGS`` in a process of its own under the file-size limit, with ``env`` added."""
    return subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=WAIT_S, preexec_fn=_limited,
                          env={**os.environ, "PYTHONPATH": str(ROOT), **env})


def test_a_component_module_failing_as_it_is_imported_is_said_on_its_key(tmp_path, monkeypatch, capsys):
    """1/0, a SyntaxError (with its file and line) and sys.exit(3) in a component's module: exit 2 on
    ``components.pong.type``, as an ImportError is; a Ctrl-C while it imports stays a Ctrl-C."""
    package = tmp_path / "failpkg_said"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "zero.py").write_text("1/0\n")
    (package / "syntax.py").write_text("x = 1\ndef (\n")
    (package / "leaves.py").write_text("import sys\nsys.exit(3)\n")
    (package / "interrupted.py").write_text("raise KeyboardInterrupt\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("COSIM_COMPONENT_PACKAGES", "failpkg_said")
    scene = tmp_path / "s.yaml"
    said = {"zero": "ZeroDivisionError: division by zero",
            "syntax": f"SyntaxError: invalid syntax (at {package / 'syntax.py'}:2)",
            "leaves": "it called sys.exit(3) as it was imported"}
    try:
        for module, why in said.items():
            scene.write_text(PING_PONG.format(pong=f"failpkg_said.{module}:X"))
            assert main(["validate", str(scene)]) == 2
            assert one_error_line(capsys.readouterr().err) == (
                f"error: {scene}: components.pong.type: component type 'failpkg_said.{module}:X': cannot import "
                f"'failpkg_said.{module}' ({why})")
        from cosim.registry import resolve

        with pytest.raises(KeyboardInterrupt):
            resolve("failpkg_said.interrupted:X")
    finally:
        for name in [n for n in sys.modules if n.partition(".")[0] == "failpkg_said"]:
            del sys.modules[name]


def test_a_text_in_a_float_field_is_the_components_failure(tmp_path, capsys):
    """A component publishing Number("abc") fails as one publishing NaN does: its name, the time, the
    port and field, and what it held, exit 1, the recording's status ``failed`` (it was an internal
    TypeError from math.isfinite). The same for a float array given texts."""
    from components.messages import Wrench
    from cosim.record.reader import Recording

    scene = tmp_path / "s.yaml"
    scene.write_text(PING_PONG.format(pong="tests.test_failure_paths_said:TextOut"))
    out = tmp_path / "s.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 1
    reason = "component 'pong' failed at t = 0.005 s: output 'out' field 'value': must be a number, got str"
    assert one_error_line(capsys.readouterr().err) == f"error: {reason}"
    status = Recording(out).status()
    assert status.status == "failed" and status.reason == reason
    texts = Wrench(force=np.array(["a", "b", "c"]), torque=np.zeros(3))
    assert texts.first_invalid() == ("force", "must be an array of numbers, got an array of <U1")
    assert Number(float("nan")).first_invalid() == ("value", "non-finite")  # NaN's fault as it was
    assert Number(1.0).first_invalid() is None


def test_an_fmu_that_cannot_be_unpacked_for_want_of_room_leaves_nothing_and_names_the_folder(tmp_path):
    """Unpacking the gust FMU into a $TMPDIR under a file-size limit: the OSError of the limit naming
    the folder it was unpacked to (which the command line says as ``FOLDER: cannot be written
    (File too large)``, exit 1), and that folder removed, at every try; ``validate`` names the
    folder too, exit 1 (it said exit 2, the scene's values), and leaves nothing in $TMPDIR (each try
    left a half-unpacked folder). (The FMU is built: the [fmi] extra, skipped without it.)"""
    pytest.importorskip("pythonfmu")
    pytest.importorskip("fmpy")
    from cosim.fmi.build import cached_fmu

    fmu = cached_fmu(GUST_MODEL)  # built here, with no limit: the child only unpacks it
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    driver = textwrap.dedent(f"""
        from pathlib import Path
        from components.fmu.instance import _unpack
        from cosim.cli import report
        for _ in range(2):
            try:
                _unpack(Path({str(fmu)!r}))
            except OSError as exc:
                print(report(exc, "validate"))
        """)
    done = subprocess.run([sys.executable, "-c", driver], cwd=tmp_path, capture_output=True, text=True,
                          timeout=WAIT_S, preexec_fn=_limited,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "TMPDIR": str(temporary)})
    assert done.stdout.split() == ["1", "1"], done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith(f"error: {temporary}/cosim-fmu-")
                                   and line.endswith(f": cannot be written ({TOO_LARGE})") for line in lines)
    assert not list(temporary.iterdir())

    scene = tmp_path / "g.yaml"
    scene.write_text(gust_scene())
    done = _cosim(["validate", str(scene)], tmp_path, TMPDIR=str(temporary))
    assert done.returncode == 1  # the machine's limit, not the scene's values (it said exit 2, bad input)
    line = one_error_line(done.stderr)
    assert line.startswith(f"error: {temporary}/cosim-fmu-") and line.endswith(f": cannot be written ({TOO_LARGE})")
    assert not list(temporary.iterdir())


def test_an_fmu_built_for_want_of_room_is_said_of_its_file_and_leaves_nothing(tmp_path):
    """``fmu export`` under a file-size limit: ``error: out.fmu: cannot be written (File too large)``,
    exit 1, no out.fmu and nothing in $TMPDIR (an internal error naming a deleted temporary file).
    A model built into the FMU cache so: the file it was to be, exit 1, and no empty key folder left
    in the cache. (The [fmi] extra: skipped without it.)"""
    pytest.importorskip("pythonfmu")
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    shutil.copy(ROOT / "scenarios" / "ping_pong.yaml", tmp_path / "pp.yaml")
    done = _cosim(["fmu", "export", "pp.yaml", "--preset", "none", "--output-var", "v=ping.out.value",
                   "-o", "out.fmu"], tmp_path, TMPDIR=str(temporary))
    assert done.returncode == 1
    assert one_error_line(done.stderr) == f"error: out.fmu: cannot be written ({TOO_LARGE})"
    assert not (tmp_path / "out.fmu").exists()
    assert not list(temporary.iterdir())

    cache = tmp_path / "cache"
    model = tmp_path / "gust_model.py"
    shutil.copy(GUST_MODEL, model)
    scene = tmp_path / "g.yaml"
    scene.write_text(gust_scene(f"model: {model.name}"))
    done = _cosim(["validate", str(scene)], tmp_path, TMPDIR=str(temporary), COSIM_FMU_CACHE=str(cache))
    assert done.returncode == 1
    line = one_error_line(done.stderr)
    assert line.startswith(f"error: {cache}/") and line.endswith(f"/gust_model.fmu: cannot be written ({TOO_LARGE})")
    assert not cache.exists() or not list(cache.iterdir())
    assert not list(temporary.iterdir())
