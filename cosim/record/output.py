"""Where a recording may go, and the private file it is written to until it is complete.

One rule for every writer of recordings (``cosim run -o``, ``cosim replay --from -o``, a sweep's
``--record``, ``cosim repair``): :func:`check_output` refuses a path that is one of the run's inputs
(the scene file, the recording a restart starts from, however the path is spelled), ``-``, a folder,
anything but a regular file (a device, a pipe, a socket), an existing file that is not an MCAP
recording or is one another program wrote, a read-only file, and a name not ending in ``.mcap``; a
symbolic link is written through. :func:`claim` then creates a private file beside the target
(``NAME.<random>.part``: a unique name, so two runs never share one) and locks it for as long as
the run and its writer process live; a second run aimed at the same target while the first is still
writing is refused. The writer moves the finished file onto the target with one ``os.replace``, so
the target is always either the previous file or a complete recording, never half of one.

The other files the commands write (a sweep's table, record and figure, the figures of ``cosim
plot``) are written whole too (:func:`written_whole`): to a new temporary file of a unique name
beside the target (:func:`new_temporary`, never a file that was there, so never the command's input),
moved onto it once complete, removed if the writing fails or is interrupted.

This module imports only the standard library (and :mod:`cosim.errors`): the writer process loads it.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from cosim.errors import RecordingError

MCAP_MAGIC = b"\x89MCAP0\r\n"
PART_SUFFIX = ".part"


def same_file(a: Path, b: Path) -> bool:
    """Whether paths ``a`` and ``b`` name one file, however spelled (links, ``..``)."""
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except (OSError, RuntimeError):  # (Python 3.11's resolve() raises RuntimeError on a symlink loop)
        return False


def _is_file(path: Path) -> bool:
    """Whether ``path`` is a file; False for a name no file can have (too long: a restart's scene is
    named ``RECORDING:scene.yaml``, past the limit for a recording named in 247 bytes)."""
    try:
        return path.is_file()
    except OSError:
        return False


def check_output(path: str | Path, inputs: Iterable[str | Path] = ()) -> Path:
    """``path`` if a recording may be written there; otherwise a RecordingError (bad input) saying why.

    ``inputs`` are files the run reads (the scene, a recording it restarts from): never overwritten.
    """
    if str(path) == "-":
        raise RecordingError("-: a recording is written to a file, not to standard output; give its name "
                             "(e.g. runs/skip.mcap)")
    path = Path(path)
    if path.is_symlink():  # written where the link points, the link kept (it was replaced by the file)
        path = Path(os.path.realpath(path))
    for source in inputs:
        source = Path(source)
        if _is_file(source) and same_file(path, source):
            raise RecordingError(f"{path}: is the run's own input {str(source)!r}; choose another output (-o)")
    if path.name in ("", ".", "..") or path.name.endswith(PART_SUFFIX):
        raise RecordingError(f"{path}: not a file name for a recording (give e.g. runs/skip.mcap)")
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):  # its folder is made (or refused) next
        return _named_as_a_recording(path, inputs)
    except OSError as exc:
        raise RecordingError(f"{path}: cannot use it as the output ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise RecordingError(f"{path}: is a folder; give the recording's file name (e.g. {path / 'run.mcap'})")
    if not stat.S_ISREG(st.st_mode):
        raise RecordingError(f"{path}: is not a regular file (a device, pipe or socket); a recording "
                             "is written only to a file")
    if _read_only(st.st_mode):
        raise RecordingError(f"{path}: is read-only; it is not replaced")
    try:
        with open(path, "rb") as f:
            head = f.read(len(MCAP_MAGIC))
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read it to check it is a recording ({exc.strerror or exc})") from None
    if head != MCAP_MAGIC:
        raise RecordingError(f"{path}: exists and is not an MCAP recording; it is not overwritten "
                             "(remove it or choose another output)")
    library = _foreign_library(path)
    if library is not None:
        raise RecordingError(f"{path}: exists and is an MCAP recording cosim did not write (written by "
                             f"{library!r}); it is not overwritten (remove it or choose another output)")
    if not _ends_whole(path, st.st_size):  # what it holds is kept by repair alone: replaced, it was lost
        raise RecordingError(f"{path}: exists and is a recording cut short (no MCAP end); it is not replaced: "
                             f"`cosim repair {path}` keeps what it holds (or remove it, or choose another output)")
    return _named_as_a_recording(path, inputs)


def _whole_file(path: Path) -> bool:
    """Whether the MCAP file ``path`` ends as a whole one does (False when it cannot be read)."""
    try:
        return _ends_whole(path, os.stat(path).st_size)
    except OSError:
        return False


def _ends_whole(path: Path, size: int) -> bool:
    """Whether the MCAP file ``path`` (``size`` bytes) ends with the magic its footer is followed by."""
    if size < 2 * len(MCAP_MAGIC):
        return False
    try:
        with open(path, "rb") as f:
            f.seek(size - len(MCAP_MAGIC))
            return f.read(len(MCAP_MAGIC)) == MCAP_MAGIC
    except OSError:
        return True  # unreadable at its end: the other checks decide, as before


def _named_as_a_recording(path: Path, inputs: Iterable[str | Path] = ()) -> Path:
    """``path``, whose name ends in ``.mcap`` as a recording's does (viewers open MCAP files by it);
    otherwise a RecordingError: ``-o skip.png`` wrote a recording a picture viewer could not open.
    The name it suggests is none of ``inputs`` (`repair cut.mcap -o cut.txt` suggested cut.mcap)."""
    if path.name.lower() == ".mcap":  # a hidden file's name has no suffix: it is all name
        raise RecordingError(f"{path}: a recording's file name needs a name before .mcap "
                             f"(give e.g. {path.with_name('run.mcap')})")
    if path.suffix.lower() != ".mcap":
        suggested = path.with_name(path.stem + ".mcap") if path.stem else Path("runs/skip.mcap")
        if any(Path(source).is_file() and same_file(suggested, Path(source)) for source in inputs):
            suggested = suggested.with_name(suggested.stem + "-out.mcap")
        raise RecordingError(f"{path}: a recording's file name ends in .mcap (give e.g. {suggested})")
    return path


METADATA_OP, HEADER_OP = 0x0C, 0x01  # MCAP record opcodes
METADATA_NAME = "cosim"  # the metadata record a cosim recording opens with (written by cosim.record.recorder)


def _foreign_library(path: Path) -> str | None:
    """The library named in the header of an MCAP file cosim did not write (no ``cosim`` metadata
    record among its first records, where a cosim recording holds it, just after the header), or
    None for a recording of cosim's (or one too short or odd to tell: it is replaced as before)."""
    import struct

    try:
        with open(path, "rb") as f:
            data = f.read(1 << 16)
    except OSError:
        return None
    at, library = len(MCAP_MAGIC), None
    for _ in range(8):
        if at + 9 > len(data):
            return None
        op, n = struct.unpack_from("<BQ", data, at)
        body = data[at + 9:at + 9 + n]
        if op == HEADER_OP and len(body) >= 8:
            k = struct.unpack_from("<I", body, 0)[0]
            at_library = 4 + k
            if at_library + 4 <= len(body):
                m = struct.unpack_from("<I", body, at_library)[0]
                library = body[at_library + 4:at_library + 4 + m].decode(errors="replace")
        elif op == METADATA_OP and len(body) >= 4:
            k = struct.unpack_from("<I", body, 0)[0]
            if body[4:4 + k] == METADATA_NAME.encode():
                return None
        elif op != HEADER_OP:
            return library if library is not None else "an unknown writer"
        at += 9 + n
    return library if library is not None else "an unknown writer"


