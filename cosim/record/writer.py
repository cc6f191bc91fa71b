"""Where a recording's records go: an MCAP writer in a separate process, fed in batches.

Compressing a recording and writing it costs a good part of what the physics costs, so it happens
in a second process, on another core, while the simulation goes on. The simulating process packs
each message into a record (its protobuf payload, :meth:`cosim.codec.proto_codec.ProtoCodec.write`;
for the few JSON types a binary record, :meth:`cosim.codec.json_codec.MessageCodec.write`; a
checkpoint into plain data, :func:`cosim.codec.json_codec.plain_state`), gathers records straight in
the free space of a ring in shared memory (:class:`cosim.codec.records.Stage`,
:mod:`cosim.record.ring`) and hands them over in batches; the writer copies each payload, writes
the JSON text of the others with :mod:`cosim.codec.jsontext` (the same functions
:func:`cosim.codec.json_codec.encode` uses, so the bytes do not depend on where they are made) and
each checkpoint's protobuf (:func:`cosim.codec.state_proto.state_bytes`: its arrays' bytes copied
once), and the file with the Foxglove SDK's MCAP writer (compiled; zstd chunks with chunk, message, attachment
and metadata indexes). It also makes the viewer channels from the recorded messages
(:mod:`cosim.record.derive`), so the simulating process neither makes the frames nor imports the
viewer modules. The writer starts in a few tens of milliseconds, and imports what it makes the
viewer channels with on a thread of its own as it starts (``preloads``); ``cosim run`` starts it
before anything else (:func:`prestart`), and hands it the file once it is known (:meth:`_Writer.hand_over`).
It is kept off the simulation's core (:class:`WriterPlacement`). It also makes
recordings sturdier: if the simulating process dies, the writer sees its control pipe close and
still finishes a valid, indexed file, with the records of every step the simulation had completed
(those it had not yet sent too: the recorder marks each step in the ring, :meth:`ProcessSink.mark`).
If the writer dies instead, the simulating process rebuilds the recording from what the writer left
on disk, what the ring still holds and its own copy of the schemas, channels, metadata and
attachments (:mod:`cosim.record.salvage`), and the run ends with a :class:`SinkError` saying so.
If the file system refuses the writer's writes (the disk full), the file is closed in place where it
was cut, ending with the run's ``failed`` status (:mod:`cosim.record.seal`): everything that fitted
is kept.

Each channel's messages are numbered from 1 in the order they are written (the MCAP sequence).
:class:`InProcessSink` does the same work in the calling process (used where a second process is
not wanted).
"""

from __future__ import annotations

import builtins
import contextlib
import errno
import io
import logging
import os
import re
import signal
import sys
import warnings
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

from cosim.codec.jsontext import RecordLayout, Renderer, renderer
from cosim.codec.records import BYTES, MESSAGE, OTHER, Stage, Write, iter_records, read_other
from cosim.codec.state_proto import state_bytes
from cosim.errors import NO_ROOM, CosimError, shortened
from cosim.record.derive import (
    RELAY_TAG,
    Derivation,
    preload,
    relay_warnings,
    relayed_warnings,
    use_site_dirs,
)
from cosim.record.output import Claim, claim, finish, new_temporary, rename_new, sibling_stem
from cosim.record.ring import STALL_S, RingConsumer, RingError, RingProducer, RingStalled, RingStuck

BATCH = 4096  # a batch is sent at this many records...
# ...or this many bytes: each batch wakes the writer process, which on a shared core can preempt the
# simulation, so batches are few (about 40 for the reference skip, against 70 at 1 MiB); still
# small enough that the last one, written after the run, takes the writer a few milliseconds
BATCH_BYTES = 2 << 20
# the space a batch is gathered in (in the ring, for the writer process): a water field fits whole
STAGE_BYTES = 4 << 20
# shared memory between the simulating and the writer process: reused, so its pages stay mapped;
# sixteen stages long, so that the simulation goes on while the writer is some batches behind: a writer
# started with the run imports the viewer modules first (about 0.2 s), while the reference skip
# sends 30 MB in its first 0.16 s (a 16 MiB ring held it up by 0.1 s)
RING_BYTES = 64 << 20
# a checkpoint (or other record) larger than the stage, up to this size, is written straight into the
# ring: at most half of it, so that such a record never waits for the writer to have read the whole ring
FRESH_MAX_BYTES = RING_BYTES // 2
WRITER_TIMEOUT_S = 600.0  # longest wait for the writer to finish a file on close
ZSTD_LEVEL = 1  # chunk compression: within 1% of the default level's size, at two thirds of its cost


class SinkError(CosimError):
    """The writer could not write the file; the message says why. When the writer died (killed, a
    crash) the recording is salvaged up to the failure and the message says to when and where;
    when writing failed (e.g. the disk full) the file is closed where it was cut, keeping everything
    that fitted (when not even its end fits, it is removed and the target keeps what it held)."""


# how a failed write is reported: by the SDK's MCAP writer over a path (``Os { code: 28 ...``), by
# _File below (``[Errno 28] ...``), or by the SDK's MCAP writer over _File (``PyErr { type: <class
# 'OSError'>, value: OSError(28, '...')``)
_OS_ERRORS = "|".join(sorted(name for name, value in vars(builtins).items()  # OSError and its kinds
                              if isinstance(value, type) and issubclass(value, OSError)))
_OS_ERROR = re.compile(rf"Os \{{ code: (\d+)|\[Errno (\d+)\]|value: (?:{_OS_ERRORS})\((\d+), ")
# the writer process's exit status when the file system refused a write: this plus the error's
# number (1 to 191), so that the simulating process knows it even when the writer could not say so
# on its error output (a temporary file, on a disk that may be the full one, under the same limit)
REFUSED_EXIT = 64
# the SDK's logger of a message its MCAP writer could not write ("error logging message: ..."): it
# logs every such message and goes on, rather than raising (pyo3-log names it after the Rust module)
_SDK_LOGGER = "foxglove.log_sink_set"
_REASON_CHARS = 300  # at most this much of a writer's own words goes into the run's error line


def _reason(text: str) -> str:
    """The cause of a writer failure from its error output: the operating system's words for the
    first failed write (disk full, file too large...), else its last line, without the traceback
    text the SDK's errors carry, and cut short should it be long."""
    text = "\n".join(line for line in text.splitlines() if not line.startswith(RELAY_TAG))  # not its warnings
    match = _OS_ERROR.search(text)
    if match:
        return os.strerror(int(next(group for group in match.groups() if group)))
    lines = text.strip().splitlines()
    return _one_line(lines[-1]) if lines else ""


def _one_line(text: str) -> str:
    """An error's words for the run's one error line: the traceback a Python error inside the SDK's
    carries (``PyErr { ..., traceback: Some("Traceback ...") }``) left out, at most
    :data:`_REASON_CHARS` characters."""
    return shortened(re.sub(r",? ?traceback: Some\(.*", "", " ".join(text.split())), _REASON_CHARS)


