"""Bad input found by an audit, each now one line naming what is wrong and where (exit 2), or, for a
damaged recording that `cosim repair` can still mend, said where it is damaged:

- `render --span 1e-300` (an internal math domain error) and `render -o x.gif --fps 0.001` (an
  internal OverflowError in Pillow: a GIF frame lasts at most 655.35 s) are refused naming the option
  and its bound, which itself is accepted;
- a killed run's private file with a chunk failing its CRC: repair read up to that chunk only and
  called the file cut short there (644 of 9195 messages kept); it now leaves that chunk out, keeps the
  chunks after it and says where the damage is, as `inspect` does;
- `inspect` printed the recording's command line raw (a newline and a terminal escape in it split
  the line and cleared the screen);
- a recording without `dt_ns` in its metadata showed `dt = 0 s`, and one of 1e23 ns `dt = 1e+14 s`:
  both refused by inspect and replay, as a step that is no whole number of nanoseconds > 0 was.
"""

from __future__ import annotations

import json
import re
import struct
from pathlib import Path

import pytest
from mcap.reader import make_reader
from PIL import Image

from cosim.cli import main
from cosim.record.output import MCAP_MAGIC
from cosim.record.reader import Recording
from cosim.record.repair import repair
from cosim.runner import run_scene
from cosim.scenario import loads
from tests.cli_toys import one_error_line
from tests.recording_copies import copy_recording
from tests.test_reliability_output import PAINT
from tests.viewer_toys import record_skip

ROOT = Path(__file__).resolve().parent.parent

# --- render ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def skip_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("audit_render") / "skip.mcap"
    record_skip(path, ["record.visual_rate=0"])
    return path


@pytest.mark.parametrize("suffix", [".png", ".gif"])
def test_a_span_narrower_than_the_stone_is_refused_naming_the_narrowest(skip_path, tmp_path, capsys, suffix):
    """`--span 1e-300`: a box of no width around the stone, and an internal math domain error in its
    x ticks (exit 1). Refused: the narrowest span is the stone's diameter, which renders."""
    out = tmp_path / f"y{suffix}"
    to = ["--to", "0.05"] if suffix == ".gif" else []
    assert main(["render", str(skip_path), "-o", str(out), "-q", "--width", "160", "--span", "1e-300", *to]) == 2
    line = one_error_line(capsys.readouterr().err)
    found = re.fullmatch(r"error: --span 1e-300 m: narrower than the stone \(([0-9.e+-]+) m across\), which would "
                         r"more than fill the frame; give at least ([0-9.e+-]+) m", line)
    assert found, line
    assert float(found[2]) >= float(found[1]) and not out.exists()
    assert main(["render", str(skip_path), "-o", str(out), "-q", "--width", "160", "--span", found[2], *to]) == 0
    assert out.exists()


def test_a_span_a_pixel_of_which_the_coordinates_cannot_resolve_is_refused():
    """With a stone narrower than that (0.2 nm across, 1 m from the origin), the narrowest span is
    where a pixel is 1e-12 of its coordinates; one narrower still is too small to follow at all."""
    import numpy as np

    from components.analysis.render import RenderError, RenderOptions, _check_span

    class Point:
        radius = 1e-10
        position = np.array([[1.0, 0.0, 0.0]])

    options = RenderOptions(width=800, span=1e-12)
    with pytest.raises(RenderError, match=r"--span 1e-12 m: a pixel of the 800 px frame would be 1.25e-15 m, finer "
                                          r"than the stone's coordinates \(as large as 1 m\) resolve; give at least "
                                          r"8e-10 m"):
        _check_span(options, Point())
    options.span = 1e-9
    _check_span(options, Point())  # within
    Point.radius = 1e-20  # a pixel across in a window of 1.6e-17 m
    with pytest.raises(RenderError, match=r"is too small for a follow view: .*; use --view fixed"):
        _check_span(options, Point())