class Claim:
    """A private file ``part`` beside ``target``, locked through ``fd`` while it is written.

    (A plain class rather than a dataclass: the writer process imports this module, and dataclasses
    with what it loads is a tenth of its start-up.)"""

    def __init__(self, target: Path, part: Path, fd: int):
        self.target, self.part, self.fd = target, part, fd
        self.handed_over = False  # the file was moved onto the target or kept for the user: never removed

    def __repr__(self) -> str:
        return f"Claim(target={self.target!r}, part={self.part!r}, fd={self.fd})"

    def release(self, remove: bool) -> None:
        """Close the lock (and remove the private file when ``remove``, unless it was handed over: a
        finished one was moved, a kept one is the user's)."""
        if remove and not self.handed_over:
            with contextlib.suppress(OSError):
                self.part.unlink()
        if self.fd >= 0:
            with contextlib.suppress(OSError):
                os.close(self.fd)
            self.fd = -1


    def hand_over(self) -> None:
        """Close the lock, the file handed over (moved onto the target, or kept under its name and
        said so): a later release, even one asked to remove it (a run discarding its recording
        after a failure), leaves it."""
        self.release(remove=False)
        self.handed_over = True


def being_written(part: str) -> bool:
    """True when another run holds the lock of ``part`` (a run still writing it)."""
    try:
        fd = os.open(part, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False
    finally:
        os.close(fd)
    return False


NAME_MAX = 255  # bytes in a file name (Linux, macOS and Windows file systems alike)


def sibling_stem(name: str, suffix_bytes: int) -> str:
    """``name``, or, when ``suffix_bytes`` more would not fit in a file name, its start and a short
    digest of the whole (``start~1a2b3c4d``): the stem of a temporary or private file beside a target
    whose own name is already near the limit (a recording named in 245 bytes was refused: its private
    file's name was too long). The same name always gives the same stem."""
    raw = os.fsencode(name)
    if len(raw) + suffix_bytes <= NAME_MAX:
        return name
    import hashlib

    digest = hashlib.sha256(raw).hexdigest()[:8]
    start = raw[:NAME_MAX - suffix_bytes - len(digest) - 1].decode("utf-8", "ignore")  # not cut inside a character
    return f"{start}~{digest}"


def beside(path: Path, ending: str) -> Path:
    """``path``'s sibling named its stem and ``ending`` (``-repaired.mcap``), the stem shortened
    (:func:`sibling_stem`) when the whole would not fit in a file name: a name a command picks for
    itself is one the file system takes (``cosim repair`` of a 247-byte name failed: "File name too
    long")."""
    return path.with_name(sibling_stem(path.stem, len(os.fsencode(ending))) + ending)


LOCKING_SUFFIX = ".lock"  # a private file's name while it is locked, before it is a .part (as long)


def _private_file(path: Path) -> tuple[int, str]:
    """Create ``NAME.<random>.part`` beside ``path``, new (never an existing file), open for reading
    and writing and locked: (descriptor, name). It is made and locked as ``NAME.<random>.lock`` and
    only then given its .part name, so that another run never finds it unlocked (it took a live run's
    file for one an earlier run had left, and said to repair it; its probe's shared lock could make
    this run's own lock fail, said as a recording that could not be written). Its mode is what any
    new file of the user's gets (0666 less the umask, as for the figures and tables the other
    commands write), not tempfile's 0600: the recording it becomes is for viewers and colleagues to
    read."""
    import secrets

    for _ in range(100):
        stem = os.path.join(path.parent, f"{_part_stem(path)}.{secrets.token_hex(4)}")
        locking, name = stem + LOCKING_SUFFIX, stem + PART_SUFFIX
        try:
            fd = os.open(locking, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # (no other process knows the name: never refused)
            rename_new(locking, name)
        except FileExistsError:
            os.close(fd)
            os.unlink(locking)
            continue
        except BaseException:
            os.close(fd)
            with contextlib.suppress(OSError):
                os.unlink(locking)
            raise
        return fd, name
    raise FileExistsError(f"{path}: no free private file name beside it")


def _part_stem(path: Path) -> str:
    """The stem of a recording's private files: ``NAME.<8 hex digits>.part`` beside it."""
    return sibling_stem(path.name, 1 + 8 + len(PART_SUFFIX))


def claim(path: str | Path, replacing: Claim | None = None) -> Claim:
    """Create and lock the private file a recording of ``path`` is written to (its folder exists).
    ``replacing``: this run's own claim of ``path`` that the new one takes over from (a recording
    rebuilt after its writer died: :mod:`cosim.record.salvage`), still locked while it is read.

    Raises RecordingError when another run is writing ``path`` now, OSError when the folder cannot
    be written.
    """
    import glob  # here: the writer process imports this module for finish() only, and starts sooner

    path = Path(path)
    fd, name = _private_file(path)  # (locked already)
    mine = Claim(path, Path(name), fd)
    try:
        # NAME.<8 hex digits>.part, as _private_file names them: NAME.* took another target's (a.mcap.x.mcap's
        # private file was "another run writing a.mcap")
        pattern = os.path.join(glob.escape(str(path.parent)), glob.escape(_part_stem(path)) + "." + "[0-9a-f]" * 8
                               + PART_SUFFIX)
        mine_too = {os.path.abspath(name)} | ({os.path.abspath(replacing.part)} if replacing is not None else set())
        left = []
        for other in glob.glob(pattern):
            if os.path.abspath(other) in mine_too:
                continue
            if being_written(other):
                raise RecordingError(f"{path}: another run is writing it now ({Path(other).name}); "
                                     "wait for it or choose another output (-o)")
            if not os.path.lexists(other):
                # removed as it was looked at: a run that ended (it removes its file, then lets go of
                # its lock), not one an earlier run left (said so, with a repair of a file not there)
                continue
            left.append(Path(other).name)
        # a whole one is a recording an earlier run could not move onto its target (its folder made
        # read-only): said to be cut short, with a repair that then refused it as whole already
        whole = sorted(name for name in left if _whole_file(path.parent / name))
        cut = sorted(name for name in left if name not in whole)
        if cut or whole:
            import warnings
        if cut:  # a run killed with its writer: what it recorded is there still, until removed
            warnings.warn(f"{path}: beside it, {', '.join(cut)} is what an earlier run left cut short "
                          f"(killed with its writer); cosim repair {path.parent / cut[0]} makes it a "
                          "valid recording", UserWarning, stacklevel=2)
        if whole:
            warnings.warn(f"{path}: beside it, {', '.join(whole)} is a whole recording an earlier run could not "
                          f"move onto it; give it a name ending in .mcap to keep it (mv {path.parent / whole[0]} "
                          f"{path.parent / (_part_stem(path) + '.kept.mcap')})", UserWarning, stacklevel=2)
    except BaseException:
        mine.release(remove=True)
        raise
    return mine


def rename_new(source: str | Path, target: str | Path) -> None:
    """Give the file ``source`` the name ``target``, which no file may have: a FileExistsError when one
    does, left as it is (os.rename would replace it, a file of the user's that happened to have it).
    A hard link then the old name removed; where links are not supported, a check then a rename."""
    try:
        os.link(source, target)
    except FileExistsError:
        raise
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EMLINK, errno.ENOSYS):
            raise
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(target)) from None
        os.rename(source, target)
        return
    os.unlink(source)


