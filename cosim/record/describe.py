"""``cosim inspect``: what a recording holds, how the run ended, and its timeline of labelled events.

Any channel whose messages carry a ``label`` field (a stage monitor's, for instance) is shown as a
timeline, each event at its message's ``since`` [s] where it has one (an event known a while after it
began), else at the message's time; the framework needs to know nothing about what the labels mean.

Every text taken from the file (its scene's name, version, command line, overrides, channels,
schemas, status and labels) is shown with its control characters and line breaks escaped
(:func:`cosim.errors.one_line`): a crafted recording cannot split a line or drive the terminal.
"""

from __future__ import annotations

import json
import math

from cosim.errors import RecordingError, counted, one_line
from cosim.record.reader import Recording
from cosim.record.recorder import STATUS_TOPIC
from cosim.timebase import NS_PER_S, exact_seconds, step_decimals

TIMELINE_MAX = 60  # timeline rows shown before eliding the middle


def _number(value: int | float) -> str:
    """A value as a reader wants it: integers as they are, floats to 4 significant digits."""
    return str(value) if isinstance(value, int) else f"{value:.4g}"


def timeline(rec: Recording) -> list[tuple[int, str, dict]]:
    """(time_ns, topic, message dict) of every message on a channel with a ``label`` field."""
    topics = sorted(t for t, ch in rec.channels.items() if "label" in ch.json_properties() and t != STATUS_TOPIC)
    if not topics:
        return []
    events = []
    for topic, stamp, data in rec.raw(topics):
        try:
            msg = json.loads(data)
        except ValueError as exc:  # not JSON (or not UTF-8): a damaged or crafted payload
            raise RecordingError(f"{rec.path}: {topic} at {stamp} ns: not a JSON message ({exc})") from None
        if not isinstance(msg, dict):
            raise RecordingError(f"{rec.path}: {topic} at {stamp} ns: not a JSON object but {type(msg).__name__}")
        if "label" in msg:  # (a message may leave its label out: no event)
            events.append((stamp, topic, msg))
    return events


def _began(stamp: int, msg: dict) -> int:
    """When an event began [ns]: its message's ``since`` [s] where it says (a state known some time after
    it began, as a stage monitor's rest), else the message's time ``stamp`` [ns]."""
    since = msg.get("since")
    if isinstance(since, (int, float)) and not isinstance(since, bool) and math.isfinite(since):
        return round(since * NS_PER_S)
    return stamp


def describe_recording(rec: Recording) -> str:
    meta = rec.metadata
    lines = [f"{one_line(rec.path)}: cosim recording of scene {meta.get('scene', '?')!r} "
             f"(cosim {one_line(meta.get('version', '?'))}, dt = {exact_seconds(rec.dt_ns)} s)"]
    if meta.get("command_line"):
        lines.append(f"  command: {one_line(meta['command_line'])}")
    if rec.overrides:
        lines.append(f"  overrides: {one_line(', '.join(rec.overrides))}")
    span = exact_seconds((rec.end_ns or 0) - (rec.start_ns or 0))
    since = ""
    if rec.restart_ns:
        # the span is of its messages: one that recorded nothing at its restart's time begins later
        first = rec.start_ns if rec.start_ns is not None and rec.start_ns > rec.restart_ns else rec.restart_ns
        later = f" from t = {exact_seconds(rec.restart_ns)} s" if first != rec.restart_ns else ""
        since = f" from t = {exact_seconds(first)} s (a restart{later})"
    status = rec.status()
    # a component stepping every few ticks stamps its outputs at its step's end, which can lie past the
    # tick the run stopped at: said, so that the two times do not read as a contradiction
    # (of a failed run, also the outputs of the steps its failing tick took before the failure)
    why = ("the steps taken in the failing tick before its failure" if status is not None and status.status == "failed"
           else "the last step of a component that steps every few ticks ends after the run's last tick")
    past = (f" (to t = {exact_seconds(rec.end_ns or 0)} s: {why})"
            if status is not None and (rec.end_ns or 0) > round(status.time * NS_PER_S) else "")
    lines.append(f"  time span: {span} s{since}{past}, {sum(c.count for c in rec.channels.values())} messages")
    if status is None:
        end = exact_seconds(rec.end_ns or 0)
        lines.append(f"  status: missing - the recording is incomplete: the run was cut off (killed?) and it "
                     f"ends at t = {end} s, with its last message")
    else:
        # a restart's tick counts its own steps from t = 0, which the run before it may have taken at
        # another dt: the steps said are the restart's own, from where it began
        steps, since = status.tick, ""
        if rec.restart_ns:
            steps -= rec.restart_ns // rec.dt_ns
            since = f" from t = {exact_seconds(rec.restart_ns)} s"
        lines.append(f"  status: {one_line(status.status)} at t = {exact_seconds(round(status.time * NS_PER_S))} s "
                     f"({counted(steps, 'step')}{since}) - {one_line(status.reason)}")
    lines.append("  channels:")
    width = max((len(one_line(t)) for t in rec.channels), default=10)
    for topic in sorted(rec.channels):
        ch = rec.channels[topic]
        lines.append(f"    {one_line(topic):<{width}}  {ch.count:>8}  {one_line(ch.schema_name)}")
    # in the order the events began (a rest, dated back to its slow spell's start, was listed after a
    # later stage of another body); the stream's order between events that began together
    events = sorted(timeline(rec), key=lambda event: _began(event[0], event[2]))
    if events:
        lines.append("  timeline:")
        if rec.restart_ns:  # (a restart publishes what changes after it: what was in force came before)
            lines.append(f"    (a restart from t = {exact_seconds(rec.restart_ns)} s: what was in force then, and "
                         "what came before, is in the recording it restarted from)")
        # to the step's last digit (at 50 us a hit at 0.07415 s read 0.0741 s, the run's summary 0.07415)
        decimals = max(4, step_decimals(rec.dt_ns))
        rows = [f"    {_began(stamp, msg) / NS_PER_S:{decimals + 5}.{decimals}f} s  {one_line(topic)}: "
                f"{one_line(msg['label'])}" +
                "".join(f", {one_line(k)} {_number(v)}" for k, v in msg.items() if k not in ("label", "stage", "since")
                        and isinstance(v, (int, float)) and not isinstance(v, bool))
                for stamp, topic, msg in events]
        if len(rows) > TIMELINE_MAX:
            half = TIMELINE_MAX // 2
            rows = [*rows[:half], f"    ... {len(rows) - TIMELINE_MAX} more ...", *rows[-half:]]
        lines += rows
    return "\n".join(lines)