def test_a_bound_is_said_rounded_to_its_own_side():
    from components.analysis.render import GIF_MIN_FPS, _rounded

    for value in (0.1, 0.10004, 0.0999999, 123456.0, 999.7, GIF_MIN_FPS, 40.0):
        assert float(_rounded(value, up=True)) >= value and float(_rounded(value, up=False)) <= value
    assert _rounded(0.1, up=True) == "0.1" and _rounded(GIF_MIN_FPS, up=True) == "0.00153"


def test_a_gif_frame_longer_than_a_gif_holds_is_refused(skip_path, tmp_path, capsys):
    """`--fps 0.001`: a frame of 1000 s, beyond the 16-bit delay of a GIF (655.35 s): an internal
    OverflowError in Pillow (exit 1). Refused with the bound, at which the GIF is written."""
    out = tmp_path / "slow.gif"
    assert main(["render", str(skip_path), "-o", str(out), "-q", "--width", "160", "--fps", "0.001"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == (f"error: {out}: --fps must be at least 0.00153 for a GIF (a frame's delay is at most 65535 "
                    "hundredths of a second, 655.35 s), got 0.001")
    assert not out.exists()
    # (at a speed that leaves the run more than one frame: 0.3 s of it a frame)
    assert main(["render", str(skip_path), "-o", str(out), "-q", "--width", "160", "--fps", "0.00153",
                 "--speed", "0.000459"]) == 0
    with Image.open(out) as im:
        assert im.info["duration"] <= 655_350


# --- a damaged chunk ------------------------------------------------------------------------------

_CRC_AT = 9 + 8 + 8 + 8  # a chunk's uncompressed CRC: after its record's opcode and length, times and size


def seven_chunks(folder: Path) -> Path:
    """A whole recording of seven chunks in ``folder``: ten frames each (the first also the checkpoint
    at t = 0, its channels defined there), the sixth defining the status channel, the seventh holding
    the status."""
    out = folder / "whole.mcap"
    run_scene(loads(PAINT, overrides=["until=0.06"]), out, progress=False)
    return out


@pytest.fixture(scope="module")
def paint(tmp_path_factory) -> Path:
    return seven_chunks(tmp_path_factory.mktemp("audit_repair"))


def _chunks(path: Path) -> list:
    with open(path, "rb") as f:
        return sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)


def _messages(path: Path) -> int:
    return sum(c.count for c in Recording(path).channels.values())


def _damaged(src: Path, dst: Path, flip_at: int, cut_at: int | None = None) -> Path:
    data = bytearray(src.read_bytes()[:cut_at])
    data[flip_at] ^= 0xFF
    dst.write_bytes(bytes(data))
    return dst


def test_a_killed_runs_file_with_a_chunk_failing_its_crc_is_repaired_past_it(paint, tmp_path, capsys):
    """The private file of a run killed in its sixth chunk, its third chunk's CRC changed: repair kept
    the first two chunks and said the file was cut short (true, but not where its messages end); it
    keeps every chunk but the damaged one, and says which it left out and what its index listed."""
    chunks = _chunks(paint)
    third, sixth = chunks[2], chunks[5]
    cut_at = sixth.chunk_start_offset + 100
    whole_cut = tmp_path / "k.mcap.0123abcd.part"
    whole_cut.write_bytes(paint.read_bytes()[:cut_at])
    undamaged = repair(whole_cut, tmp_path / "undamaged.mcap")
    assert undamaged.messages == 51  # five whole chunks

    part = _damaged(paint, tmp_path / "flip.part", third.chunk_start_offset + _CRC_AT, cut_at)
    at = third.chunk_start_offset
    with pytest.warns(UserWarning) as said:
        assert main(["repair", str(part), "-o", str(tmp_path / "rflip.mcap")]) == 0
    out = tmp_path / "rflip.mcap"
    assert _messages(out) == 41 and Recording(out).end_ns == undamaged.end_ns
    assert [str(w.message) for w in said] == [
        f"{part}: the chunk at byte {at} fails its CRC: left out, with the 10 messages its index lists "
        f"(t = {third.message_start_time / 1e9:g} .. {third.message_end_time / 1e9:g} s)"]
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"wrote {out}: 41 messages, up to t = {undamaged.end_ns / 1e9:g} s, with no final status")
    assert line.endswith(f"; {part} was cut short, with 1 damaged stretch left out (above), and is left as it was")
    assert main(["inspect", str(out)]) == 0 and not undamaged.damage
    capsys.readouterr()

    assert main(["inspect", str(part)]) == 2  # inspect says the same
    line = one_error_line(capsys.readouterr().err)
    assert line == (f"error: {part}: not a readable MCAP recording (truncated or corrupt: no footer at its end; the "
                    f"file was cut short, or its writer was killed, and the chunk at byte {at} fails its CRC: cosim "
                    "repair makes what it holds a valid recording, leaving it out)")