def _refused_exit(exc: BaseException) -> int:
    """The writer process's exit status for a failure ``exc`` while writing its file:
    :data:`REFUSED_EXIT` plus the error's number when the system refused a write, else 1."""
    code = exc.errno if isinstance(exc, OSError) else None
    return REFUSED_EXIT + code if isinstance(code, int) and 0 < code < 256 - REFUSED_EXIT else 1


def _say(line: str) -> None:
    """Write one line on the error output, if it can be written at all (on a full disk, the writer
    process's error output, a temporary file, may be refused too: its exit status says why)."""
    with contextlib.suppress(OSError, ValueError):
        print(line, file=sys.stderr, flush=True)


# the writer's line on a finished recording it could not put at its target (its folder gone and
# replaced by a file): TAG, where it put the recording instead, tab, why
RESCUED_TAG = "cosim-rescued\t"


def _rescued(text: str) -> tuple[str, str] | None:
    """(where, why) of a recording the writer rescued elsewhere than its target, from its error
    output ``text`` (:data:`RESCUED_TAG`); None when it did not."""
    for line in text.splitlines():
        if line.startswith(RESCUED_TAG):
            where, _, why = line[len(RESCUED_TAG):].partition("\t")
            return where, why
    return None


def _rescued_line(path: Path, where: str, why: str) -> str:
    """The run's error line for a finished recording of ``path`` rescued into ``where``."""
    return (f"{path}: the finished recording could not be put there ({why}; its folder was removed or replaced "
            f"during the run); the whole recording was rescued into {where}")


def _warn_whole(line: str) -> None:
    """Say that the recording is whole though its writer failed as it finished it (``line``): a
    warning, as the run stands; under an "error" warnings filter, the run's error."""
    try:
        warnings.warn(line, RuntimeWarning, stacklevel=3)
    except Warning:
        raise SinkError(line) from None


# writes that fail for want of room: a rebuilt copy of the recording would need as much again


class _File(io.FileIO):
    """The recording's file as the MCAP writer writes it, keeping the first write the system refused
    (the disk full, a file-size limit): the writer itself then reports only that a write failed."""

    failure: OSError | None = None

    def write(self, data: Any) -> int | None:
        try:
            return super().write(data)
        except OSError as exc:
            if self.failure is None:
                self.failure = exc
            raise


class _Refusals(logging.Filter):
    """The SDK's "error logging message: ..." for each message its MCAP writer could not write: it
    logs them rather than raising, one for every message after a write the system refused
    (thousands of lines, each with a Python traceback, which flooded the writer's error output on a
    full disk: a temporary file on that disk). Once ``file`` has refused a write they are kept from
    the log (its :attr:`_File.failure` says it all); before that, one is let through as the SDK
    gives it (it may come from another of its writers in this process, such as a live view), the
    first one kept here (:meth:`_Apply.check`)."""

    def __init__(self, file: _File) -> None:
        super().__init__()
        self.file = file
        self.first: str | None = None

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if not message.startswith("error logging message"):
            return True  # any other word of the SDK's goes on as it would
        if self.file.failure is not None:
            return False  # the file refused a write: every message after it fails the same way
        if self.first is None:
            self.first = message
        return True


