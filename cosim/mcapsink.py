"""Where a recording's records go: an MCAP writer in a separate process, fed in batches.

The mcap writer is pure Python and costs about as much per message as a physics step; writing in a
second process lets it run on another core while the simulation goes on, so recording every
exchange costs little more than encoding it. It also makes recordings sturdier: if the simulating
process dies, the writer sees its pipe close and still finishes a valid, indexed file.

Schema and channel ids are assigned here in registration order, exactly as the mcap writer assigns
them, so the bytes written do not depend on where the writer runs. :class:`InProcessSink` does the
same work in the calling process (used where a second process is not wanted).
"""

from __future__ import annotations

import os
import pickle
import queue
import signal
import struct
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType, IndexType, Writer

# Chunk and message indexes for fast seeking; attachment and metadata indexes because every
# recording has both (the mcap default also writes empty index groups that strict checkers flag).
INDEX_TYPES = IndexType.CHUNK | IndexType.MESSAGE | IndexType.ATTACHMENT | IndexType.METADATA
BATCH = 2048  # records per batch sent to the writer process
WRITER_TIMEOUT_S = 600.0  # longest wait for the writer to finish a file on close


class SinkError(RuntimeError):
    """The writer could not write the file (e.g. disk full); the message says why."""


class _Apply:
    """Applies records to an mcap Writer over an open file, then finishes it and renames it."""

    def __init__(self, part: str, final: str, library: str):
        self.part, self.final = part, final
        self.file: BinaryIO = open(part, "wb")
        self.writer = Writer(self.file, compression=CompressionType.ZSTD, index_types=INDEX_TYPES)
        self.writer.start(profile="", library=library)

    def apply(self, record: tuple) -> None:
        op = record[0]
        w = self.writer
        if op == "m":
            w.add_message(record[1], log_time=record[2], data=record[3], publish_time=record[2],
                          sequence=record[4])
        elif op == "schema":
            got = w.register_schema(record[2], record[3], record[4])
            if got != record[1]:
                raise SinkError(f"schema id {got} != {record[1]}")
        elif op == "channel":
            got = w.register_channel(record[2], record[3], record[4])
            if got != record[1]:
                raise SinkError(f"channel id {got} != {record[1]}")
        elif op == "metadata":
            w.add_metadata(record[1], record[2])
        elif op == "attachment":
            w.add_attachment(create_time=0, log_time=record[2], name=record[1], media_type=record[3],
                             data=record[4])
        else:
            raise SinkError(f"unknown record {op!r}")

    def finish(self) -> None:
        try:
            self.writer.finish()
        finally:
            self.file.close()
        os.replace(self.part, self.final)


_FRAME = struct.Struct("<Q")  # length prefix of each pickled batch on the writer's stdin