def test_a_chunk_whose_length_is_damaged_is_left_out_up_to_the_next_whole_chunk(paint, tmp_path):
    """The length of the third chunk's record made to run past the file's end: the next chunk that is
    whole and passes its CRC is searched for, and reading goes on there."""
    chunks = _chunks(paint)
    third = chunks[2]
    part = _damaged(paint, tmp_path / "len.part", third.chunk_start_offset + 8, chunks[5].chunk_start_offset + 100)
    with pytest.warns(UserWarning, match=rf"the record at byte {third.chunk_start_offset} runs past the file's end "
                                         r"\(its length is damaged\): left out, with the messages it held"):
        done = repair(part, tmp_path / "out.mcap")
    assert done.messages == 41 and done.damage[0].end == chunks[3].chunk_start_offset


def test_a_whole_recording_with_a_damaged_chunk_keeps_the_rest_and_its_status(paint, tmp_path, capsys):
    """A closed recording: inspect names the chunk whose CRC fails (it said only that the data's CRC
    does not match), and repair keeps the chunks after it, the run's status with them."""
    third = _chunks(paint)[2]
    bad = _damaged(paint, tmp_path / "bad.mcap", third.chunk_start_offset + _CRC_AT)
    assert main(["inspect", str(bad)]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {bad}: corrupt: the CRC of its data does not match (changed on disk?): the chunk at byte "
        f"{third.chunk_start_offset} fails its CRC (cosim repair makes what it holds a valid recording, leaving "
        "it out)")
    with pytest.warns(UserWarning, match=f"the chunk at byte {third.chunk_start_offset} fails its CRC: left out"):
        done = repair(bad, tmp_path / "fixed.mcap")
    assert not done.cut_short and done.messages == _messages(paint) - 10
    assert done.status is not None and done.status.status == Recording(paint).status().status