class _Apply:
    """Applies records to an MCAP writer over ``part``, then finishes the file and renames it."""

    def __init__(self, part: str, final: str, fd: int | None = None):
        """``fd``: a descriptor of the private file ``part`` to write it through (closed with it),
        when the file was handed over open: its name may be gone by the time it would be opened (its
        folder removed early in the run)."""
        import foxglove  # the SDK's compiled MCAP writer: several times faster than a pure-Python one
        from foxglove.mcap import MCAPCompression, MCAPWriteOptions

        self.part, self.final = part, final
        self._foxglove = foxglove
        self.context = foxglove.Context()  # this file's own channels, apart from any live view
        # The private file exists already (created empty and locked by the simulating process): it is
        # opened as it is, not truncated. On ext4, closing a file that was truncated to nothing and
        # written again waits for its blocks to be allocated (the file system's guard for programs
        # that rewrite a file in place): about 40 ms for the reference skip's 40 MB, which the
        # simulating process would wait for at the end of every recorded run.
        self.file = _File(part if fd is None else fd, "r+")  # closed in finish() or abandon()
        self.refusals = _Refusals(self.file)  # the messages the SDK's writer could not write (it only logs them)
        logging.getLogger(_SDK_LOGGER).addFilter(self.refusals)  # taken off in finish() or abandon()
        try:
            self.writer = foxglove.open_mcap(
                self.file, context=self.context,
                writer_options=MCAPWriteOptions(compression=MCAPCompression.Zstd, compression_level=ZSTD_LEVEL,
                                                compression_threads=0, profile="", chunk_size=262144))
        except BaseException:
            self._let_go()
            raise
        self.schemas: dict[int, Any] = {}
        self.channels: dict[int, Any] = {}
        # channel id -> its log(data, log_time): the SDK's compiled channel's own, without the Python
        # wrapper's checks (a microsecond a message, which the writer pays for every exchange)
        self.logs: dict[int, Callable[[bytes, int], None]] = {}
        self.renderers: dict[int, Renderer] = {}  # channel id -> the writer of its messages' text
        self.derivation: Derivation | None = None  # the viewer channels made here, once asked for
        self.derived: dict[int, list] = {}  # channel id -> the ports derived from its messages (the derivation's)
        # (where, why) when the finished file could not be put at its target and was rescued elsewhere
        self.rescued: tuple[str, str] | None = None

    def apply_batch(self, batch: memoryview) -> int:
        """Write every record of a batch (see :mod:`cosim.codec.records`), and the channels derived
        from its messages here (:mod:`cosim.record.derive`); the number of the batch's messages
        written (the derived ones not counted: the ring's tally and the salvage count the stream)."""
        logs, derived = self.logs, self.derived
        count = 0
        for kind, channel, time_ns, payload in iter_records(batch, self.renderers):
            if kind == MESSAGE:
                logs[channel](payload, time_ns)
                count += 1
                if channel in derived:
                    self.after(channel, time_ns, payload)
            elif kind == BYTES:
                data = bytes(payload)
                logs[channel](data, time_ns)
                count += 1
                if channel in derived:
                    self.after(channel, time_ns, data)
            elif kind == OTHER:
                count += self.apply(read_other(payload))
            else:
                raise SinkError(f"unknown record kind {kind}")
        return count

    def check(self, strict: bool = False) -> None:
        """Raise the first write the system refused (the disk full, a file-size limit: an OSError),
        and, when ``strict`` (in the writer process, where the SDK writes nothing else), a SinkError
        when the SDK's MCAP writer could not write a message for another reason. The SDK only logs
        such failures and goes on (:class:`_Refusals`): it is asked after each batch, so that the
        first failure stops the writing."""
        if self.file.failure is not None:
            raise self.file.failure
        if strict and self.refusals.first is not None:
            raise SinkError(f"the MCAP writer could not write a message ({_one_line(self.refusals.first)})")

    def _let_go(self) -> None:
        """Close the file and stop catching the SDK's messages about it."""
        logging.getLogger(_SDK_LOGGER).removeFilter(self.refusals)
        self.file.close()

    def after(self, channel: int, time_ns: int, data: bytes) -> None:
        """A message of ``channel`` was written: write the viewer channels derived from it here."""
        if self.derivation is not None and channel in self.derived:
            self.derivation.after(channel, time_ns, data)

    def apply(self, record: tuple) -> int:
        """Write a record other than a message: a schema, a channel, metadata, an attachment, a
        checkpoint; the number of messages written (1 for a checkpoint, else 0)."""
        op = record[0]
        if op == "state":
            self.logs[record[1]](state_bytes(record[3]), record[2])
            return 1
        if op in ("deriver", "derive"):
            if self.derivation is None:
                self.derivation = Derivation(self, self.derived)
            self.derivation.apply(record)
            return 0
        if op == "schema":
            self.schemas[record[1]] = self._foxglove.Schema(name=record[2], encoding=record[3], data=record[4])
        elif op == "channel":
            _, cid, topic, encoding, schema_id, layout = record
            self.channels[cid] = self._foxglove.Channel(topic, message_encoding=encoding,
                                                        schema=self.schemas[schema_id], context=self.context)
            self.logs[cid] = self.channels[cid].base.log
            if layout is not None:
                self.renderers[cid] = renderer(RecordLayout(*layout))
        elif op == "metadata":
            self.writer.write_metadata(record[1], record[2])
        elif op == "attachment":
            self.writer.attach(log_time=record[2], create_time=0, name=record[1], media_type=record[3],
                               data=record[4])
        else:
            raise SinkError(f"unknown record {op!r}")
        return 0

    def finish(self) -> None:
        """Finish the file and move it onto its target; the system's own error (``[Errno N] ...``)
        when it refused a write. A private file whose folder was removed while it was written lives
        on through this process's descriptor: it is copied into the folder, made again, or, where
        that cannot be, elsewhere (:meth:`_rescue`; :attr:`rescued` then says where and why)."""
        try:
            if self.derivation is not None:
                self.derivation.finish()  # the viewer channels' final frame
            self.writer.close()
            self.file.truncate()  # the recording ends where the writer stopped (nothing stale after it)
            if not os.path.exists(self.part):
                self._rescue()
                return
        except Exception:
            if self.file.failure is not None:
                raise self.file.failure from None
            raise
        finally:
            self._let_go()
        finish(self.part, self.final)

    def _rescue(self) -> None:
        """The finished file, its private name gone (the file or its folder removed during the run),
        copied from this process's descriptor to its final name, the folder made again if it went;
        said as a warning. Where the folder cannot be made again (a file stands where it or a folder
        above it was), the recording is copied into the working folder, else the system's temporary
        folder, as ``NAME.rescued.mcap`` (:meth:`_rescue_elsewhere`), and :attr:`rescued` says
        where and why."""
        folder = os.path.dirname(self.final)
        tmp = None
        try:
            os.makedirs(folder or ".", exist_ok=True)
            # a new file of its own name (a fixed one was written over, whatever it held), made empty
            # here, so the copy may truncate it
            tmp = str(new_temporary(Path(self.final), ".rescue.tmp", prefix="."))
            self._copy_to(tmp, os.O_TRUNC)
            os.replace(tmp, self.final)
        except OSError as exc:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            self.rescued = (self._rescue_elsewhere(exc), exc.strerror or str(exc))
            return
        except BaseException:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            raise
        warnings.warn(f"{self.final}: its private file was removed while the run was recorded (with its folder?); "
                      "the whole recording was written there all the same", RuntimeWarning, stacklevel=2)

    def _rescue_elsewhere(self, refused: OSError) -> str:
        """Copy the finished file into the first folder that takes it, the working one, then the
        system's temporary one, under a name saying what it is (``NAME.rescued.mcap``, or with a
        random part should that be taken); where it now is. ``refused``, the error that kept it from
        its target, is raised when no folder takes it."""
        import secrets
        import tempfile

        stem = os.path.basename(self.final)
        stem = sibling_stem(stem[:-len(".mcap")] if stem.endswith(".mcap") else stem, len(".rescued-1a2b3c4d.mcap"))
        folders = list(dict.fromkeys(os.path.abspath(f) for f in (os.getcwd(), tempfile.gettempdir())))
        for folder in folders:
            for name in (f"{stem}.rescued.mcap", f"{stem}.rescued-{secrets.token_hex(4)}.mcap"):
                where = os.path.join(folder, name)
                try:
                    self._copy_to(where, os.O_EXCL)
                except FileExistsError:
                    continue  # never over another file: the next name
                except OSError:
                    break  # this folder takes nothing (full, read-only): the next folder
                return where
        raise refused

    def _copy_to(self, path: str, mode: int) -> None:
        """Copy the finished file, from this process's descriptor, into a file ``path`` created with
        the open flag ``mode`` (``os.O_TRUNC``, or ``os.O_EXCL``: only a new file); a copy that fails
        part-way is removed."""
        import shutil

        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC | mode, 0o666)
        try:
            with open(fd, "wb") as out:
                self.file.seek(0)
                shutil.copyfileobj(self.file, out, 1 << 20)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(path)
            raise

    def abandon(self) -> None:
        """Close the writer and the file, whatever state they are in (the file is dropped anyway)."""
        try:
            self.writer.close()
        except Exception:
            pass
        finally:
            self._let_go()


_PACKAGE_ROOT = str(Path(__file__).resolve().parents[2])  # the folder holding the cosim package


def _site_dirs() -> str:
    """This interpreter's site-packages folders (where the writer's foxglove comes from), joined by
    os.pathsep: the writer starts without site processing and adds them after its standard library."""
    import site

    dirs = [*site.getsitepackages(), site.getusersitepackages() if site.ENABLE_USER_SITE else ""]
    return os.pathsep.join(d for d in dirs if d and os.path.isdir(d))


def _take_file(handover: Any) -> tuple[str, str, int] | None:
    """(private name, final name, locked descriptor) of the next file handed over on the socket
    ``handover`` (:meth:`_Writer.hand_over`), or None when the simulating process closed it (it
    ended, or will record no more)."""
    import socket

    try:
        data, fds, _, _ = socket.recv_fds(handover, 1 << 16, 1)
    except OSError:
        return None
    if not data or not fds:
        return None
    part, final = (os.fsdecode(name) for name in data.split(b"\0"))
    return part, final, fds[0]


