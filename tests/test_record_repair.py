"""`cosim repair` (cosim.record.repair) writes only what reads back as a cosim recording, and says
what it wrote as read back from it:

    NAME.mcap cut short --copy, seal, read back--> NAME-repaired.mcap   (exit 0: messages, end, status)
    whole, foreign, or nothing kept ----------------> nothing written   (exit 2: one line saying why)

Before, any file the reader refused was "cut short": a whole MCAP of another program, a recording
with its header damaged, or one cut before its first message was "repaired" (exit 0) into a file
`cosim inspect` refused, and every success said "no final status", status or not.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from cosim.cli import main
from cosim.errors import RecordingError
from cosim.record.output import MCAP_MAGIC
from cosim.record.reader import Recording
from cosim.record.repair import repair
from cosim.runner import run_scene
from cosim.scenario import load
from tests.cli_toys import one_error_line
from tests.recording_copies import copy_recording
from tests.test_bad_input_audit import _CRC_AT, seven_chunks
from tests.test_bad_input_audit import _chunks as _chunk_indexes

ROOT = Path(__file__).resolve().parents[1]
UNTIL_NS = 5_000_000_000  # ping_pong for 5 s: two chunks, the second ending with the run's status


@pytest.fixture(scope="module")
def whole(tmp_path_factory) -> Path:
    """A whole recording of ping_pong (two chunks), read-only to the tests: they cut copies of it."""
    out = tmp_path_factory.mktemp("repair") / "whole.mcap"
    outcome = run_scene(load(ROOT / "scenarios" / "ping_pong.yaml"), out, until_ns=UNTIL_NS, progress=False)
    assert outcome.result.status == "ok"
    return out


def _second_chunk_at(path: Path) -> int:
    with open(path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    assert len(chunks) == 2
    return chunks[1].chunk_start_offset


def _written(folder: Path, name: str, data: bytes) -> Path:
    path = folder / name
    path.write_bytes(data)
    return path


def _refused(path: Path, capsys, said: str) -> None:
    """``cosim repair path``: exit 2, one line naming ``path`` and saying ``said``, nothing written."""
    before = sorted(p.name for p in path.parent.iterdir())
    assert main(["repair", str(path)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: {path}: ") and said in line, line
    assert sorted(p.name for p in path.parent.iterdir()) == before  # no output, no temporary


def test_a_whole_recording_needs_no_repair(whole, capsys):
    """Said without promising that replay reads it: a closed file whose checks pass may still hold
    a scene replay cannot load (a crafted file with a scene of a name alone)."""
    _refused(whole, capsys, "is a whole recording already (it was closed, and its checks pass); "
                            "there is nothing to repair")


def test_a_whole_mcap_file_another_program_wrote_is_refused(tmp_path, capsys):
    """One channel, one message, written by the mcap package: not cosim's, and whole (it was
    'repaired' into a file inspect refused as not a cosim recording)."""
    foreign = tmp_path / "foreign.mcap"
    with open(foreign, "wb") as f:
        writer = Writer(f)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b"{}")
        writer.add_message(writer.register_channel("/x", "json", schema), log_time=1, data=b"{}", publish_time=1)
        writer.finish()
    _refused(foreign, capsys, "not a cosim recording (no 'cosim' metadata or 'scene.yaml' attachment; written by "
                              "'mcap-python/")
    _refused(foreign, capsys, "its MCAP records are whole (it was not cut short or damaged), so there is nothing "
                              "to repair")
    cut = _written(tmp_path, "foreign-cut.mcap", foreign.read_bytes()[:-40])
    _refused(cut, capsys, f"cut short at {cut.stat().st_size} bytes, and what it holds whole is not a cosim "
                          "recording")


@pytest.mark.parametrize(("at", "flip", "said"), [
    (30, 0xFF, "its library is not UTF-8 text"),  # a byte of the library's name
    (17, 0x40, "its profile's length runs past the record"),  # the profile's length
])
def test_a_whole_recording_damaged_in_its_header_has_the_header_written_anew(whole, tmp_path, capsys, at, flip,
                                                                               said):
    """The header (it has no CRC) damaged: every record after it is whole, and kept, the header
    written anew and said in a warning. It was refused ("what it holds whole is not a readable MCAP
    recording (... UnicodeDecodeError ...)"), a whole run's recording lost for one byte of its
    writer's name."""
    data = bytearray(whole.read_bytes())
    data[at] ^= flip
    damaged = _written(tmp_path, "damaged.mcap", bytes(data))
    with pytest.raises(RecordingError) as refused:  # what inspect and replay say of it
        Recording(damaged)
    assert str(refused.value).endswith(f"its header record (byte 8) is damaged ({said}) (cosim repair makes it a "
                                       "valid recording, its header written anew)")
    with pytest.warns(UserWarning) as given:
        assert main(["repair", str(damaged), "-o", str(tmp_path / "mended.mcap")]) == 0
    assert [str(w.message) for w in given] == [
        f"{damaged}: its header record (byte 8) is damaged ({said}): written anew, naming 'cosim repair' as its writer"]
    mended, original = Recording(tmp_path / "mended.mcap"), Recording(whole)
    assert mended.library == "cosim repair" and repr(mended.status()) == repr(original.status())
    assert {t: c.count for t, c in mended.channels.items()} == {t: c.count for t, c in original.channels.items()}
    assert capsys.readouterr().out.startswith(f"wrote {tmp_path / 'mended.mcap'}: ")


@pytest.mark.parametrize("size", [100, 1000])
def test_a_recording_cut_before_its_first_message_is_refused(whole, tmp_path, capsys, size):
    """Cut at 100 or 1000 bytes (in its metadata, in its scene): nothing to keep (it wrote a file of
    0 messages, without the run's metadata, that inspect and replay refused)."""
    cut = _written(tmp_path, "cut.mcap", whole.read_bytes()[:size])
    _refused(cut, capsys, f"cut short at {size} bytes, before its first whole message: nothing in it can be kept")


def test_a_recording_cut_in_its_summary_keeps_the_runs_status_and_says_so(whole, tmp_path, capsys):
    """Cut one byte short: every message and the run's `ok` status are kept, and the line says so
    (it said "no final status" while inspect showed `status: ok`)."""
    cut = _written(tmp_path, "cut.mcap", whole.read_bytes()[:-1])
    assert main(["repair", str(cut)]) == 0
    said = capsys.readouterr().out.strip()
    out = tmp_path / "cut-repaired.mcap"
    rec, was = Recording(out), Recording(whole)
    assert repr(rec.status()) == repr(was.status()) and rec.channels == was.channels  # Messages compare by identity
    messages = sum(c.count for c in rec.channels.values())
    assert said == (f"wrote {out}: {messages} messages, up to t = 5 s, with the run's final status: ok at t = 5 s; "
                    f"{cut} was cut short and is left as it was")


def test_a_recording_cut_mid_run_says_where_it_ends_without_a_status(whole, tmp_path, capsys):
    """Cut inside its second chunk: the first chunk's messages are kept, no status, and the line gives
    the count and end of what was written, read back from it."""
    cut = _written(tmp_path, "cut.mcap", whole.read_bytes()[:_second_chunk_at(whole) + 100])
    out = tmp_path / "deep" / "er" / "kept.mcap"
    assert main(["repair", str(cut), "-o", str(out)]) == 0
    said = capsys.readouterr().out.strip()
    rec = Recording(out)
    messages = sum(c.count for c in rec.channels.values())
    assert rec.status() is None and 0 < rec.end_ns < UNTIL_NS and messages > 0
    assert said == (f"wrote {out}: {messages} messages, up to t = {rec.end_ns / 1e9:g} s, with no final status "
                    f"(the run's end was cut off: cosim inspect says where it stops); {cut} was cut short and is "
                    "left as it was")
    assert main(["inspect", str(out)]) == 0


def test_an_output_not_named_as_a_recording_is_told_a_name_other_than_the_input(whole, tmp_path, capsys):
    """`repair cut.mcap -o cut.txt` suggested cut.mcap, the file being repaired, which the next try
    would then refuse as its own input."""
    cut = _written(tmp_path, "cut.mcap", whole.read_bytes()[:_second_chunk_at(whole) + 100])
    assert main(["repair", str(cut), "-o", str(tmp_path / "cut.txt")]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.endswith(f"a recording's file name ends in .mcap (give e.g. {tmp_path / 'cut-out.mcap'})")
    assert main(["repair", str(cut), "-o", str(tmp_path / "kept.txt")]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(f"(give e.g. {tmp_path / 'kept.mcap'})")


def test_a_refused_repair_leaves_no_folder_it_made(whole, tmp_path, capsys):
    cut = _written(tmp_path, "cut.mcap", whole.read_bytes()[:100])
    assert main(["repair", str(cut), "-o", str(tmp_path / "new" / "deeper" / "x.mcap")]) == 2
    assert "nothing in it can be kept" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "new").exists()


# --- a damaged chunk that defined the channels of the chunks after it ------------------------------

@pytest.fixture(scope="module")
def paint(tmp_path_factory) -> Path:
    return seven_chunks(tmp_path_factory.mktemp("repair_paint"))


def _flipped(src: Path, dst: Path, *at: int) -> Path:
    data = bytearray(src.read_bytes())
    for offset in at:
        data[offset] ^= 0xFF
    dst.write_bytes(bytes(data))
    return dst


def _in_file_order(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        return [(channel.topic, msg.log_time, msg.data)
                for _, channel, msg in make_reader(f).iter_messages(log_time_order=False)]


def test_a_closed_recording_keeps_the_chunks_after_one_that_defined_their_channels(paint, tmp_path, capsys):
    """The sixth chunk, defining the status channel the seventh uses, fails its CRC: the file's
    summary is intact and defines that channel, so its records are written where the damaged chunk
    was and the seventh chunk is kept, the run's status with it (repair kept only the five chunks
    before the damage: "the chunk ... after it uses a channel not defined before it")."""
    chunks = _chunk_indexes(paint)
    sixth = chunks[5]
    bad = _flipped(paint, tmp_path / "bad.mcap", sixth.chunk_start_offset + _CRC_AT)
    assert main(["inspect", str(bad)]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        f"the chunk at byte {sixth.chunk_start_offset} fails its CRC (cosim repair makes what it holds a valid "
        "recording, leaving it out)")
    with pytest.warns(UserWarning) as said:
        done = repair(bad, tmp_path / "fixed.mcap")
    assert [str(w.message) for w in said] == [
        f"{bad}: the chunk at byte {sixth.chunk_start_offset} fails its CRC: left out, with the 10 messages its index "
        f"lists (t = {sixth.message_start_time / 1e9:g} .. {sixth.message_end_time / 1e9:g} s)"]
    whole = _in_file_order(paint)
    kept = [m for m in whole if m[0] != "/p/frame" or not sixth.message_start_time <= m[1] <= sixth.message_end_time]
    assert len(whole) - len(kept) == 10
    assert _in_file_order(done.path) == kept  # every message of every other chunk, bytes and all
    assert done.status is not None and done.status.status == Recording(paint).status().status
    assert main(["inspect", str(done.path)]) == 0


def test_without_an_intact_summary_what_is_kept_still_ends_at_a_chunk_that_may_have_defined_a_channel(
        paint, tmp_path):
    """The same damage with the summary's CRC failing too: nothing says what the damaged chunk
    defined, so the copy ends where it begins, as before."""
    chunks = _chunk_indexes(paint)
    sixth = chunks[5]
    footer = paint.read_bytes()[-len(MCAP_MAGIC) - 29:-len(MCAP_MAGIC)]  # opcode, length, summary start, ...
    summary_start = struct.unpack("<BQQQI", footer)[2]
    bad = _flipped(paint, tmp_path / "bad.mcap", sixth.chunk_start_offset + _CRC_AT, summary_start + 20)
    with pytest.warns(UserWarning) as said:
        done = repair(bad, tmp_path / "fixed.mcap")
    assert done.messages == 51 and done.status is None
    assert [str(w.message) for w in said] == [
        f"{bad}: the chunk at byte {sixth.chunk_start_offset} fails its CRC: nothing from there on is kept (the chunk "
        f"at byte {chunks[6].chunk_start_offset} after it uses a channel not defined before it, which it may have "
        "defined)"]


# --- what is no recording to repair, or not yet one -------------------------------------------------


@pytest.mark.parametrize("content", [b"hello, this is not an mcap file\n" * 100, bytes(range(256)) * 40])
def test_a_file_that_is_not_mcap_at_all_is_said_to_be_none(tmp_path, capsys, content):
    """A text or random bytes were "cut short at 3200 bytes": they are no MCAP file."""
    path = _written(tmp_path, "text.mcap", content)
    _refused(path, capsys, "not an MCAP file (no MCAP magic at its start), so not a recording cosim repair can mend")


@pytest.mark.parametrize("size", [8, 9, 16, 17])
def test_a_file_cut_just_after_its_magic_is_said_to_be_cut_in_its_header(whole, tmp_path, capsys, size):
    """8 to 16 bytes, the MCAP magic whole: "no MCAP magic at its start" was said of them."""
    path = _written(tmp_path, "cut.mcap", whole.read_bytes()[:size])
    _refused(path, capsys, f"cut short at {size} bytes; nothing in it can be kept (its header is cut short)")


def test_a_file_a_live_run_is_writing_is_said_to_be_written_by_inspect_too(whole, tmp_path, capsys):
    """A run's private file, locked by the run writing it: inspect (as plot and replay, through the
    reader) said it was truncated or corrupt and that repair would mend it, where repair refused it
    as being written; both say a run is writing it."""
    import fcntl
    import os

    part = _written(tmp_path, "live.mcap.0123abcd.part", whole.read_bytes()[:_second_chunk_at(whole) + 100])
    fd = os.open(part, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # as the run writing it holds it
        for command in ("inspect", "repair"):
            assert main([command, str(part)]) == 2
            assert one_error_line(capsys.readouterr().err) == (
                f"error: {part}: a run is writing it now; it is finished when that run ends")
    finally:
        os.close(fd)
    assert main(["inspect", str(part)]) == 2  # once no run holds it, it is what a killed run left
    assert "cosim repair makes what it holds a valid recording" in one_error_line(capsys.readouterr().err)


def _with_scene(src: Path, dst: Path, scene: bytes) -> Path:
    """A copy of the recording ``src`` whose scene attachment is ``scene`` (every CRC matching)."""
    return copy_recording(src, dst, attachment=lambda att: scene if att.name == "scene.yaml" else att.data)


def test_a_scene_attachment_that_is_not_utf8_is_named(whole, tmp_path, capsys):
    """Every command said "not a cosim recording (its metadata cannot be read: 'utf-8' codec ...)":
    it is the scene that cannot be read."""
    bad = _with_scene(whole, tmp_path / "bad.mcap", b"\x00\xff: [")
    said = (f"error: {bad}: its scene (the 'scene.yaml' attachment) cannot be read: it is not UTF-8 text (byte 0xff "
            "at offset 1: invalid start byte)")
    for command in ("inspect", "replay"):
        assert main([command, str(bad)]) == 2
        assert one_error_line(capsys.readouterr().err) == said