def finish(part: str | Path, target: str | Path) -> None:
    """Move a complete recording onto its target in one step."""
    os.replace(part, target)


def remove_quietly(path: Path) -> None:
    """Remove a file (or an empty folder) a command made, if it is there; never raises."""
    try:
        if path.is_dir():
            path.rmdir()
        else:
            path.unlink(missing_ok=True)
    except OSError:
        pass  # already failing: the error being reported matters more than this leftover


TMP_SUFFIX = ".tmp"  # the ending of a command's temporary files (NAME.<8 hex digits>.tmp beside NAME)


def new_temporary(path: Path, suffix: str = TMP_SUFFIX, prefix: str = "") -> Path:
    """Create a new, empty file beside ``path`` to write ``path``'s content to before it is moved onto
    it: ``<prefix>NAME.<8 hex digits><suffix>`` (the stem shortened as :func:`sibling_stem` does near
    the name limit), made with ``O_EXCL``, so it is never a file that was there. A fixed name (``NAME.tmp``)
    was written over and then removed whatever it held: ``cosim repair victim.mcap.tmp -o
    victim.mcap`` lost the only copy of the recording it was asked to mend, as did ``plot`` and
    ``render`` of a recording so named; two commands writing one target shared it (one repair
    truncated the file the other had memory-mapped: SIGBUS). Its mode is any new file's (0666 less
    the umask), as the file it becomes is the user's. An OSError names ``path``, the file meant (its
    folder missing, no inode left), not the temporary the user never asked for."""
    import secrets

    for _ in range(100):
        stem = sibling_stem(path.name, len(prefix) + 1 + 8 + len(suffix))
        tmp = path.with_name(f"{prefix}{stem}.{secrets.token_hex(4)}{suffix}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue  # someone's file: another name
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary file name beside it", str(path))


@contextmanager
def written_whole(path: Path) -> Iterator[Path]:
    """A new temporary file beside ``path`` to write to (:func:`new_temporary`), moved onto ``path``
    once written and removed if the writing fails or is interrupted: ``path`` holds the whole new file
    or what it held before, never half of one. A failed write is an OSError naming ``path``, not the
    temporary (a writer that names no file, such as an image library on a full disk, is taken to have
    failed on it too)."""
    path = Path(path)
    refuse_read_only(path)
    tmp = new_temporary(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        remove_quietly(tmp)
        raise named_for(exc, tmp, path) from None
    except BaseException:
        remove_quietly(tmp)
        raise


def refuse_read_only(path: Path) -> None:
    """A PermissionError naming ``path`` when it is a file no one may write to: a command's output
    replaces a file by moving a new one onto it, which its folder allows (a render, a plot or a page
    silently replaced a file made read-only, where a run's recording is refused so)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):  # none there, not to be seen, no path at all (a NUL in it): the
        return  # writing says what is wrong, if anything
    if stat.S_ISREG(st.st_mode) and _read_only(st.st_mode):
        raise PermissionError(errno.EACCES, "is read-only; it is not replaced", str(path))


def _read_only(mode: int) -> bool:
    """Whether a file of ``mode`` is one no one may write to (by its permission bits, which root's
    writes ignore: a file made read-only is refused by every user alike)."""
    return not mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH)


def named_for(exc: OSError, tmp: Path, path: Path) -> OSError:
    """``exc``, raised writing ``tmp`` (the temporary name of ``path``), as the error to report: one
    naming ``path`` when it named ``tmp`` or no file at all (a writer that names no file, such as an
    image library on a full disk, is taken to have failed on it), else ``exc`` itself."""
    if exc.filename is None or Path(os.fsdecode(exc.filename)) == tmp:
        return OSError(exc.errno, exc.strerror or str(exc), str(path))
    return exc


def move_together(staged: list[tuple[Path, Path]]) -> None:
    """Move each (temporary file, target) of ``staged`` onto its target, all or none: a target's
    previous file is set aside until every move is done, and if one fails, the targets moved so far
    are taken back and the previous files put back. An OSError names the target that could not be
    put in place."""
    for _, path in staged:  # (before any move: all or none)
        refuse_read_only(path)
    done: list[tuple[Path, Path | None, bool]] = []  # (target, its previous file set aside, the new one in place)
    try:
        for tmp, path in staged:
            kept = _set_aside(path) if path.is_file() else None
            done.append((path, kept, False))
            try:
                os.replace(tmp, path)
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
            done[-1] = (path, kept, True)
    except BaseException:
        for path, kept, moved in reversed(done):
            try:
                if kept is not None:
                    os.replace(kept, path)
                elif moved:
                    path.unlink()
            except OSError:
                pass  # already failing: the error being reported matters more than this one
        raise
    for _, kept, _ in done:
        if kept is not None:
            remove_quietly(kept)


def _set_aside(path: Path) -> Path:
    """Move the file ``path`` to a new name of its own beside it (``NAME.<random>.old``); that name."""
    import tempfile

    fd, name = tempfile.mkstemp(prefix=f"{sibling_stem(path.name, 16)}.", suffix=".old", dir=path.parent)
    os.close(fd)
    try:
        os.replace(path, name)
    except BaseException:
        remove_quietly(Path(name))
        raise
    return Path(name)


def nearest_existing(path: Path) -> Path | None:
    """``path``, or the nearest of its parents that exists (None when none does): where an output's
    folders would be made from, and a file there stands in their way."""
    return next((p for p in (path, *path.parents) if p.exists()), None)


@contextmanager
def output_folder(folder: Path) -> Iterator[Path]:
    """Make ``folder`` (and its parents) for a command's outputs; if the writing fails, each folder
    made here that is still empty goes again, the deepest first: a failed command leaves no empty
    folder behind. A NotADirectoryError naming ``folder`` when it, or the nearest of its parents
    that exists, is a file: ``-o run.mcap/x.png`` was refused as 'File exists', naming neither."""
    made = [f for f in (folder, *folder.parents) if not f.exists()]  # the deepest first
    nearest = nearest_existing(folder)
    if nearest is not None and not nearest.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, f"cannot be made: {nearest} is a file, not a folder", str(folder))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        yield folder
    except BaseException:
        for path in made:
            remove_quietly(path)  # only when empty
        raise


COPY_BLOCK = 1 << 20  # bytes read and written at a time by copy_file


def copy_file(source: Path, target: Path,
              spans: Iterable[tuple[int, int | None] | tuple[int, int | None, bytes]] = ((0, None),)) -> None:
    """Copy the file ``source`` to ``target`` by plain reads and writes: its byte ``spans`` (start,
    end; end None: to the end of the file), one after another, each followed by the bytes a third
    item gives (what a repair writes in place of a stretch it leaves out), by default the whole
    file. Not shutil.copyfile: its sendfile copy fails on a full disk with the source's name on the
    error, where the target's is due (:func:`written_whole` names the output for an error that names
    no file); a read error names ``source``."""
    with open(source, "rb") as src, open(target, "wb") as dst:
        for start, end, *after in spans:
            src.seek(start)
            left = None if end is None else end - start
            while left is None or left > 0:
                try:
                    block = src.read(COPY_BLOCK if left is None else min(COPY_BLOCK, left))
                except OSError as exc:
                    raise OSError(exc.errno, exc.strerror or str(exc), str(source)) from None
                if not block:
                    break
                dst.write(block)
                left = None if left is None else left - len(block)
            for extra in after:
                dst.write(extra)