def writer_main(argv: list[str]) -> int:
    """Body of the writer process: take the file to write, apply batches from the ring until the
    simulating process ends the stream (then finish the file and wait for the next one) or closes
    the control pipe (then finish the file and exit).

    The process may be started before the run knows its file (:func:`prestart`): it then imports
    what deriving viewer channels needs and makes the ring resident while the simulating process
    starts, and waits for the file to be handed over. Kept for the simulating process's next
    recording (:meth:`ProcessSink.close`), it has all that done already.

    The simulating process closing the pipe, on purpose or by dying, is the signal to finish, so the
    writer ignores Ctrl-C and SIGTERM meant for the simulation. One that died leaves the records of
    its last completed steps marked in the ring (:meth:`ProcessSink.mark`): they are written too.
    After each batch the writer tallies the messages written so far in the ring's control block, so
    that should it die, the simulating process knows what it had taken (:mod:`cosim.record.salvage`).
    """
    import socket

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    ring_fd, ring_size, control_fd, ack_fd, site_dirs, preloads, handover_fd = argv
    # after the standard library, as site processing would put them (nothing there may shadow it)
    folders = [d for d in site_dirs.split(os.pathsep) if d]
    sys.path.extend(d for d in folders if d not in sys.path)
    relay_warnings()  # a deriver's warnings (a visuals function switched off) reach the user
    use_site_dirs(folders)  # their .pth entries, read before anything is derived here
    if preloads:  # what deriving viewer channels here needs, imported while the simulation starts
        import threading

        threading.Thread(target=preload, args=(preloads.split(","),), daemon=True).start()
    ring = RingConsumer(int(ring_fd), int(ring_size), int(control_fd), int(ack_fd))
    ring.prefault()  # the ring's memory allocated here rather than in the simulating process's writes
    handover = socket.socket(fileno=int(handover_fd))
    while True:
        # the file: its private name, its final one, and the lock on it (held open, and so held,
        # until it is finished); none when the simulating process records no more
        handed = _take_file(handover)
        if handed is None:
            return 0
        part, final, lock_fd = handed
        sink = _Apply(part, final, os.dup(lock_fd))  # (the lock stays on the file until both are closed)
        written = 0
        try:
            for (batch,) in ring.batches():
                written += sink.apply_batch(batch)
                sink.check(strict=True)  # a write refused in it (the SDK's writer goes on regardless): stop here
                ring.tally(written)
            if not ring.ended:  # the simulating process died: the steps it completed but had not sent
                unsent = ring.unsent()
                if unsent is not None:
                    sink.apply_batch(unsent)
                    sink.check(strict=True)
        except Exception as exc:
            refused = sink.file.failure
            if refused is not None:
                # the system refused a write (the disk full, a file-size limit), which the MCAP library
                # only logs: said in the system's words and by the exit status (should even that line
                # not fit), so that the simulating process closes the file where it was cut (seal)
                # rather than salvage it, and says why
                _say(f"cannot write the file: {refused}")
                sink.abandon()
                return _refused_exit(refused)
            # a record this process cannot write: the file is left as it is, for the simulating
            # process to salvage (with what the ring still holds) and say so; it is not passed off
            # as finished
            if isinstance(exc, SinkError):
                _say(str(exc))
            else:
                import traceback

                with contextlib.suppress(OSError, ValueError):
                    traceback.print_exc()
            sink.abandon()
            return 2
        try:
            sink.finish()
        except Exception as exc:  # e.g. the disk filled up: one line for the simulating process to show
            _say(f"cannot finish the file: {exc}")
            return _refused_exit(exc)
        if sink.rescued is not None:  # finished, but not at its target: the simulating process says where
            where, why = sink.rescued
            _say(f"{RESCUED_TAG}{where}\t{why}")
        if not ring.ended:
            ring.finish()  # the file is complete under its final name: the simulating process need not wait
            return 0
        os.close(lock_fd)
        ring.finish_stream()  # the file is complete: the simulating process may hand over the next one


class WriterPlacement:
    """Keeps a writer process off the core this (the simulating) process runs on, until it waits.

    Woken by the simulating process (a batch on the control pipe), the kernel tends to run the writer
    on the waker's core (so that it finds the data in the cache), where it takes the simulation's
    time: while another job holds the machine's other core, all of the writer's CPU then lands on
    the run's wall time. Told at each batch which core the simulation is on (:meth:`avoid_mine`), the
    writer runs anywhere else, sharing another core with whatever runs there; once the simulation
    waits for it (the file being finished, :meth:`anywhere`) it may run anywhere again. Nothing is
    pinned on a single-core machine, nor where the system gives no such figures (no ``/proc``).
    """

    def __init__(self, pid: int):
        self.pid = pid
        try:
            self.allowed = os.sched_getaffinity(pid)
        except (AttributeError, OSError):
            self.allowed = set()
        self.avoided = -1  # the core the writer keeps off, -1 for none

    def _set(self, cpu: int) -> None:
        if cpu != self.avoided and len(self.allowed) > 1:
            try:
                os.sched_setaffinity(self.pid, self.allowed - {cpu})
                self.avoided = cpu
            except OSError:  # the writer has gone: its failure is told elsewhere
                self.allowed = set()

    def avoid_mine(self) -> None:
        """Keep the writer off the core this process last ran on (``/proc/self/stat``, field 39)."""
        if len(self.allowed) < 2:
            return
        try:
            with open("/proc/self/stat", "rb") as f:
                cpu = int(f.read().rsplit(b")", 1)[1].split()[36])
        except (OSError, ValueError, IndexError):
            self.allowed = set()
            return
        if cpu in self.allowed:
            self._set(cpu)

    def anywhere(self) -> None:
        """Let the writer run on any core it may."""
        self._set(-1)


class _Ids:
    """Schema and channel ids, counting from 1 in registration order."""

    def __init__(self) -> None:
        self.schemas = 0
        self.channels = 0

    def schema(self) -> int:
        self.schemas += 1
        return self.schemas

    def channel(self) -> int:
        self.channels += 1
        return self.channels


class _Sink:
    """What both sinks share: ids counted here, and every record gathered in a
    :class:`cosim.codec.records.Stage` whose batches go to :meth:`_send` (applied by :class:`_Apply`, here or
    in the writer process).

    Messages are packed by their codec (:meth:`add_message_record`) or given as bytes
    (:meth:`add_message`); everything else (schemas, channels, checkpoints as plain data, metadata,
    attachments) travels pickled. The records other than messages are also kept here
    (:attr:`directory`: a few per run), for a recording rebuilt after its writer died.
    """

    def __init__(self, fresh: Callable[[int], memoryview] | None = None) -> None:
        """``fresh``: where the stage gathers each batch (see :class:`cosim.codec.records.Stage`)."""
        self._ids = _Ids()
        self.stage = Stage(STAGE_BYTES, BATCH, self._send, BATCH_BYTES, fresh, fresh_max=FRESH_MAX_BYTES)
        self.add_message_record = self.stage.add_message  # type: ignore[method-assign]
        self.directory: list[tuple] = []  # every schema, channel, metadata and attachment record, in order
        # the recorder's last word for a recording salvaged after its writer died: called with the
        # writer's fate, the latest time salvaged [ns] and whether all that was sent is there; gives
        # (log time [ns], a message with the attributes of a cosim.record.recorder.DerivedMessage), or
        # None to add nothing
        self.epitaph: Callable[..., tuple[int, Any] | None] | None = None
        # the time [ns] a restart begins at (the recorder's start_ns; 0 for a run from the start): a
        # recording cut short before its first message still stands there, not at t = 0
        self.start_ns = 0

    def _send(self, batch: memoryview) -> None:
        raise NotImplementedError

    def _other(self, record: tuple) -> None:
        self.stage.add_other(record)
        self.directory.append(record)

    def mark(self) -> None:
        """The records given so far are whole steps: should this process die before sending them,
        the writer process writes them still (:meth:`cosim.record.ring.RingProducer.mark`)."""

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = self._ids.schema()
        self._other(("schema", sid, name, encoding, data))
        return sid

    def register_channel(self, topic: str, encoding: str, schema_id: int,
                         layout: RecordLayout | None = None) -> int:
        """A channel id; ``layout`` is how :meth:`add_message_record` records on it are laid out."""
        cid = self._ids.channel()
        self._other(("channel", cid, topic, encoding, schema_id, None if layout is None else tuple(layout)))
        return cid

    def add_message(self, channel: int, time_ns: int, data: bytes) -> None:
        """A message's bytes, at log time = publish time = ``time_ns``."""
        self.stage.add_bytes(BYTES, channel, time_ns, data)

    def add_message_record(self, write: Write, channel: int, time_ns: int, msg: Any) -> bool:
        """A message packed by its codec's ``write`` (the channel's layout); False, with nothing
        written, when the message needs the slow path (:meth:`add_message` of its bytes). (Each sink
        binds this name to its stage's method directly: it is called for every exchange.)"""
        return self.stage.add_message(write, channel, time_ns, msg)

    def add_state(self, channel: int, time_ns: int, plain: Any) -> None:
        """A checkpoint, as :func:`cosim.codec.json_codec.plain_state` gives it (its arrays already copied)."""
        self.stage.add_other(("state", channel, time_ns, plain))

    def add_derivation(self, record: tuple) -> None:
        """A ``deriver`` or ``derive`` record (:mod:`cosim.record.derive`): viewer channels the
        writer derives from the recorded messages (kept for a salvage, which derives them again)."""
        self._other(record)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._other(("metadata", name, dict(data)))

    def add_attachment(self, name: str, time_ns: int, media_type: str, data: bytes) -> None:
        self._other(("attachment", name, time_ns, media_type, data))

    def flush(self) -> None:
        """Send the records gathered so far."""
        self.stage.flush()


