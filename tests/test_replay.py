"""Replay from a recording: each component alone, bit for bit; restart from a checkpoint."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from cosim.errors import RecordingError
from cosim.record.reader import Recording
from cosim.replay import replay_component, restart_simulation
from cosim.runner import run_scene
from cosim.scenario import load, loads
from tests.fmu_toys import fmu_cache  # noqa: F401  (FMUs the tests build go to a folder of their own)
from tests.toys import Gain

SCENES = Path(__file__).resolve().parent.parent / "scenarios"

SCENE = """
name: replayable
dt: 0.001
until: 0.1
components:
  src: {type: "tests.toys:Source", rate: 3}
  src2: {type: "tests.toys:Source", rate: 5}
  g: {type: "tests.toys:Gain", gain: 0.7}
  acc: {type: "tests.toys:Accumulator", every: 3}
  sum: {type: "tests.toys:Summer"}
connections:
  - g.out -> acc.x
  - {from: acc.total, to: g.x, delay: 1, initial: {value: 0.5}}
  - src.force -> sum.f
  - src2.force -> sum.f
  - acc.total -> sum.kick
record: {checkpoint_every: 0.02}
"""


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "run.mcap"
    run_scene(loads(SCENE), path, progress=False)
    return Recording(path)


@pytest.mark.parametrize("name", ["src", "g", "acc", "sum"])
def test_each_component_replays_bit_for_bit(recording, name):
    """Driven by its recorded inputs alone, every component reproduces every recorded output exactly
    (direct, delayed, multi-rate, additive and event inputs)."""
    report = replay_component(recording, name)
    assert report.ok, str(report)
    assert report.messages_compared > 30


def test_the_report_gives_each_components_own_cost_a_step(recording, monkeypatch):
    """The report says what the component's steps cost, alone on its recorded inputs: the clock is
    read around each step only, the first step (which loads compiled code) left out. A clock that
    moves 1.5 ms between any two readings makes that 1.5 ms a step."""
    readings = iter(range(10**6))
    monkeypatch.setattr("cosim.replay.time.perf_counter", lambda: 0.0015 * next(readings))
    report = replay_component(recording, "g")
    assert report.ok and report.steps == 100
    assert report.per_step_us() == pytest.approx(1500.0)
    assert str(report).endswith("outputs identical bit for bit; 1.5 ms a step")


class DriftingGain(Gain):
    """A deliberately changed Gain: from t = 40 ms its output is off by one part in 1e15."""

    def _step_impl(self, t, dt, inputs):
        out = super()._step_impl(t, dt, inputs)
        if t >= 0.040 - 1e-12:
            out["out"] = out["out"].replace(value=out["out"].value * (1 + 1e-15))
        return out


def test_changed_component_is_caught_at_the_right_step(recording):
    """A component that drifts from the recorded behaviour is reported at the first differing output:
    its time, port and field."""
    scene = recording.scene()
    report = replay_component(recording, "g", DriftingGain("g", scene.components["g"].params))
    assert not report.ok
    assert report.divergence.time_ns == 41_000_000
    assert (report.divergence.port, report.divergence.field) == ("out", "value")
    assert "first divergence at t = 0.041 s on port 'out', field 'value'" in str(report)


def test_restart_from_checkpoint_reproduces_the_original_run(recording, tmp_path):
    """Restarting from the checkpoint at 40 ms reproduces the original later messages exactly."""
    sim, stamp = restart_simulation(recording, 45_000_000)
    assert stamp == 40_000_000
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim)
    assert outcome.result.status == "ok"
    again = Recording(outcome.recording)
    from tests.toys import Scalar

    original = [(t, m.value) for t, m in recording.messages("/g/out", Scalar) if t > stamp]
    assert [(t, m.value) for t, m in again.messages("/g/out", Scalar)] == original


def test_restart_with_changed_settings(recording, tmp_path):
    """A restart can change settings, e.g. a finer base step, when the checkpoint time lies on it."""
    sim, _ = restart_simulation(recording, 60_000_000, overrides=["dt=0.0005"])
    assert sim.tick == 120
    outcome = run_scene(sim.scene, None, progress=False, simulation=sim)
    assert outcome.result.status == "ok" and outcome.result.tick == 200


def test_replay_errors_are_clear(recording):
    """Unknown components and missing checkpoints are reported plainly."""
    with pytest.raises(RecordingError, match=r"no component 'nope' in the recorded scene \(components: "):
        replay_component(recording, "nope")
    with pytest.raises(RecordingError, match=r"no checkpoint at or before t = -0.001 s"):
        restart_simulation(recording, -1_000_000)


def test_a_checkpoint_missing_what_a_component_restores_is_named(recording, monkeypatch):
    """A checkpoint whose component state lacks a key the scene's component reads (a component or
    setting changed by --set) names the key, not just the KeyError's bare 'total'."""
    found = Recording.checkpoint_at_or_before

    def broken(rec, from_ns):
        stamps, stamp, cp = found(rec, from_ns)
        acc = {**cp["components"]["acc"], "state": {}}
        return stamps, stamp, {**cp, "components": {**cp["components"], "acc": acc}}

    monkeypatch.setattr(Recording, "checkpoint_at_or_before", broken)
    with pytest.raises(RecordingError, match=r"cannot restart from the checkpoint at 0\.06 s: it holds no 'total' "
                                             r"for component 'acc', whose set_state reads it"):
        restart_simulation(recording, 60_000_000)