def test_damage_that_takes_the_runs_description_is_not_sent_to_repair(paint, tmp_path, capsys):
    """A byte changed in the header's length: the damage takes the cosim metadata and the scene with
    it. inspect said repair would make it a valid recording, and repair then refused it ("not a cosim
    recording"); it now says repair cannot, as repair finds."""
    bad = _damaged(paint, tmp_path / "head.mcap", 10)
    assert main(["inspect", str(bad)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: {bad}: corrupt: the CRC of its data does not match (changed on disk?): ")
    assert line.endswith("(it takes its run's description with it, so cosim repair cannot make it a recording)")
    assert main(["repair", str(bad), "-o", str(tmp_path / "fixed.mcap")]) == 2
    assert "cannot be made a cosim recording" in capsys.readouterr().err
    assert not (tmp_path / "fixed.mcap").exists()


def test_a_repaired_recording_whose_gap_leaves_an_input_without_a_message_is_replayed_as_far_as_it_can(
        tmp_path, capsys):
    """ping_pong with its first chunk left out by repair: pong's input has no message at t = 0. The
    replay says so in one line naming the component, the input, its channel and the remedy (exit 2),
    and still reports the other component (ping: recorded nothing in the gap); pong was fed None and
    failed with an internal error (AttributeError), exit 1."""
    whole = tmp_path / "pp.mcap"
    run_scene(loads((ROOT / "scenarios" / "ping_pong.yaml").read_text(), source="ping_pong"), whole, progress=False)
    first = _chunks(whole)[0]
    bad = _damaged(whole, tmp_path / "bad.mcap", first.chunk_start_offset + _CRC_AT)
    with pytest.warns(UserWarning, match=f"the chunk at byte {first.chunk_start_offset} fails its CRC: left out"):
        repair(bad, tmp_path / "fixed.mcap")
    capsys.readouterr()
    assert main(["replay", str(tmp_path / "fixed.mcap")]) == 2
    said = capsys.readouterr()
    assert "ping: first divergence at t = 0.001 s on port 'out', field '<message>': recorded nothing" in said.out
    assert one_error_line(said.err) == (
        f"error: {tmp_path / 'fixed.mcap'}: cannot replay 'pong' at t = 0 s: its input 'inp' (/ping/out) has no "
        "message recorded at or before then: the recording has a gap there (a damaged chunk left out by repair); "
        "replay from a checkpoint after it (--from)")


def test_a_file_cut_short_without_damage_says_nothing_more(paint, tmp_path, recwarn):
    part = tmp_path / "cut.part"
    part.write_bytes(paint.read_bytes()[:_chunks(paint)[3].chunk_start_offset + 100])
    done = repair(part, tmp_path / "out.mcap")
    assert done.messages == 31 and not done.damage and not recwarn.list


# --- inspect and the recording's metadata ---------------------------------------------------------


def _rewritten(src: Path, dst: Path, change) -> Path:
    """A copy of the recording ``src`` whose cosim metadata is ``change(metadata)`` (CRCs intact)."""
    return copy_recording(src, dst, metadata=lambda name, fields: change(fields) if name == "cosim" else fields)


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("audit_meta") / "small.mcap"
    run_scene(loads((Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml").read_text(),
                    overrides=["until=0.01"]), out, progress=False)
    return out


def test_inspect_escapes_every_text_it_takes_from_the_recording(small, tmp_path, capsys):
    """The command line `x\\ny\\x1b[2J` was printed raw: a line split in two and the screen cleared."""
    crafted = _rewritten(small, tmp_path / "crafted.mcap", lambda m: {
        **m, "command_line": "x\ny\x1b[2J", "version": "1\r2", "overrides": json.dumps(["until=0.01\x1b[31m"])})
    assert main(["inspect", str(crafted)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\r" not in out
    lines = out.splitlines()
    assert lines[0].endswith("(cosim 1\\r2, dt = 0.001 s)")
    assert lines[1] == "  command: x\\ny\\x1b[2J" and lines[2] == "  overrides: until=0.01\\x1b[31m"


@pytest.mark.parametrize(("change", "said"), [
    (lambda m: {k: v for k, v in m.items() if k != "dt_ns"}, "dt_ns, the run's step, is missing"),
    (lambda m: {**m, "dt_ns": "99999999999999999999999"},
     "dt_ns is '99999999999999999999999', more nanoseconds than a recording's times hold (at most 2^63 - 1, about "
     "292 years)"),
    (lambda m: {**m, "dt_ns": str(2**63)}, f"dt_ns is '{2**63}', more nanoseconds than a recording's times hold"),
    (lambda m: {**m, "until_ns": "1" + "0" * 5000}, "until_ns is '100000000000000000000000'... (5001 characters), "
                                                   "more nanoseconds than"),
    (lambda m: {**m, "dt_ns": "\u00b2"}, "dt_ns is '\u00b2', not a whole number of nanoseconds > 0"),
])
def test_a_step_missing_or_beyond_a_recordings_times_is_refused_by_inspect_and_replay(small, tmp_path, capsys,
                                                                                      change, said):
    """No dt_ns was shown as `dt = 0 s`, and 1e23 ns as `dt = 1e+14 s`; replay ran on both."""
    bad = _rewritten(small, tmp_path / "bad.mcap", change)
    for command in ("inspect", "replay"):
        assert main([command, str(bad)]) == 2
        line = one_error_line(capsys.readouterr().err)
        assert line.startswith(f"error: {bad}: not a cosim recording (its metadata cannot be read: ") and said in line


def test_the_largest_step_a_recording_holds_is_read(small, tmp_path):
    good = _rewritten(small, tmp_path / "edge.mcap", lambda m: {**m, "dt_ns": "0" + str(2**63 - 1)})
    assert Recording(good).dt_ns == 2**63 - 1


def test_a_step_other_than_the_scenes_is_refused_by_replay(small, tmp_path, capsys):
    """dt_ns edited to 2 ms beside a scene of 1 ms: inspect showed the one and replay ran the other."""
    edited = _rewritten(small, tmp_path / "edited.mcap", lambda m: {**m, "dt_ns": "2000000"})
    assert main(["replay", str(edited)]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {edited}: its run's step dt_ns = 2000000 ns is not its scene's dt = 1000000 ns (with its "
        "overrides): the recording was edited")


@pytest.mark.parametrize("start", ["x", "-5", "1e9", "99999999999999999999999"])
def test_a_restart_time_that_is_not_a_time_is_refused(small, tmp_path, capsys, start):
    """start_ns that is not a whole number of nanoseconds was read as 0: the restart taken for a run
    from t = 0."""
    bad = _rewritten(small, tmp_path / "start.mcap", lambda m: {**m, "start_ns": start})
    assert main(["inspect", str(bad)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: {bad}: not a cosim recording (its metadata cannot be read: start_ns is ")


def test_a_run_from_the_start_reads_its_restart_time_as_zero(small, tmp_path):
    assert Recording(small).restart_ns == 0
    assert Recording(_rewritten(small, tmp_path / "zero.mcap", lambda m: {**m, "start_ns": "000"})).restart_ns == 0
    assert Recording(_rewritten(small, tmp_path / "half.mcap", lambda m: {**m, "start_ns": "5000000"})).restart_ns \
        == 5_000_000


def _nested_candidates(path: Path, size: int) -> Path:
    """A crafted file: a header, a chunk whose length runs past the end, then a chunk record every 49
    bytes, each framed by its own lengths to the file's end and failing its CRC (the resync's worst case)."""
    out = bytearray(MCAP_MAGIC)
    body = struct.pack("<I", 0) + struct.pack("<I", 0)  # profile "", library ""
    out += struct.pack("<BQ", 0x01, len(body)) + body
    out += struct.pack("<BQ", 0x06, 1 << 40)
    while len(out) + 49 <= size:
        rest = size - (len(out) + 49)
        out += struct.pack("<BQ", 0x06, size - len(out) - 9) + struct.pack("<QQQII", 0, 0, rest, 1, 0)
        out += struct.pack("<Q", rest)
    path.write_bytes(bytes(out + b"\0" * (size - len(out))))
    return path


def test_resynchronising_past_damage_reads_a_bounded_share_of_the_file(tmp_path, monkeypatch):
    """Nested candidate chunks, each running to the file's end, were each read back whole: quadratic
    in the file's size (54 s for 4 MB, hours for a recording's 40 MB, in inspect and repair)."""
    from cosim.record import seal

    read = []
    real = seal._read_chunk
    monkeypatch.setattr(seal, "_read_chunk", lambda chunk: (read.append(len(chunk)), real(chunk))[1])
    size = 256 * 1024
    seal.find_damage(_nested_candidates(tmp_path / "crafted.mcap", size))
    assert sum(read) <= seal.RESYNC_BUDGET * size  # (before: 2600 candidates, 340 times the file)


def test_a_whole_recording_whose_component_begins_without_a_direct_inputs_message_is_replayed(tmp_path, capsys):
    """ping_pong, whole: pong's required input, fed by a direct edge, has nothing before ping's first
    step, in the run as in the recording. The gap check refused every such recording (exit 2, "the
    recording has a gap there"); both components replay bit for bit."""
    whole = tmp_path / "pp.mcap"
    run_scene(loads((ROOT / "scenarios" / "ping_pong.yaml").read_text(), source="ping_pong"),
              whole, progress=False, until_ns=500_000_000)
    capsys.readouterr()
    assert main(["replay", str(whole)]) == 0
    said = capsys.readouterr().out
    assert "ping: 500 steps replayed, 500 outputs identical bit for bit" in said
    assert "pong: 500 steps replayed, 500 outputs identical bit for bit" in said