class InProcessSink(_Sink):
    """Writes records in this process, a batch at a time."""

    def __init__(self, path: Path):
        self.path = path
        self.claim = claim(path)
        try:
            self._apply = _Apply(str(self.claim.part), str(path))
        except BaseException:
            self.claim.release(remove=True)
            raise
        super().__init__()

    def _send(self, batch: memoryview) -> None:
        self._apply.apply_batch(batch)

    def close(self) -> None:
        try:
            try:
                self.flush()
            finally:
                self._apply.finish()
        except Exception as exc:
            self.claim.release(remove=True)
            raise SinkError(f"{self.path}: the recording could not be written ({exc}); no file was left") from None
        self.claim.release(remove=False)
        if self._apply.rescued is not None:
            where, why = self._apply.rescued
            raise SinkError(_rescued_line(self.path, where, why))

    def discard(self) -> None:
        """Close and remove the private file (the target keeps what it held)."""
        self._apply.abandon()
        self.claim.release(remove=True)


SMALLEST_RING_BYTES = 1 << 20  # a ring made smaller to fit a file-size limit is at least this large


def _ring() -> RingProducer:
    """The shared memory to a writer process: :data:`RING_BYTES`, or, where a file-size limit
    (``ulimit -f``, which counts the memory file too) is lower, the largest power-of-two share of it
    that fits, down to :data:`SMALLEST_RING_BYTES` (every recording failed at its start, blaming its
    output file, under a limit below 64 MiB)."""
    size = RING_BYTES
    while True:
        try:
            return RingProducer(size)
        except OSError as exc:
            if exc.errno != errno.EFBIG or size // 2 < SMALLEST_RING_BYTES:
                if exc.errno == errno.EFBIG:
                    need = f"{SMALLEST_RING_BYTES >> 20} MiB"
                    raise OSError(exc.errno, f"the file-size limit (ulimit -f) is below the {need} of shared memory "
                                             "a recording's writer needs") from None
                raise
            size //= 2


class _Writer:
    """A writer process, started: its ring, its error output (a file, read back only if it fails or
    relays warnings: a pipe could fill and block it), and the socket its file is handed over on."""

    def __init__(self, preloads: tuple[str, ...]):
        import socket
        import subprocess  # here and below, not at import: the writer process imports this module too
        import tempfile

        self.owner = os.getpid()  # a process forked from this one may not use it
        self.errors = tempfile.TemporaryFile()
        self.errors_read = 0  # bytes of it read back (new_errors)
        # the writer imports this package from where this process found it
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [_PACKAGE_ROOT, env.get("PYTHONPATH")]))
        self.ring = _ring()
        control_r, control_w = os.pipe()
        ack_r, ack_w = os.pipe()
        self.handover, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)  # one message
        try:
            self.proc = subprocess.Popen(
                # -P: the working folder must not shadow anything on the writer's path
                # -S: no site processing (its .pth files cost tens of milliseconds of every short run's
                # wait for the writer); the packages the writer needs are found through _site_dirs()
                [sys.executable, "-S", "-P", "-m", "cosim.record.writer", str(self.ring.fd), str(self.ring.size),
                 str(control_r), str(ack_w), _site_dirs(), ",".join(preloads), str(theirs.fileno())],
                pass_fds=(self.ring.fd, control_r, ack_w, theirs.fileno()), stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=self.errors, start_new_session=True, env=env)
        except BaseException:
            for end in (control_w, ack_r):
                os.close(end)
            self.handover.close()
            self.ring.close()
            self.errors.close()
            raise
        finally:
            os.close(control_r)
            os.close(ack_w)
            theirs.close()
        self.ring.connect(control_w, ack_r)
        self.ring.consumer_pid = self.proc.pid  # a wait for it watches whether it gets anywhere
        self.placement = WriterPlacement(self.proc.pid)

    def hand_over(self, part: Path, final: Path, lock_fd: int) -> bool:
        """Give the writer its next file (the private one, locked by ``lock_fd``, and the final name);
        False when it has gone. The names go absolute: the writer's working folder is the one this
        process had when it started the writer."""
        import socket

        names = os.fsencode(os.path.abspath(part)) + b"\0" + os.fsencode(os.path.abspath(final))
        try:
            socket.send_fds(self.handover, [names], [lock_fd])
        except OSError:
            return False
        return True

    def new_errors(self) -> str:
        """What the writer wrote on its error output since last asked."""
        try:
            self.errors.seek(self.errors_read)
            data = self.errors.read()
        except (OSError, ValueError):
            return ""
        self.errors_read += len(data)
        return data.decode(errors="replace")

    def close(self) -> None:
        """Let go of a writer that has no file (between recordings, or never handed one), or whose
        file is to be dropped: it is stopped, since a process forked from this one may hold its
        socket open, and reaped."""
        try:
            self.proc.kill()
            self.proc.wait(WRITER_TIMEOUT_S)
        except Exception:  # already gone
            pass
        self.hang_up()

    def hang_up(self, wait: bool = True) -> None:
        """Close this process's ends: the socket (a writer waiting for its next file ends), the ring
        (a writer still writing finishes its file, and is waited for unless not ``wait``: a writer
        given up on finishes it on its own) and the error file."""
        self.handover.close()
        self.ring.hang_up(wait)
        self.ring.close()
        self.errors.close()

    def forget(self) -> None:
        """In a process forked from the one that started the writer: close this process's copies of
        its socket, pipes and memory (the writer stays the parent's)."""
        self.handover.close()
        for fd in (self.ring.control_fd, self.ring.ack_fd):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self.ring.control_fd = self.ring.ack_fd = -1
        self.ring.close()


