"""An FMU built from a pythonfmu model (a Python file holding one ``Fmi2Slave`` class), on demand
and cached: the first use builds it, later uses find it in the cache.

The cache key is the model's own bytes, every extra file packed beside it, the build options and the
pythonfmu version, so a changed model is rebuilt and an unchanged one never is. The build runs
``python -m pythonfmu build`` in a child process: pythonfmu imports the model to read its variables,
and that import must not leave the model's module (or its folder on ``sys.path``) in this process.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from cosim.errors import NO_ROOM
from cosim.record.output import sibling_stem

CACHE_ENV = "COSIM_FMU_CACHE"  # overrides the cache folder (default: $XDG_CACHE_HOME/cosim/fmu)
BUILD_TIMEOUT_S = 300  # a build taking longer than this [s] is reported as failed
_ERRNO = re.compile(r"\[Errno (\d+)\]")  # how a Python error output gives an OSError's number


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
    in its registered variables, which is what pythonfmu serializes).

    A build that fails for want of room (a full disk, a quota, a file-size limit; in the build's
    temporary folder or at ``dest``) raises the OSError of that errno naming ``dest``, the file that
    could not be made: the machine's limit, not the model's fault (FmuBuildError). The folders made
    for ``dest`` go again when it is not written."""
    model, dest = Path(model), Path(dest)
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
            refused = _refused_for_room(said)
            if refused is not None:
                raise OSError(refused, os.strerror(refused), str(dest))
            raise FmuBuildError(f"{model}: pythonfmu build failed ({said[-1] if said else f'exit {done.returncode}'})")
        # the folder made only now, once there is an FMU to put in it: a failed build leaves none
        with _folders_made_for(dest):
            _copy_whole(built[0], dest)
    return dest


def _refused_for_room(lines: list[str]) -> int | None:
    """The errno of a write refused for want of room that pythonfmu's error output ``lines`` reports
    (its last ``[Errno N]``, N one of NO_ROOM), or None."""
    for line in reversed(lines):
        match = _ERRNO.search(line)
        if match and int(match.group(1)) in NO_ROOM:
            return int(match.group(1))
    return None


@contextlib.contextmanager
def _folders_made_for(dest: Path) -> Iterator[None]:
    """Make the folders ``dest`` needs; should the body fail, remove those made here that stay empty
    (an empty cache/<key> folder was left by each build on a full disk). One another process has
    filled meanwhile is left as it is."""
    made = [p for p in (dest.parent, *dest.parent.parents) if not p.exists()]
    dest.parent.mkdir(parents=True, exist_ok=True)
    try:
        yield
    except BaseException:
        for folder in made:  # innermost first
            try:
                folder.rmdir()
            except OSError:  # not empty (another build's), or gone: left as it is
                break
        raise


def _copy_whole(built: Path, dest: Path) -> None:
    """Copy ``built`` to ``dest`` whole or not at all, also when two processes build the same model."""
    part = dest.with_name(f".{sibling_stem(dest.name, 30)}.{os.getpid()}.part")
    try:
        shutil.copyfile(built, part)
        os.replace(part, dest)
    except BaseException as exc:  # a full disk, an interrupt: no part left behind in the cache for ever
        part.unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno in NO_ROOM:  # named as the file it was to be
            raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(dest)) from None
        raise


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
    except OSError as exc:  # a cache that is a file or not writable (the system's error named a folder in it)
        if exc.errno in NO_ROOM:  # the machine's limit, not the scene's: said as the file not written
            raise
        said = "$" + CACHE_ENV if os.environ.get(CACHE_ENV) else f"the default; ${CACHE_ENV} names another"
        raise FmuBuildError(f"{model}: cannot keep its FMU in the FMU cache {folder} ({said}): "
                            f"{exc.strerror or exc}") from None
    return target