def test_a_restart_after_the_recorded_end_is_refused_with_the_end_named(recording):
    """--from beyond the run's end (0.1 s here) is an error naming both times, not a silent restart
    from the run's last checkpoint; the end itself is still a time within the run."""
    with pytest.raises(RecordingError, match=r"--from 99 s is after the recorded run's end \(t = 0.1 s\)"):
        restart_simulation(recording, 99 * 1_000_000_000)
    _, stamp = restart_simulation(recording, 100_000_000)
    assert stamp <= 100_000_000


def _cut_off(full: Recording, path, until_ns: int, metadata: dict[str, str] | None = None,
             cut_inside: str | None = None, damaged: tuple[str, int] | None = None) -> None:
    """The recording of a run cut off at ``until_ns``: its messages up to then, without the final
    status (as a run killed there leaves it); ``metadata`` changes entries of its cosim metadata;
    ``cut_inside`` a topic whose message at ``until_ns`` is left out too (the cut fell between a
    step's outputs); ``damaged`` (topic, time [ns]) a message whose payload is replaced by bytes no
    decoder reads (the file's checksums still match)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    from cosim.record.recorder import STATUS_TOPIC

    with open(full.path, "rb") as src, open(path, "wb") as dst:
        reader = make_reader(src)
        summary = reader.get_summary()
        writer = Writer(dst)
        writer.start(profile="", library="test")
        schemas = {sid: writer.register_schema(schema.name, schema.encoding, schema.data)
                   for sid, schema in summary.schemas.items()}
        ids = {cid: writer.register_channel(ch.topic, ch.message_encoding, schemas.get(ch.schema_id, 0), ch.metadata)
               for cid, ch in summary.channels.items()}
        for meta in reader.iter_metadata():
            writer.add_metadata(meta.name, {**meta.metadata, **(metadata or {})})
        for att in reader.iter_attachments():
            writer.add_attachment(att.log_time, att.create_time, att.name, att.media_type, att.data)
        for _, channel, message in reader.iter_messages(log_time_order=False):
            cut = channel.topic == cut_inside and message.log_time == until_ns
            data = b"\xff\xff not a payload" if damaged == (channel.topic, message.log_time) else message.data
            if channel.topic != STATUS_TOPIC and message.log_time <= until_ns and not cut:
                writer.add_message(ids[channel.id], message.log_time, data, message.publish_time)
        writer.finish()


def test_a_cut_off_recording_replays_each_component_up_to_where_it_ends(tmp_path):
    """A run killed part-way leaves a valid recording without its final status: each component
    replays bit for bit up to its last recorded output, and the report says the recording is
    incomplete (it was refused as a whole: 'no final status record')."""
    full = tmp_path / "full.mcap"
    run_scene(loads(SCENE), full, progress=False)
    cut = tmp_path / "cut.mcap"
    _cut_off(Recording(full), cut, 50_000_000)
    rec = Recording(cut)
    assert rec.status() is None
    for name in ("src", "g", "acc", "sum"):
        report = replay_component(rec, name)
        assert report.ok, str(report)
        assert report.cut_off_ns is not None and 40_000_000 <= report.cut_off_ns <= 50_000_000
        assert report.steps > 0 and "the recording is incomplete: replayed up to its last output" in str(report)
    whole = replay_component(Recording(full), "acc")
    assert whole.ok and whole.cut_off_ns is None and whole.steps > replay_component(rec, "acc").steps


def test_a_recording_cut_between_a_steps_outputs_replays_to_that_step(tmp_path):
    """A run killed (or repaired) with its last step's outputs partly written: the step missing an
    output is where the recording ends, not a divergence (it said 'recorded nothing, replayed ...')."""
    full = tmp_path / "full.mcap"
    run_scene(loads(SCENE), full, progress=False)
    cut = tmp_path / "cut.mcap"
    _cut_off(Recording(full), cut, 50_000_000, cut_inside="/src/force")
    report = replay_component(Recording(cut), "src")
    assert report.ok, str(report)
    assert report.cut_off_ns == 50_000_000 and report.steps == 50
    # the outputs of that step that were recorded are still compared: a change there is found, also
    # after the output the cut left out (the first one)
    from tests.toys import Force, Source

    class Changed(Source):
        def _step_impl(self, t, dt, inputs):
            out = super()._step_impl(t, dt, inputs)
            return {**out, "force": Force(out["force"].value + (1e-9 if t > 0.0485 else 0.0))}

    first_out = tmp_path / "cut_out.mcap"
    _cut_off(Recording(full), first_out, 50_000_000, cut_inside="/src/out")
    rec = Recording(first_out)
    assert replay_component(rec, "src").ok
    changed = replay_component(rec, "src", Changed("src", rec.scene().components["src"].params))
    assert not changed.ok and changed.divergence.port == "force" and changed.divergence.time_ns == 50_000_000


def test_a_restarted_run_replays_each_component_bit_for_bit(recording, tmp_path):
    """A recording made by a restart (`cosim replay RUN --from T -o NEW`) begins at its checkpoint:
    each component is replayed from the state it held there, its inputs' last messages and
    deliveries as the restart had them (it ended in false divergences and an internal error)."""
    sim, stamp = restart_simulation(recording, 45_000_000)
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim)
    again = Recording(outcome.recording)
    assert again.start_ns > 0 and again.checkpoints()[0][0] == stamp
    for name in ("src", "g", "acc", "sum"):
        report = replay_component(again, name)
        assert report.ok, str(report)
        assert report.steps == (100_000_000 - stamp) // 1_000_000 // (3 if name == "acc" else 1)


def test_a_restart_recorded_without_its_checkpoint_is_refused_in_one_line(recording, tmp_path):
    sim, _ = restart_simulation(recording, 45_000_000, overrides=["record.checkpoint_every=0"])
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim)
    with pytest.raises(RecordingError, match=r"cannot replay: a restart from t = 0.04 s, recorded without the "
                                             r"checkpoint it started from"):
        replay_component(Recording(outcome.recording), "g")


@pytest.mark.parametrize("overrides, said", [
    (["record.checkpoint_every=0"], "recorded without the checkpoint it started from"),
    (["record.every=2"], "the run recorded a selection of its exchanges"),
])
def test_what_keeps_every_component_from_a_replay_is_said_once(recording, tmp_path, capsys, overrides, said):
    """`cosim replay` of a restart recorded without its checkpoint, or of a thinned recording: one
    line, exit 2 (it was said again for each of the scene's components)."""
    from cosim.cli import main
    sim, _ = restart_simulation(recording, 45_000_000, overrides=overrides)
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim)
    assert main(["replay", str(outcome.recording)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and said in err[0], err


def test_a_run_from_t0_whose_first_message_comes_later_is_no_restart(tmp_path):
    """A run without checkpoints whose components publish nothing at t = 0 begins its recording a
    step in: it is still a run from t = 0, replayed as one (it was refused as a restart, and inspect
    called it one). A restart says so in its metadata."""
    from cosim.record.describe import describe_recording

    text = SCENE.replace("record: {checkpoint_every: 0.02}", "record: {checkpoint_every: 0}")
    text = text.replace('  acc: {type: "tests.toys:Accumulator", every: 3}\n', "")
    text = text.replace("  - g.out -> acc.x\n  - {from: acc.total, to: g.x, delay: 1, initial: {value: 0.5}}\n", "")
    text = text.replace("  - acc.total -> sum.kick\n", "")
    run_scene(loads(text), tmp_path / "late.mcap", progress=False)
    rec = Recording(tmp_path / "late.mcap")
    assert rec.start_ns > 0 and rec.restart_ns == 0
    assert replay_component(rec, "g").ok and replay_component(rec, "src").ok
    assert "(a restart)" not in describe_recording(rec)


@pytest.mark.parametrize("value", ["abc", "0", "-5", "1.5"])
def test_a_recording_whose_step_in_its_metadata_is_no_step_is_refused_in_one_line(tmp_path, capsys, value):
    """dt_ns: 'abc' in the cosim metadata (checksums intact) made inspect fail with an internal
    ValueError (exit 1), and '0' was shown as dt = 0 s: exit 2, naming the field and its value."""
    from cosim.cli import main
    from tests.cli_toys import one_error_line

    full = tmp_path / "full.mcap"
    run_scene(loads(SCENE), full, progress=False)
    bad = tmp_path / "bad.mcap"
    _cut_off(Recording(full), bad, 10**12, metadata={"dt_ns": value})
    for command in ("inspect", "replay"):
        assert main([command, str(bad)]) == 2
        line = one_error_line(capsys.readouterr().err)
        assert f"dt_ns is {value!r}, not a whole number of nanoseconds > 0" in line and str(bad) in line


def test_a_recording_whose_scene_does_not_match_its_channels_is_named(tmp_path, monkeypatch):
    """The scene attached to a recording names a source the recording holds no channel of (a file
    rewritten with another scene): replay says so, naming the input and the channel (it stopped on
    an AttributeError of the component fed None)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml").read_text()
    path = tmp_path / "pp.mcap"
    run_scene(loads(text, overrides=["until=0.01"]), path, progress=False)
    recording = Recording(path)
    other = loads(text.replace("pong", "echo"), overrides=["until=0.01"])
    monkeypatch.setattr(recording, "scene", lambda overrides=None: other)
    with pytest.raises(RecordingError, match=r"cannot replay 'ping': its input 'inp' comes from /echo/out, which "
                                             r"the recording holds no message of \(the run ended before its first, "
                                             r"or the attached scene is not the one that made the channels"):
        replay_component(recording, "ping")


def test_a_restart_refuses_a_changed_fmu_start_value_or_whole_component_mapping(tmp_path, capsys):
    """An FMU's ``start`` values, like a body's position, set what the restart takes from the
    checkpoint (the FMU's own saved state): `--set components.gust.start.peak_speed=0` is refused
    (the restart went on byte for byte as without it, and inspect listed it as applied), and so is
    a whole mapping (`components.gust={...}`, `components={...}`) whose start-only values differ from
    the recorded ones: exit 2, one line, no file. The recorded mapping given again is accepted."""
    pytest.importorskip("fmpy")
    pytest.importorskip("pythonfmu")
    import json

    import yaml

    from cosim.cli import main
    from tests.cli_toys import one_error_line
    from tests.fmu_toys import gust_scene

    scene = tmp_path / "gust.yaml"
    scene.write_text(gust_scene())
    path = tmp_path / "gust.mcap"
    assert main(["run", str(scene), "--until", "0.06", "-o", str(path), "-q"]) == 0
    capsys.readouterr()
    components = yaml.safe_load(gust_scene())["components"]
    calm = {**components["gust"], "start": {**components["gust"]["start"], "peak_speed": 0.0}}
    higher = {**components, "stone": {**components["stone"], "position": [0, 0, 2.0]}}
    out = tmp_path / "again.mcap"
    for override, said in (
            ("components.gust.start.peak_speed=0",
             "--set components.gust.start.peak_speed: sets gust's state at t = 0"),
            (f"components.gust={json.dumps(calm)}",
             "--set components.gust: changes gust's start (recorded {'peak_speed': 8.0, 'start_time': 0.05, "
             "'duration': 0.1}, given {'peak_speed': 0.0, "),
            (f"components={json.dumps(higher)}",
             "--set components: changes stone's position (recorded (0.0, 0.0, 1.0), given (0.0, 0.0, 2.0)), which "
             "only sets its state at t = 0")):
        assert main(["replay", str(path), "--from", "0.05", "--set", override, "-o", str(out), "-q"]) == 2
        line = one_error_line(capsys.readouterr().err)
        assert said in line and "from the checkpoint at 0.05 s instead" in line, line
        assert not out.exists()
    assert main(["replay", str(path), "--from", "0.05", "--set", f"components={json.dumps(components)}",
                 "-o", str(out), "-q"]) == 0


@pytest.mark.parametrize(("from_ms", "overrides", "said"), [
    (40, ["dt=0.0005"], "acc (every 3, a step of 1.5 ms) has its state at t = 0.042 s (its step spans the checkpoint), "
                        "but its first step would begin at t = 0.0405 s, 1.5 ms before it, counting that time twice; "
                        "give acc a step whose grid passes through t = 0.042 s, such as its recorded 3 ms: every 6 "
                        "with this dt (components.acc.every=6), or run the scene from t = 0 (cosim run)"),
    (40, ["components.acc.every=2"], "acc (every 2, a step of 2 ms) has its state at t = 0.042 s (its step spans the "
                                     "checkpoint), but its first step would begin at t = 0.04 s, 2 ms before it"),
    (60, ["components.acc.every=7"], "acc (every 7, a step of 7 ms) has its state at t = 0.06 s, but its first step "
                                     "would begin at t = 0.063 s, 3 ms after it, skipping that time"),
])
def test_a_restart_that_would_move_a_components_steps_off_its_state_is_refused(recording, from_ms, overrides, said):
    """acc steps every 3 ticks of 1 ms: at the checkpoint at 40 ms its state is at 42 ms (its step
    from 39 ms spans the checkpoint). A dt or every that starts its steps anywhere else shifted its
    clock silently (dt = 0.5 ms: a step from 40.5 ms published a second output stamped 42 ms;
    every 2: 2 ms counted twice; at 60 ms, every 7: 3 ms skipped); refused, naming the component,
    its every, the checkpoint's time and its state's, and a step that fits."""
    import re

    with pytest.raises(RecordingError, match=re.escape(f"cannot restart from the checkpoint at {from_ms / 1000:g} s "
                                                       "with dt = ") + ".*" + re.escape(said)):
        restart_simulation(recording, from_ms * 1_000_000, overrides)


def test_a_restart_on_the_components_step_grid_runs_on_and_an_off_grid_one_writes_nothing(recording, tmp_path,
                                                                                            capsys):
    """The step the refusal names (every 6 of 0.5 ms, acc's recorded 3 ms) restarts acc where its
    state is: its outputs from there on are the original run's, no stamp twice; the off-grid
    restart on the command line is exit 2, one line, no file."""
    from cosim.cli import main
    from tests.cli_toys import one_error_line
    from tests.toys import Scalar

    out = tmp_path / "again.mcap"
    assert main(["replay", str(recording.path), "--from", "0.045", "--set", "dt=0.0005", "-o", str(out), "-q"]) == 2
    assert "acc (every 3, a step of 1.5 ms) has its state at t = 0.042 s" in one_error_line(capsys.readouterr().err)
    assert not out.exists()
    sim, stamp = restart_simulation(recording, 45_000_000, ["dt=0.0005", "components.acc.every=6"])
    outcome = run_scene(sim.scene, out, progress=False, simulation=sim)
    assert outcome.result.status == "ok"
    again = [(t, m.value) for t, m in Recording(out).messages("/acc/total", Scalar)]
    assert again == [(t, m.value) for t, m in recording.messages("/acc/total", Scalar) if t > stamp]
    assert again[0][0] == 42_000_000


def test_a_restarts_default_name_tells_its_variants_apart(recording, tmp_path):
    """Without -o a restart is written beside its recording as NAME-fromTs.mcap; one with --set or
    --until as NAME-fromTs-set-<hash>.mcap, the hash of its overrides, as `cosim run` names a variant
    (each variant wrote NAME-fromTs.mcap, the last silently replacing the others)."""
    import hashlib
    import shutil

    from cosim.cli import main

    path = tmp_path / "run.mcap"
    shutil.copy(recording.path, path)
    for extra in ([], ["--set", "dt=0.0005", "--until", "0.08"], ["--until", "0.08"], ["--until", "0.09"]):
        assert main(["replay", str(path), "--from", "0.065", "-q", *extra]) == 0
    digest = hashlib.sha256(b"dt=0.0005\nuntil=0.08").hexdigest()[:8]
    names = sorted(p.name for p in tmp_path.glob("run-from*.mcap"))
    assert len(names) == 4 and {"run-from0.06s.mcap", f"run-from0.06s-set-{digest}.mcap"} <= set(names)


def test_restarts_from_checkpoints_apart_by_less_than_six_digits_are_named_apart(tmp_path):
    """A restart's default name and the times it is said at carry every digit of its checkpoint's time:
    restarts from 10 s and from 10.00004 s were both written as NAME-from10s.mcap (:g keeps six
    digits), the second replacing the first, and inspect said the second began at t = 10 s."""
    from cosim.cli import main
    from cosim.record.describe import describe_recording

    first, fine = tmp_path / "pong.mcap", tmp_path / "fine.mcap"
    assert main(["run", str(SCENES / "ping_pong.yaml"), "-q", "--until", "10.001", "--set",
                 "record.checkpoint_every=10", "-o", str(first)]) == 0
    assert main(["replay", str(first), "--from", "10", "-q", "--set", "dt=0.00002", "--set",
                 "record.checkpoint_every=0.00002", "--until", "10.0002", "-o", str(fine)]) == 0
    for start in ("10", "10.00004"):
        assert main(["replay", str(fine), "--from", start, "-q"]) == 0
    assert sorted(p.name for p in tmp_path.glob("fine-from*.mcap")) == ["fine-from10.00004s.mcap", "fine-from10s.mcap"]
    assert "from t = 10.00004 s (a restart)" in describe_recording(Recording(tmp_path / "fine-from10.00004s.mcap"))

def test_a_restarts_time_span_begins_where_its_messages_do(tmp_path):
    """A restart recording only channels with nothing at its checkpoint's time: inspect gave its span
    from the first message (0.999 s) but said it ran "from t = 1 s"; it says from where."""
    from cosim.cli import main
    from cosim.record.describe import describe_recording

    run, restart = tmp_path / "pp.mcap", tmp_path / "pong.mcap"
    assert main(["run", str(SCENES / "ping_pong.yaml"), "-q", "--until", "3", "-o", str(run)]) == 0
    assert main(["replay", str(run), "--from", "1", "--until", "2", "-q", "--set", "record.checkpoint_every=0",
                 "--set", "record.channels=[/pong/*]", "-o", str(restart)]) == 0
    said = describe_recording(Recording(restart))
    assert "  time span: 0.999 s from t = 1.001 s (a restart from t = 1 s), " in said


def test_a_restart_decodes_only_its_checkpoint_and_a_damaged_one_elsewhere_does_not_stop_it(recording, tmp_path,
                                                                                             monkeypatch):
    """--from T decoded every checkpoint in the file to use one (as costly as reading the file), and
    one that could not be decoded anywhere stopped every restart: the checkpoints' times are read
    from their records, and only the one restarted from is decoded."""
    from cosim.codec import state_proto
    from cosim.record.recorder import CHECKPOINT_TOPIC

    damaged = tmp_path / "damaged.mcap"
    _cut_off(recording, damaged, 10**12, damaged=(CHECKPOINT_TOPIC, 80_000_000))
    rec = Recording(damaged)
    with pytest.raises(RecordingError, match="the checkpoint at 80000000 ns cannot be read"):
        rec.checkpoints()
    decoded = []
    decode = state_proto.decode_checkpoint
    monkeypatch.setattr(state_proto, "decode_checkpoint", lambda data: decoded.append(len(data)) or decode(data))
    sim, stamp = restart_simulation(rec, 45_000_000)
    assert stamp == 40_000_000 and len(decoded) == 1 and sim.tick == 40
    with pytest.raises(RecordingError, match=r"damaged.mcap: the checkpoint at 80000000 ns cannot be read \("):
        restart_simulation(rec, 85_000_000)


def test_a_restart_from_before_a_restarted_recordings_start_says_where_it_began(recording, tmp_path):
    """A recording made by a restart from 40 ms holds no checkpoint before it: --from 30 ms says the
    recording is a restart and where it began (it said to record with record.checkpoint_every > 0,
    which it was)."""
    sim, _ = restart_simulation(recording, 45_000_000)
    outcome = run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim)
    with pytest.raises(RecordingError, match=r"no checkpoint at or before t = 0.03 s \(checkpoints at \[s\]: 0.04, "
                                             r"0.06, 0.08, 0.1\); this recording is a restart from 0.04 s: restart "
                                             r"from the recording it came from, or from 0.04 s or later$"):
        restart_simulation(Recording(outcome.recording), 30_000_000)


def test_inspect_counts_a_restart_at_another_dt_by_its_own_steps(recording, tmp_path):
    """A restart at half the step from 0.06 s to 0.1 s takes 80 steps of 0.5 ms: inspect says so. It
    said 200 steps "from t = 0", the last tick counted in the new step, where the run before took its
    first 60 at 1 ms."""
    from cosim.record.describe import describe_recording

    sim, _ = restart_simulation(recording, 60_000_000, overrides=["dt=0.0005"])
    outcome = run_scene(sim.scene, tmp_path / "fine.mcap", progress=False, simulation=sim)
    assert outcome.result.tick == 200
    status = [line for line in describe_recording(Recording(outcome.recording)).splitlines()
              if line.strip().startswith("status:")]
    assert len(status) == 1 and "(80 steps from t = 0.06 s)" in status[0], status


@pytest.mark.parametrize(("change", "said"), [
    (lambda cp: {**cp, "components": {k: v for k, v in cp["components"].items() if k != "acc"}},
     "holds no state of 'acc', a component of the recorded scene"),
    (lambda cp: {**cp, "edges": cp["edges"][:1]}, "holds the deliveries of 1 connections, the recorded scene has 5"),
])
def test_a_restart_whose_checkpoint_does_not_fit_its_scene_is_refused_in_one_line(recording, tmp_path, change, said):
    """Replaying a restart's recording whose checkpoint lacks a component or an edge of the scene that
    ran: exit 2 naming it (an internal KeyError or IndexError)."""
    from cosim.cli import main
    from cosim.codec import state_proto
    from cosim.codec.json_codec import plain_state
    from cosim.record.recorder import CHECKPOINT_TOPIC
    from tests.recording_copies import copy_recording

    sim, stamp = restart_simulation(recording, 40_000_000)
    outcome = run_scene(sim.scene, tmp_path / "restart.mcap", progress=False, simulation=sim)

    def message(channel, msg) -> bytes:
        if channel.topic == CHECKPOINT_TOPIC and msg.log_time == stamp:
            return state_proto.state_bytes(plain_state(change(state_proto.decode_checkpoint(msg.data))))
        return msg.data

    bad = copy_recording(outcome.recording, tmp_path / "bad.mcap", message=message)
    with pytest.raises(RecordingError, match=re.escape(f"cannot replay: the checkpoint at 0.04 s it restarted from "
                                                       f"{said}")):
        replay_component(Recording(bad), "g")
    assert main(["replay", str(bad)]) == 2


STOPPING = """
name: stopping
dt: 0.001
until: 1.0
components:
  src: {type: "tests.toys:Source", rate: 100}
  acc: {type: "tests.toys:Accumulator", stop_at: 0.5}
connections:
  - src.out -> acc.x
record: {checkpoint_every: 0.001}
"""


def test_a_restart_from_a_stopped_runs_last_checkpoint_stops_there(tmp_path):
    """The checkpoint of the tick in which a component asked to stop was written before the stop
    ended the run, and did not keep the request: a restart from it ran on past the stop (a held skip
    restarted at 2.239 s recorded its stone at 2.2395 s, which the original never reached). The
    restart ends where the original did, for the same reason, without a step more."""
    path = tmp_path / "stop.mcap"
    run_scene(loads(STOPPING), path, progress=False)
    status = Recording(path).status()
    assert status.status == "stopped"
    sim, stamp = restart_simulation(Recording(path), round(status.time * 1e9))
    assert stamp == round(status.time * 1e9)
    result = sim.run()
    assert (result.status, result.reason) == ("stopped", status.reason)
    assert sim.time_ns == stamp and result.component_steps == 0

    # a later end, or another way of recording, is the same run, which stopped there (--until took a
    # step more than it, as did a change of the viewer's rate)
    for same in (["until=2.0"], ["record.visual_rate=10"], ["record.checkpoint_every=0.01", "until=2.0"]):
        sim, _ = restart_simulation(Recording(path), stamp, overrides=same)
        assert sim.run().component_steps == 0 and sim.time_ns == stamp, same


def test_a_restart_taking_no_step_gives_the_stage_times_to_the_original_digits(tmp_path):
    """The stage monitor's step is part of its state: a restart from a stopped run's last checkpoint,
    which takes no step, printed the timeline to the millisecond (slide 0.025 s where the original
    said 0.0252 s)."""
    from cosim.scenario import load
    from cosim.scheduler import Simulation
    from cosim.timebase import exact_seconds

    path = tmp_path / "disk.mcap"
    # a checkpoint where the run stops (found by a run without a recording): the restart takes no step
    stopped = Simulation(load(SCENES / "free_disk.yaml", ["record.visual_rate=0"])).run()
    assert stopped.status == "stopped"
    scene = load(SCENES / "free_disk.yaml", [f"record.checkpoint_every={exact_seconds(stopped.time_ns)}",
                                              "record.visual_rate=0"])
    assert run_scene(scene, path, progress=False).result.status == "stopped"
    monitor = next(name for name, cfg in scene.components.items() if cfg.type_name == "StageMonitor")
    stop_ns = round(Recording(path).status().time * 1e9)
    sim, _ = restart_simulation(Recording(path), stop_ns)
    assert sim.run().component_steps == 0
    (line,) = [s for s in sim.components[monitor].summary() if "stages:" in s]
    assert "slide (0.0252 s)" in line
    assert sim.components[monitor].get_state()["step"] == 0.0001


SUBSTEPPING = """
name: substepping
dt: 0.001
until: 0.01
on_unstable: substep
components:
  src: {type: "tests.toys:Source"}
  acc: {type: "tests.toys:Accumulator", stable_step: 0.0004}
connections:
  - src.out -> acc.x
record: {checkpoint_every: 0.005}
"""


def test_a_restart_says_no_substep_change_that_the_original_did_not_make(tmp_path):
    """A component substepping all along (3 substeps a step, from the first): the restart's recording
    said again "3 substeps of acc per step" at the checkpoint (the count it compares with was not kept),
    and its summary's "up to" counted from the restart. The event names the stable step that set the
    count (it was asked after the step)."""
    from cosim.cli import main
    from cosim.record.recorder import Event

    def events(recording):
        return [(stamp, event.detail) for stamp, event in Recording(recording).messages("/cosim/events", Event)]

    path, again = tmp_path / "sub.mcap", tmp_path / "again.mcap"
    run_scene(loads(SUBSTEPPING), path, progress=False)
    assert events(path) == [(0, "3 substeps of acc per step (stable step 0.0004 s)")]
    assert main(["replay", str(path), "--from", "0.005", "-q", "-o", str(again)]) == 0
    assert events(again) == []


def test_a_restart_with_new_settings_from_a_stopped_runs_last_checkpoint_runs_under_them(tmp_path):
    """The same restart with --set (the stop's own setting raised) is another run from there: the
    stop the original asked for under its settings is not carried over (it ended at once, 0 steps)."""
    path = tmp_path / "stop.mcap"
    run_scene(loads(STOPPING), path, progress=False)
    stop_ns = round(Recording(path).status().time * 1e9)
    sim, _ = restart_simulation(Recording(path), stop_ns, overrides=["components.acc.stop_at=0.6"])
    result = sim.run()
    assert result.status == "stopped" and sim.time_ns > stop_ns and result.reason.startswith("acc: total reached 0.6")


def test_a_recording_that_kept_what_a_replay_needs_is_replayed_whatever_its_channel_patterns(tmp_path, capsys):
    """record.channels that match every exchange (`--record '*'`), or every one a component's replay
    needs (its outputs and inputs), were refused as "a selection"; a selection that leaves out
    what the replay needs is still refused, naming what it left out."""
    from cosim.cli import main

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml"
    every, part = tmp_path / "every.mcap", tmp_path / "part.mcap"
    run_scene(load(scene, ["until=0.05", "record.channels=['*']"]), every, progress=False)
    run_scene(load(scene, ["until=0.05", "record.channels=['/sphere/*', '/floor_sphere/*']"]), part, progress=False)
    assert main(["replay", str(every)]) == 0
    assert main(["replay", str(part), "--component", "sphere"]) == 0
    capsys.readouterr()
    assert main(["replay", str(part)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the run's record.channels left out /disk_flat/state" in err[0], err


def test_an_array_field_that_differs_is_shown_by_its_first_differing_element():
    """A replayed body state one bit off in one velocity component: numpy's print of the two arrays
    (8 digits) showed them alike, and a water window's took several lines. The report names the
    element and gives both values to every digit, on one line."""
    import numpy as np

    from components.messages import HeightPatch, Wrench
    from cosim.replay import _divergence

    force = np.array([7.61465171453155, -8.1e-22, -1.46])
    nudged = force.copy()
    nudged[0] = np.nextafter(force[0], 0.0)
    said = _divergence(80_000_000, "wrench", "force", Wrench(force, np.zeros(3)), Wrench(nudged, np.zeros(3)))
    assert str(said) == ("first divergence at t = 0.08 s on port 'wrench', field 'force[0]': recorded "
                         "7.61465171453155, replayed 7.614651714531549")
    height = np.zeros((30, 40))
    changed = height.copy()
    changed[3, 7] = 8.289046e-317

    def patch(h):
        return HeightPatch(0, 0, 0.01, 0.0, 0.0, 0.0, h, np.zeros((30, 40)), np.zeros((30, 40)))

    said = _divergence(0, "patch", "height", patch(height), patch(changed))
    assert str(said) == ("first divergence at t = 0 s on port 'patch', field 'height[3, 7]': recorded 0.0, "
                         "replayed 8.289046e-317")
    said = _divergence(0, "patch", "height", patch(height), patch(np.zeros((2, 2))))
    assert (said.field, said.expected, said.got) == ("height", "shape (30, 40)", "shape (2, 2)")