# a writer ready for this process's next recording: started ahead of it (prestart), or kept from the
# last one (ProcessSink.close)
_spare: _Writer | None = None


def prestart(preloads: tuple[str, ...] = ()) -> None:
    """Start the writer process of the next recording now, before its file is known: a program that
    will record (``cosim run``) calls this first, so that the writer's start, the import of what it
    derives viewer channels with (``preloads``) and its ring's allocation happen while the program
    itself starts, not at the run's end (a short run waits for the writer to finish its file). A
    spare that is never used ends when this process does."""
    global _spare
    if _spare is None or _spare.owner != os.getpid():
        _spare = _Writer(preloads)
        _let_go_at_exit()


def _writer(preloads: tuple[str, ...]) -> _Writer:
    """The spare writer (:func:`prestart`, or the last recording's) if there is one, else a new one."""
    global _spare
    spare, _spare = _spare, None
    if spare is not None and spare.owner == os.getpid():
        return spare
    return _Writer(preloads)


def _keep(writer: _Writer) -> None:
    """Keep a writer that finished its file for this process's next recording (one is kept)."""
    global _spare
    if _spare is None and writer.owner == os.getpid():
        _spare = writer
        _let_go_at_exit()
    else:
        writer.close()


@cache
def _let_go_at_exit() -> None:
    """At this process's exit, let the spare writer go (:meth:`_Writer.close`); in a process forked
    from this one, forget it (:meth:`_Writer.forget`)."""
    import atexit

    def let_go() -> None:
        global _spare
        spare, _spare = _spare, None
        if spare is not None and spare.owner == os.getpid():
            spare.close()

    def forget_in_child() -> None:
        global _spare
        spare, _spare = _spare, None
        if spare is not None:
            spare.forget()

    atexit.register(let_go)
    os.register_at_fork(after_in_child=forget_in_child)


