"""`cosim repair` (cosim.record.repair) writes only what reads back as a cosim recording, and says
what it wrote as read back from it:

    NAME.mcap cut short --copy, seal, read back--> NAME-repaired.mcap   (exit 0: messages, end, status)
    whole, foreign, or nothing kept ----------------> nothing written   (exit 2: one line saying why)

Before, any file the reader refused was "cut short": a whole MCAP of another program, a recording
with its header damaged, or one cut before its first message was "repaired" (exit 0) into a file
`cosim inspect` refused, and every success said "no final status", status or not.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from cosim.cli import main
from cosim.record.reader import Recording
from cosim.runner import run_scene
from cosim.scenario import load
from tests.cli_toys import one_error_line

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


def test_a_whole_recording_damaged_in_its_header_is_refused(whole, tmp_path, capsys):
    """One byte changed at offset 30, in the header's library name: every record after it is whole,
    but the header cannot be read, so no copy of it reads either (it was 'repaired', 830 messages,
    into a file as unreadable)."""
    data = bytearray(whole.read_bytes())
    data[30] ^= 0xFF
    damaged = _written(tmp_path, "damaged.mcap", bytes(data))
    _refused(damaged, capsys, "damaged (corrupt: the CRC of its data does not match (changed on disk?)), and what "
                              "it holds whole is not a readable MCAP recording")


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
