"""A recording cut short where the disk filled up is closed in place (cosim.record.seal): whatever
the byte it was cut at, the result is a valid recording holding exactly the messages written whole
before the cut, in order, ending with the ending it was given; when its end does not fit, whole
chunks are given up until it does."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from cosim.codec.json_codec import codec_for
from cosim.record.reader import Recording
from cosim.record.recorder import STATUS_TOPIC, DerivedMessage, RunStatus
from cosim.record.seal import seal
from cosim.runner import run_scene
from cosim.scenario import loads
from tests.test_foxglove_recording import CHECKER, needs_mcap_check
from tests.test_reliability_output import PAINT

ROOT = Path(__file__).resolve().parents[1]



@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("seal") / "whole.mcap"
    run_scene(loads(PAINT, overrides=["until=0.06"]), out, progress=False)
    return out


def in_file_order(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [(channel.topic, msg.log_time, msg.data)
                for _, channel, msg in make_reader(f).iter_messages(log_time_order=False)]


def chunk_starts(path: Path) -> list[int]:
    with open(path, "rb") as f:
        return [index.chunk_start_offset for index in make_reader(f).get_summary().chunk_indexes]


def failed_status(end_ns: int) -> tuple[int, DerivedMessage]:
    codec = codec_for(RunStatus)
    status = RunStatus("failed", f"the disk filled up after {end_ns} ns", 1, end_ns / 1e9, 0)
    return end_ns, DerivedMessage(STATUS_TOPIC, codec.schema_name, "jsonschema", codec.schema_bytes(), "json",
                                  codec.encode(status))


def cut_copy(src: Path, dst: Path, size: int) -> Path:
    shutil.copyfile(src, dst)
    os.truncate(dst, size)
    return dst


def test_a_recording_cut_anywhere_is_sealed_into_a_valid_prefix(recording, tmp_path):
    whole = in_file_order(recording)
    size = recording.stat().st_size
    starts = chunk_starts(recording)
    assert len(starts) >= 4  # the cuts below fall in several chunks
    # inside chunks, right at and around their starts (a chunk whole, its message index cut off)
    cuts = sorted({size * k // 13 for k in range(1, 13)} | {s + d for s in starts[1:] for d in (-1, 0, 9)})
    kept_before = -1
    for cut in cuts:
        path = cut_copy(recording, tmp_path / "cut.mcap", cut)
        sealed = seal(path, failed_status)
        rec = Recording(path)  # magic, footer, summary and every CRC checked
        found = in_file_order(path)
        assert found[-1][0] == STATUS_TOPIC and rec.status().status == "failed"
        assert found[:-1] == whole[:sealed.messages], cut  # exactly the first messages, bytes and all
        assert sealed.end_ns == max((t for _, t, _ in found[:-1]), default=0)
        assert sum(c.count for c in rec.channels.values()) == len(found)  # the statistics agree
        assert sealed.size == path.stat().st_size and sealed.chunks_dropped == 0
        assert rec.scene().name  # the metadata and the scene attachment are indexed
        assert sealed.messages >= kept_before  # a later cut never keeps less
        kept_before = sealed.messages
    assert 0 < kept_before < len(whole)


@needs_mcap_check
def test_the_typescript_reader_reads_recordings_sealed_anywhere_around_a_chunk(recording, tmp_path):
    """@mcap/core (Foxglove's reader) finds a chunk's messages through its message index: cut in a
    chunk, just behind it (its index cut off whole) or inside its index, the sealed file's last
    chunk has its index again, and the reader decodes every message and agrees with the summary."""
    with open(recording, "rb") as f:
        chunk = make_reader(f).get_summary().chunk_indexes[2]
    after = chunk.chunk_start_offset + chunk.chunk_length
    paths = []
    for n, cut in enumerate((after - 50, after, after + 3, after + chunk.message_index_length - 1)):
        paths.append(cut_copy(recording, tmp_path / f"cut{n}.mcap", cut))
        seal(paths[-1], failed_status)
    done = subprocess.run(["node", str(CHECKER), *map(str, paths)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{len(paths)} passed, 0 failed" in done.stdout


def test_a_recording_cut_in_its_summary_keeps_everything_without_a_second_ending(recording, tmp_path):
    """The data section whole (the run's own status in it): every message, no ending added."""
    path = cut_copy(recording, tmp_path / "cut.mcap", recording.stat().st_size - 40)
    asked = []
    sealed = seal(path, lambda end_ns: asked.append(end_ns))
    assert asked == []
    assert in_file_order(path) == in_file_order(recording)
    assert Recording(path).status().status == Recording(recording).status().status
    assert sealed.messages == len(in_file_order(recording))


SEAL_IN_A_FULL_FILE = """
import resource, sys
from cosim.record.seal import seal
limit = int(sys.argv[2])
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
sealed = seal(sys.argv[1])
print(sealed.messages, sealed.chunks_dropped)
"""


def test_when_the_end_does_not_fit_whole_chunks_are_given_up(recording, tmp_path):
    """The file cannot grow past where it was cut (the disk still full): the last chunks go, to make
    room for the summary, and what is left is valid."""
    starts = chunk_starts(recording)
    cut = starts[3] + 100  # a little of the fourth chunk written
    path = cut_copy(recording, tmp_path / "cut.mcap", cut)
    done = subprocess.run([sys.executable, "-c", SEAL_IN_A_FULL_FILE, str(path), str(cut)], cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, check=True)
    messages, dropped = map(int, done.stdout.split())
    assert dropped >= 1
    assert path.stat().st_size <= cut
    Recording(path)
    assert in_file_order(path) == in_file_order(recording)[:messages]


def test_what_is_not_a_cut_recording_is_refused(tmp_path):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    text = tmp_path / "text.mcap"
    text.write_text("not a recording\n")
    for path in (empty, text):
        with pytest.raises(ValueError):
            seal(path)