def _read_exact(stream: BinaryIO, n: int) -> bytes | None:
    chunks = []
    while n:
        chunk = stream.read(n)
        if not chunk:
            return None
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def writer_main(argv: list[str]) -> int:
    """Body of the writer process: apply batches from stdin until it closes, then finish the file.

    The simulating process closing the pipe, on purpose or by dying, is the signal to finish, so the
    writer ignores Ctrl-C and SIGTERM meant for the simulation.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    part, final, library = argv
    sink = _Apply(part, final, library)
    stream = sys.stdin.buffer
    try:
        while True:
            head = _read_exact(stream, _FRAME.size)
            if head is None:
                break
            body = _read_exact(stream, _FRAME.unpack(head)[0])
            if body is None:
                break
            for record in pickle.loads(body):
                sink.apply(record)
    finally:
        sink.finish()
    return 0


class _Ids:
    """Schema and channel ids in the order the mcap writer gives them (both counting from 1)."""

    def __init__(self) -> None:
        self.schemas = 0
        self.channels = 0

    def schema(self) -> int:
        self.schemas += 1
        return self.schemas

    def channel(self) -> int:
        self.channels += 1
        return self.channels


class InProcessSink:
    """Writes records directly, in this process."""

    def __init__(self, path: Path, library: str):
        self.path = path
        self._apply = _Apply(str(path.with_name(path.name + ".part")), str(path), library)
        self._ids = _Ids()

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = self._ids.schema()
        self._apply.apply(("schema", sid, name, encoding, data))
        return sid

    def register_channel(self, topic: str, encoding: str, schema_id: int) -> int:
        cid = self._ids.channel()
        self._apply.apply(("channel", cid, topic, encoding, schema_id))
        return cid

    def add_message(self, channel: int, time_ns: int, data: bytes, sequence: int) -> None:
        self._apply.writer.add_message(channel, log_time=time_ns, data=data, publish_time=time_ns,
                                       sequence=sequence)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._apply.apply(("metadata", name, data))

    def add_attachment(self, name: str, time_ns: int, media_type: str, data: bytes) -> None:
        self._apply.apply(("attachment", name, time_ns, media_type, data))

    def close(self) -> None:
        self._apply.finish()


class ProcessSink:
    """Sends records in batches to a writer process (this file run as a script: it imports only mcap,
    so it starts fast and shares no threads or locks with the simulation)."""

    def __init__(self, path: Path, library: str):
        self.path = path
        part = path.with_name(path.name + ".part")
        part.touch()  # a path that cannot be written fails at once, in this process
        # the writer's own errors go to a file, read back only if it fails (a pipe could fill and block it)
        self._errors = tempfile.TemporaryFile()
        self._proc = subprocess.Popen(
            # -P: this file's folder must not shadow the standard library on the writer's path
            [sys.executable, "-P", str(Path(__file__).resolve()), str(part), str(path), library],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._errors,
            start_new_session=True)
        self._batch: list[tuple] = []
        self._ids = _Ids()
        # A feeder thread does the pipe writes (which release the GIL), so the simulation never waits
        # for the writer: not while it starts up, nor while it compresses a chunk.
        self._frames: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._feed_error: BaseException | None = None
        self._feeder = threading.Thread(target=self._feed, name=f"cosim-feed:{path.name}", daemon=True)
        self._feeder.start()

    def _feed(self) -> None:
        stdin = self._proc.stdin
        assert stdin is not None
        try:
            while (frame := self._frames.get()) is not None:
                stdin.write(frame)
            stdin.close()
        except (BrokenPipeError, OSError) as exc:
            self._feed_error = exc

    def _push(self, record: tuple) -> None:
        self._batch.append(record)
        if len(self._batch) >= BATCH:
            self.flush()

    def flush(self) -> None:
        if self._feed_error is not None:
            raise SinkError(f"{self.path}: the recording writer stopped ({self._feed_error}){self._stderr()}")
        if self._batch:
            body = pickle.dumps(self._batch, protocol=pickle.HIGHEST_PROTOCOL)
            self._frames.put(_FRAME.pack(len(body)) + body)
            self._batch = []

    def _stderr(self) -> str:
        """The writer's last error line, if it wrote one."""
        try:
            self._proc.wait(5)
            self._errors.seek(0)
            text = self._errors.read().decode(errors="replace").strip()
        except (subprocess.TimeoutExpired, OSError, ValueError):
            return ""
        return f": {text.splitlines()[-1]}" if text else ""

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = self._ids.schema()
        self._push(("schema", sid, name, encoding, data))
        return sid

    def register_channel(self, topic: str, encoding: str, schema_id: int) -> int:
        cid = self._ids.channel()
        self._push(("channel", cid, topic, encoding, schema_id))
        return cid

    def add_message(self, channel: int, time_ns: int, data: bytes, sequence: int) -> None:
        self._batch.append(("m", channel, time_ns, data, sequence))
        if len(self._batch) >= BATCH:
            self.flush()

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._push(("metadata", name, dict(data)))

    def add_attachment(self, name: str, time_ns: int, media_type: str, data: bytes) -> None:
        self._push(("attachment", name, time_ns, media_type, data))

    def close(self) -> None:
        """Send what is left, close the pipe, and wait until the writer has finished the file."""
        try:
            self.flush()
        finally:
            self._frames.put(None)
            self._feeder.join(WRITER_TIMEOUT_S)
            code = self._proc.wait(WRITER_TIMEOUT_S)
        try:
            if code != 0 or not self.path.exists():
                raise SinkError(f"{self.path}: the recording writer failed (exit code {code}){self._stderr()}")
        finally:
            self._errors.close()

    def discard(self) -> None:
        """Stop the writer and remove the partial file."""
        self._proc.kill()
        self._frames.put(None)
        self._feeder.join(WRITER_TIMEOUT_S)
        self._proc.wait(WRITER_TIMEOUT_S)
        self._errors.close()
        for p in (self.path, self.path.with_name(self.path.name + ".part")):
            p.unlink(missing_ok=True)


def open_sink(path: Path, library: str, background: bool = True) -> InProcessSink | ProcessSink:
    """A sink writing ``path`` (via ``path.part``, renamed when finished)."""
    return ProcessSink(path, library) if background else InProcessSink(path, library)


if __name__ == "__main__":
    sys.exit(writer_main(sys.argv[1:]))