class ProcessSink(_Sink):
    """Sends records in batches to a writer process (this module run with ``python -m``: it shares no
    threads or locks with the simulation, and starts while the simulation does), through a ring in
    shared memory (:mod:`cosim.record.ring`)."""

    def __init__(self, path: Path, preloads: tuple[str, ...] = ()):
        """``preloads``: modules the writer imports as it starts, for the viewer channels it will
        derive (:mod:`cosim.record.derive`)."""
        # batches are gathered in the ring itself, so they reach the writer without a copy
        super().__init__(self._reserve)
        self.path = path
        self._failed: str | None = None  # the line saying how the writer failed, once it has
        self._abandoned = False  # the writer was given up on (_abandon): it keeps the private file
        self._whole = False  # the writer failed, but its file holds the whole run (_seal, _salvage): the run stands
        self._closing = False  # close() has begun: the run has sent everything it records
        # a path that cannot be written fails at once, in this process (the private file is created
        # here, empty, and locked; the writer opens it by name and holds the lock too)
        self.claim = claim(path)
        try:
            writer = _writer(preloads)
            if not writer.hand_over(self.claim.part, path, self.claim.fd):  # a spare that died
                writer.close()
                writer = _Writer(preloads)
                if not writer.hand_over(self.claim.part, path, self.claim.fd):
                    writer.close()
                    raise OSError("the recording writer process ended as it started")
        except BaseException:
            self.claim.release(remove=True)
            raise
        self._writer = writer
        # the writer's parts used on every batch or step, at hand
        self._ring, self._marked, self._placement = writer.ring, writer.ring.marked, writer.placement
        self._ring.forget_interrupts()  # a kept writer: the last recording's Ctrl-C is not this one's
        if writer.ring.size < RING_BYTES:  # a ring made smaller (_ring): batches a share of it
            stage = self.stage
            stage.size = min(stage.size, writer.ring.size // 4)
            stage.batch_bytes = min(stage.batch_bytes, stage.size)
            stage.fresh_max = min(stage.fresh_max, writer.ring.size // 2)

    @property
    def writer_pid(self) -> int:
        """The writer process's id."""
        return self._writer.proc.pid

    def _reserve(self, n: int) -> memoryview:
        try:
            return self._ring.reserve(n)
        except RingStalled:  # asked to stop, and the writer does not answer
            raise SinkError(self._abandon()) from None
        except RingStuck as exc:  # the writer is there, but gets nowhere (stopped, or stuck)
            raise SinkError(self._failure(unresponsive=str(exc))) from None
        except (RingError, OSError):  # the writer has gone while this process waited for room
            raise SinkError(self._failure()) from None

    def _send(self, batch: memoryview) -> None:
        self._placement.avoid_mine()
        try:
            if self._ring.owns(batch):
                self._ring.commit(len(batch))
            else:  # a record larger than the stage, from a buffer of its own
                self._ring.put([batch])
        except RingStalled:
            raise SinkError(self._abandon()) from None
        except RingStuck as exc:
            raise SinkError(self._failure(unresponsive=str(exc))) from None
        except (RingError, OSError):
            raise SinkError(self._failure()) from None

    def interrupted(self) -> None:
        """The run was asked to stop (a Ctrl-C, a SIGTERM; called from the signal handler): a writer
        that stops answering is not waited for without end (:meth:`RingProducer.interrupted`)."""
        self._ring.interrupted()

    def _abandon(self) -> str:
        """Give up on a writer that has not answered since the run was asked to stop (stopped, or
        stuck on its file system): hang up without waiting, leaving it the private file, which it
        finishes and moves onto the target should it go on; the line saying so."""
        if self._failed is None:
            self._abandoned = True
            self.stage.view = memoryview(b"")  # the stage no longer writes into the ring
            quiet = "asked again" if self._ring.interrupts >= 2 else f"for {STALL_S:g} s"
            self._failed = (f"{self.path}: the recording writer (process {self._writer.proc.pid}) has not answered "
                            f"since the run was asked to stop ({quiet}); it was left to finish the recording on "
                            f"its own should it go on (in {self.claim.part.name} until then), without the steps "
                            "it had not been handed")
            self._writer.hang_up(wait=False)
            self.claim.release(remove=False)
        return self._failed

    def mark(self) -> None:
        self._marked[1] = self.stage.offset  # RingProducer.mark, inlined: the recorder calls it every step

    def _failure(self, unresponsive: str | None = None) -> str:
        """What went wrong with the writer, in one line (the same line when asked again). A writer that
        died (killed, or failing otherwise than in writing the file) has its recording salvaged
        (:meth:`_salvage`); when writing failed (the disk full) the file is closed where it was cut
        (:meth:`_seal`). ``unresponsive``: why the writer, still there, is given up on (stopped, or
        stuck: :class:`cosim.record.ring.RingStuck`); it is killed first, and its recording salvaged
        as a killed writer's is. Called while the ring is still open: the salvage reads it."""
        import subprocess

        if self._failed is not None:
            return self._failed
        proc = self._writer.proc
        if unresponsive is not None:  # (SIGKILL ends a stopped process too)
            with contextlib.suppress(OSError):
                proc.kill()
        try:
            code = proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = proc.wait(WRITER_TIMEOUT_S)
        text = self._writer.new_errors()  # (what it wrote since its last file: a writer may be kept)
        # the system's refusal of a write, by the writer's exit status (REFUSED_EXIT + errno) or its words
        refused = code - REFUSED_EXIT if REFUSED_EXIT < code < 256 else None
        reason = os.strerror(refused) if refused is not None else _reason(text)
        # the salvage derives the viewer channels again here, so a deriver's warning comes again; it
        # is held until the file is safe (an "error" filter would have it end the salvage, losing
        # the recording) and given once with those the writer relayed
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                if code < 0:
                    self._failed = self._salvage(self._killed(code, unresponsive))
                elif refused is None and not _OS_ERROR.search(text):  # not the file system refusing its writes
                    self._failed = self._salvage(f"the recording writer failed ({reason or f'exit code {code}'})")
                else:
                    self._failed = self._seal(reason)
        except BaseException:
            if self._failed is not None:  # (a Ctrl-C in the salvage) where the writer's file is kept: said now,
                with contextlib.suppress(Warning):  # as the interrupt is what the run reports
                    warnings.warn(self._failed, RuntimeWarning, stacklevel=2)
            raise
        given = relayed_warnings(text) + [(w.category, str(w.message)) for w in caught]
        _give(list(dict.fromkeys(given)), failing=True)
        return self._failed

    def _killed(self, code: int, unresponsive: str | None) -> str:
        """How the writer, ended by the signal ``-code``, came to its end: killed here, for
        ``unresponsive`` reasons, or by someone else."""
        if unresponsive is not None:
            return (f"the recording writer (process {self._writer.proc.pid}) stopped responding ({unresponsive}), "
                    "so it was killed")
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"the recording writer was killed ({name})"

    def _seal(self, reason: str, fate: str | None = None) -> str:
        """The file system refused the writer's writes (the disk full, a file-size limit): close the
        private file where it was cut (:mod:`cosim.record.seal`), ending with the recorder's
        :attr:`epitaph`, and move it onto the target; the line saying so (or, when not even that
        could be written, that no file was left). ``fate``: what happened, when other than that
        writing the recording failed for ``reason``."""
        from cosim.record.seal import seal

        fate = fate or f"writing the recording failed ({reason})"
        cut = []  # asked for an ending: the data section was cut short (else only its end, or the move, failed)

        def ending(end_ns: int) -> tuple[int, Any] | None:
            end_ns = max(end_ns, self.start_ns)  # a restart that kept nothing stopped where it began, not at t = 0
            cut.append(end_ns)
            return self.epitaph(fate, end_ns, False, "closed where it stopped, at") if self.epitaph is not None \
                else None

        try:
            kept = seal(self.claim.part, ending)
        except Exception:  # not even the file's start whole, or no room at all: nothing to keep
            self.claim.release(remove=True)
            return f"{self.path}: the recording could not be written: {reason}; no file was left"
        except BaseException:  # (a second Ctrl-C) the writer's file is the only copy: kept, and said
            self._interrupted(fate, "closing it where it stopped")
            raise
        if cut and not kept.messages and self.path.is_file():
            # nothing of the run fitted: a file holding its failed status alone would replace the
            # recording there before, which is worth more (a full disk lost a whole earlier recording)
            self.claim.release(remove=True)
            return (f"{self.path}: {fate}; none of the run's messages could be written, so the recording there "
                    "before is left as it was")
        try:
            finish(self.claim.part, self.path)
            where = ""
        except OSError as exc:  # the target cannot be replaced (a folder made there): the recording is kept
            where = f"; it could not be moved there ({exc.strerror or exc}) and is kept as {self._keep()}"
        self.claim.hand_over()  # (a run that then discards its recording leaves it: it is the user's now)
        if not cut:  # the data section was whole: only its summary, or the move onto the target, failed
            whole = f"the recording is whole ({kept.messages} messages, to t = {kept.end_ns / 1e9:g} s)"
            if where:
                return f"{self.path}: {whole}{where}"
            if self._took_everything():  # nothing was lost: the run's recording stands, said in a warning
                self._whole = True
                return (f"{self.path}: {whole}; its summary, cut short ({reason}) as the writer finished the file, was "
                        "written again without the summary offsets (readers do not need them)")
            return f"{self.path}: {whole}, after {reason}"
        gave_way = "chunk" if kept.chunks_dropped == 1 else f"{kept.chunks_dropped} chunks"
        dropped = f"; its last {gave_way} gave way to its end" if kept.chunks_dropped else ""
        end_ns = max(kept.end_ns, self.start_ns)  # (a restart that kept nothing: where it began)
        first = ("none of the run's messages" if not kept.messages else "the run's first message" if kept.messages == 1
                 else f"the run's first {kept.messages} messages")
        # the run's own messages: the file holds its status record (and viewer items) beside them
        return (f"{self.path}: {fate}; the recording was closed where it stopped, at t = {end_ns / 1e9:g} s "
                f"({first}{dropped}), and what the run recorded after that was lost{where}")

    def _interrupted(self, fate: str, doing: str) -> None:
        """A Ctrl-C while the dead writer's file was being ``doing`` (salvaged, closed): the file is the
        only copy of what it recorded, so it is kept, not removed, and the line saying where is the
        recording's failure (:meth:`_failure` gives it as a warning too)."""
        self.claim.hand_over()
        self._failed = (f"{self.path}: {fate}; {doing} was interrupted, and what the writer had written is kept as "
                        f"{self.claim.part} (cosim repair {self.claim.part} makes it a valid recording)")

    def _keep(self) -> Path:
        """Give the private file that could not be moved onto the target a recording's name beside it
        (``NAME.<8 hex digits>.mcap``), or leave it as it is if even that fails; where it now is."""
        part = self.claim.part
        kept = part.with_suffix(".mcap")
        try:
            rename_new(part, kept)  # (never over a file of the user's that has that name)
        except OSError:
            return part
        self.claim.part = kept
        return kept

    def _salvage(self, fate: str) -> str:
        """Rebuild the recording from what the writer that died left (:mod:`cosim.record.salvage`) in a
        private file of its own, ending with the recorder's :attr:`epitaph`, and move it onto the
        target; the line saying so (or, if even that fails, that no file was left)."""
        from cosim.record.salvage import rebuild

        path, old = self.path, self.claim
        new: Claim | None = None
        out: _Apply | None = None
        try:
            new = claim(path, replacing=old)
            out = _Apply(str(new.part), str(path))
            kept = rebuild(out, old.part, self.directory, self._ring.held(), self._ring.tallies())
            kept.end_ns = max(kept.end_ns, self.start_ns)  # a restart that kept nothing: where it began
            ending = self.epitaph(fate, kept.end_ns, kept.complete) if self.epitaph is not None else None
            if ending is not None:
                self._end_with(out, kept.channels, *ending)
            out.finish()
        except BaseException as exc:
            if out is not None:
                out.abandon()
            if new is not None:
                new.release(remove=True)
            if isinstance(exc, OSError) and exc.errno in NO_ROOM and old.part.exists():
                # no room for a second copy (the disk full, a file-size limit): the writer's own file
                # is closed in place where it stopped instead, keeping what it had written
                reason = os.strerror(exc.errno)
                self._failed = self._seal(reason, f"{fate}, and there was no room to salvage the rest ({reason})")
                return self._failed
            if not isinstance(exc, Exception):  # (a second Ctrl-C) the writer's file is kept, not removed
                self._interrupted(fate, "salvaging what it had recorded")
                raise
            old.release(remove=True)
            why = f"{type(exc).__name__}: {_one_line(str(exc))}"
            self._failed = (f"{path}: the recording could not be written: {fate}, and salvaging what it "
                            f"had recorded failed too ({why}); no file was left")
            return self._failed
        new.release(remove=False)
        old.release(remove=True)
        end = f"t = {kept.end_ns / 1e9:g} s"
        # the run's own messages: the file holds its status record and the viewer items made from them too
        if kept.complete:
            # as the run's recording was being finished (the writer stopped answering as it closed the
            # file): everything the run sent, its status with it, is in the file: the run stands
            self._whole = self._closing
            return (f"{path}: {fate}; the recording was salvaged up to {end}, all the run had recorded "
                    f"(its {kept.messages} messages), into {path}")
        return (f"{path}: {fate}; the recording was salvaged up to {end} (the run's first {kept.messages} "
                f"messages) into {path}; what the run recorded after that was lost")

    def _end_with(self, out: _Apply, written: set[int], time_ns: int, msg: Any) -> None:
        """Write ``msg`` (a DerivedMessage: topic, schema and data) at ``time_ns`` unless its channel
        already has a message among those ``written``."""
        schemas = {r[2]: r[1] for r in self.directory if r[0] == "schema"}
        channels = {r[2]: r[1] for r in self.directory if r[0] == "channel"}
        channel = channels.get(msg.topic)
        if channel in written:
            return
        if channel is None:
            schema = schemas.get(msg.schema_name)
            if schema is None:
                schema = max(schemas.values(), default=0) + 1
                out.apply(("schema", schema, msg.schema_name, msg.schema_encoding, msg.schema_data))
            channel = max(channels.values(), default=0) + 1
            out.apply(("channel", channel, msg.topic, msg.message_encoding, schema, None))
        out.logs[channel](msg.data, time_ns)

    def close(self) -> None:
        """Send what is left, end the ring's stream, and wait until the writer has finished the file;
        a SinkError when it could not (its message says whether the recording was salvaged). The
        writer is kept for this process's next recording (:func:`_keep`)."""
        if self._abandoned:
            raise SinkError(self._failed or "")
        self._closing = True  # everything the run records has been sent (a salvage that keeps it all: _whole)
        finished = cut_short = False
        relayed: list[tuple[type[Warning], str]] = []
        rescued: tuple[str, str] | None = None
        try:
            try:
                try:
                    self.flush()
                except SinkError:
                    # the writer failed as the last batch was sent: a salvage that kept it all is
                    # said below, as a warning, as when it fails later in closing
                    if not self._whole:
                        raise
                self._placement.anywhere()  # this process only waits from now on
            finally:
                self.stage.view = memoryview(b"")  # the stage no longer writes into the ring
                try:
                    finished = self._failed is None and self._ring.end_stream()
                except RingStalled:
                    raise SinkError(self._abandon()) from None
                except RingStuck as exc:
                    line = self._failure(unresponsive=str(exc))
                    if not self._whole:  # (else said below, as a warning: nothing was lost)
                        raise SinkError(line) from None
            if self._failed is not None or (not finished and not self._finished_unsaid()):
                line = self._failure()  # the ring is still open here: the salvage reads it
                if not self._whole:
                    raise SinkError(line)
                _warn_whole(line)
            else:
                said = self._writer.new_errors()
                relayed, rescued = relayed_warnings(said), _rescued(said)
        except BaseException as exc:
            if finished:  # the file is whole, but closing was interrupted (Ctrl-C): the writer is let go
                self._writer.close()
                self.claim.release(remove=False)
            # a Ctrl-C while waiting for the writer: it finishes the file on its own, not waited for
            cut_short = isinstance(exc, KeyboardInterrupt)
            raise
        finally:
            if not finished and not self._abandoned:
                self._writer.hang_up(wait=not cut_short)
                import threading

                threading.Thread(target=self._writer.proc.wait, daemon=True).start()  # reaped in the background
        self.claim.release(remove=False)
        if finished:
            _keep(self._writer)
        _give(relayed)
        if rescued is not None:
            raise SinkError(_rescued_line(self.path, *rescued))

    def _finished_unsaid(self) -> bool:
        """Whether a writer that ended without saying it had finished the file had finished it all the
        same (killed after moving it onto the target, before it could say so): its private file gone,
        the target there, and no failure in its exit status. (A writer that failed with its private
        file gone, its folder removed, is not taken for one that finished.)"""
        import subprocess

        if self.claim.part.exists() or not self.path.exists():
            return False
        try:
            return self._writer.proc.wait(5) <= 0
        except subprocess.TimeoutExpired:
            return False

    def _took_everything(self) -> bool:
        """Whether the writer had written every batch this recording sent (it tallies in the ring after
        each, :meth:`cosim.record.ring.RingConsumer.tally`): its file then holds the whole run."""
        return self._ring.sent in self._ring.tallies()

    def discard(self) -> None:
        """Stop the writer and remove the private file (the target keeps what it held; a recording
        already salvaged after the writer died stays; a writer given up on keeps its file)."""
        if self._abandoned:
            return
        self.stage.view = memoryview(b"")  # the stage no longer writes into the ring
        self._writer.close()
        self.claim.release(remove=True)


def _give(relayed: list[tuple[type[Warning], str]], failing: bool = False) -> None:
    """Give again here the warnings the writer relayed (a visuals function of a viewer channel it
    derived that failed and was switched off). While the recording itself is ``failing``, a warning
    that an "error" filter would raise is left out: the recording's failure is what is raised."""
    for category, message in relayed:
        try:
            warnings.warn(message, category, stacklevel=3)
        except Warning:
            if not failing:
                raise


def open_sink(path: Path, background: bool = True, preloads: tuple[str, ...] = ()) -> InProcessSink | ProcessSink:
    """A sink writing ``path`` (via a private ``path.<random>.part``, moved onto it when finished:
    :mod:`cosim.record.output`); ``preloads``: modules a writer process imports as it starts."""
    return ProcessSink(path, preloads) if background else InProcessSink(path)


if __name__ == "__main__":
    status = writer_main(sys.argv[1:])
    # the file is finished: exit at once (tearing down the interpreter costs tens of milliseconds
    # that the simulating process would spend waiting); an error output that cannot be written (a
    # full disk) changes nothing: the exit status says what happened
    with contextlib.suppress(OSError, ValueError):
        sys.stderr.flush()
    os._exit(status)
