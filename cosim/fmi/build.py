"""An FMU built from a pythonfmu model (a Python file holding one ``Fmi2Slave`` class), on demand
and cached: the first use builds it, later uses find it in the cache.

The cache key is the model's own bytes, every extra file packed beside it, the build options and the
pythonfmu version, so a changed model is rebuilt and an unchanged one never is. The build runs
``python -m pythonfmu build`` in a child process: pythonfmu imports the model to read its variables,
and that import must not leave the model's module (or its folder on ``sys.path``) in this process.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

from cosim.record.output import sibling_stem

CACHE_ENV = "COSIM_FMU_CACHE"  # overrides the cache folder (default: $XDG_CACHE_HOME/cosim/fmu)
BUILD_TIMEOUT_S = 300  # a build taking longer than this [s] is reported as failed


class FmuBuildError(RuntimeError):
    """pythonfmu could not build the FMU; the message holds the model and pythonfmu's own words."""


def cache_dir() -> Path:
    """Where built FMUs are kept: ``$COSIM_FMU_CACHE``, else ``$XDG_CACHE_HOME/cosim/fmu``, else
    ``~/.cache/cosim/fmu``."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "cosim" / "fmu"


def build_fmu(model: str | Path, dest: str | Path, *, extra_files: Iterable[str | Path] = (),
              state: bool = True) -> Path:
    """Build the pythonfmu model ``model`` (a .py file) into the FMU file ``dest`` (written whole or
    not at all). ``extra_files``: files the model imports, packed into the FMU's resources beside it;
    ``state``: declare canGetAndSetFMUstate and canSerializeFMUstate (the model keeps its whole state
    in its registered variables, which is what pythonfmu serializes)."""
    model, dest = Path(model), Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="cosim-fmu-") as tmp:
        command = [sys.executable, "-m", "pythonfmu", "build", "-f", str(model.resolve()), "-d", tmp,
                   *(["--handle-state", "--serialize-state"] if state else []),
                   *(str(Path(f).resolve()) for f in extra_files)]
        try:
            done = subprocess.run(command, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S,
                                  cwd=tmp, check=False)
        except subprocess.TimeoutExpired:
            raise FmuBuildError(f"{model}: pythonfmu build took more than {BUILD_TIMEOUT_S} s") from None
        built = sorted(Path(tmp).glob("*.fmu"))
        if done.returncode != 0 or len(built) != 1:
            said = (done.stderr.strip() or done.stdout.strip()).splitlines()
            raise FmuBuildError(f"{model}: pythonfmu build failed ({said[-1] if said else f'exit {done.returncode}'})")
        part = dest.with_name(f".{sibling_stem(dest.name, 30)}.{os.getpid()}.part")
        try:
            shutil.copyfile(built[0], part)
            os.replace(part, dest)  # whole or not at all, also when two processes build the same model
        except BaseException:  # a full disk, an interrupt: no part left behind in the cache for ever
            part.unlink(missing_ok=True)
            raise
    return dest


def cache_key(model: Path, extra_files: Iterable[Path] = (), state: bool = True) -> str:
    """A digest of everything a built FMU depends on: the model's bytes, each extra file's bytes,
    the build options and the pythonfmu version."""
    from importlib.metadata import version

    digest = hashlib.sha256()
    for path in (model, *extra_files):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    digest.update(f"state={state};pythonfmu={version('pythonfmu')}".encode())
    return digest.hexdigest()[:16]


def cached_fmu(model: str | Path, *, extra_files: Iterable[str | Path] = (), state: bool = True) -> Path:
    """The FMU built from ``model``, from the cache when it is there, else built now and cached.
    Named after the model's file (``wind_gust.py`` -> ``.../<key>/wind_gust.fmu``)."""
    from importlib.util import find_spec

    if find_spec("pythonfmu") is None:
        raise FmuBuildError(f"{model}: building an FMU from a model needs pythonfmu, which is not installed: "
                            "pip install 'cosim[fmi]'")
    model = Path(model)
    extras = [Path(f) for f in extra_files]
    folder = cache_dir()
    target = folder / cache_key(model, extras, state) / f"{model.stem}.fmu"
    try:
        if not target.is_file():
            build_fmu(model, target, extra_files=extras, state=state)
    except OSError as exc:  # a cache that is a file, not writable or full (the system's error named a folder in it)
        said = "$" + CACHE_ENV if os.environ.get(CACHE_ENV) else f"the default; ${CACHE_ENV} names another"
        raise FmuBuildError(f"{model}: cannot keep its FMU in the FMU cache {folder} ({said}): "
                            f"{exc.strerror or exc}") from None
    return target
