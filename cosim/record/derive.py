"""Viewer channels made where the recording is written, from the recorded messages.

A deriver (the viewer channels' :class:`cosim.view.items.VisualDeriver`) needs only the messages,
and every message it reads is recorded: so the writer process can make its channels as well as the
simulating process, on the other core. The recorder (:class:`cosim.record.recorder.Recorder`) sends
two kinds of records for it, besides the messages:

- ``("deriver", name, recipe)``: how the writer makes the deriver ``name``, a
  ``(module, function, args)`` recipe called once (only for a recording of every exchange and
  every channel: each viewer channel it makes is recorded);
- ``("derive", name, channel, component, port, (module, qualname))``: the recorded channel that
  carries the messages of ``/component/port``, of that message type, for deriver ``name``.

:class:`Derivation` is then shown every message as it is written (:meth:`Derivation.after`): a
message of a derived port, at or after the deriver's next frame, is decoded (as a replay decodes it:
bit for bit the message published) and what the deriver makes of it is written right after it. That
is the order the recorder gives when it calls the deriver itself, so the file is the same, byte for
byte (tests/test_recorded_visuals.py). The simulating process is spared the frames and the viewer
modules' import.

A warning the deriver gives in the writer process (a visuals function switched off) reaches the user
through the writer's error output: :func:`relay_warnings` writes each as a tagged line there, and the
simulating process gives it again (:func:`relayed_warnings`).
"""

from __future__ import annotations

import importlib
import sys
import threading
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

RELAY_TAG = "cosim-warning\t"  # a warning relayed on the writer's error output: TAG, module:category, tab, text
# the writer's own keys for the channels and schemas derived there, above any the recorder numbers
# (the MCAP writer numbers the channels in the file itself)
DERIVED_KEYS = 1 << 20

Recipe = tuple[str, str, tuple]  # (module, function, args): the writer's deriver is module.function(*args)


@dataclass
class DerivedMessage:
    """A message a deriver wants written: topic, schema name/encoding/bytes, message encoding, data."""

    topic: str
    schema_name: str
    schema_encoding: str
    schema_data: bytes
    message_encoding: str
    data: bytes


class _Target(Protocol):
    """Where derived messages go (:class:`cosim.record.writer._Apply`)."""

    logs: dict[int, Callable[[bytes, int], None]]

    def apply(self, record: tuple) -> int: ...


@dataclass
class _Port:
    """A recorded port some deriver makes viewer channels of."""

    component: str
    port: str
    decode: Callable[[bytes], Any]
    deriver: Any
    due_ns: int = 0  # the deriver's next frame for this port [ns]: messages before it are not decoded
    # the last message passed over since the last frame (time [ns], its bytes), for the final frame
    pending: tuple[int, bytes] | None = None


FINAL_FRAME_BYTES = 1 << 18  # a message passed over is kept for the final frame up to this size [bytes]


def make_deriver(recipe: Recipe) -> Any:
    """The deriver a recipe names."""
    module, function, args = recipe
    return getattr(importlib.import_module(module), function)(*args)


def message_type(path: tuple[str, str]) -> type:
    """The class at ``(module, qualname)`` (a message type, or a warning's category)."""
    module, qualname = path
    found: Any = importlib.import_module(module)
    for part in qualname.split("."):
        found = getattr(found, part)
    return found


class Derivation:
    """The derived channels of one recording: set up by the records above, fed every message written."""

    def __init__(self, target: _Target, ports: dict[int, list[_Port]] | None = None):
        """``ports``: the dict to keep the derived ports in, recorded channel -> its ports (the
        target's own, so that it sees at once which channels to show :meth:`after`)."""
        self.target = target
        self.derivers: dict[str, Any] = {}  # name -> the deriver (None: it could not be made)
        self.ports: dict[int, list[_Port]] = {} if ports is None else ports
        self._channels: dict[str, int] = {}  # derived topic -> the writer's key of its channel
        # (schema name, encoding, bytes) -> the writer's key of the schema: two derivers may name a
        # schema alike with other fields (a user's type beside a viewer's), each channel keeps its own
        self._schemas: dict[tuple[str, str, bytes], int] = {}
        self._next = DERIVED_KEYS

    def apply(self, record: tuple) -> None:
        """Take a ``deriver`` or ``derive`` record. One that cannot be followed (a recipe or a
        message type that does not import here) leaves its channels unmade, with a warning: the
        recording itself goes on."""
        ensure_site()
        try:
            if record[0] == "deriver":
                _, name, recipe = record
                self.derivers[name] = None  # until it is made
                self.derivers[name] = make_deriver(recipe)
                return
            from cosim.codec.wire import wire_codec

            _, name, channel, component, port, type_path = record
            deriver = self.derivers.get(name)
            if deriver is None:  # it could not be made (said when it failed)
                return
            decode = wire_codec(message_type(type_path)).decode
        except Exception as exc:
            what = f"deriver {record[2][:2]}" if record[0] == "deriver" else f"/{record[3]}/{record[4]}"
            _warn_unmade(what, exc)
            return
        self.ports.setdefault(channel, []).append(_Port(component, port, decode, deriver))

    def after(self, channel: int, time_ns: int, data: bytes) -> None:
        """The message ``data`` of ``channel`` at ``time_ns`` has been written: write what the
        derivers make of it. A port whose message cannot be decoded, or whose deriver fails, is
        switched off with a warning (the deriver's own looks failing are its business: it says so in
        the log channel); the recording goes on."""
        for p in tuple(self.ports.get(channel, ())):
            if time_ns < p.due_ns:
                # kept (copied: the batch's memory is reused) for the final frame; a large one (a
                # water field published faster than the frames) is not: the surface moves slowly
                p.pending = (time_ns, bytes(data)) if len(data) <= FINAL_FRAME_BYTES else None
                continue
            p.pending = None
            self._derive(p, channel, time_ns, data)

    def finish(self) -> None:
        """The final frame: what the derivers make of each port's last message, where it came after
        the port's last frame (the viewer left the stone up to a frame's time short of its end: 18 cm
        above the water, where it had gone under)."""
        for channel, ports in tuple(self.ports.items()):
            for p in tuple(ports):
                if p.pending is not None and getattr(p.deriver, "draws_final", False):
                    (time_ns, data), p.pending = p.pending, None
                    self._derive(p, channel, time_ns, data, final=True)

    def _derive(self, p: _Port, channel: int, time_ns: int, data: bytes, final: bool = False) -> None:
        """Write what ``p``'s deriver makes of its message ``data`` at ``time_ns`` (``final``: the
        run's last, drawn whatever the deriver's frame rate)."""
        try:
            msg = p.decode(data)
            made = list(p.deriver(time_ns, p.component, p.port, msg, final=True) if final
                        else p.deriver(time_ns, p.component, p.port, msg))
            p.due_ns = p.deriver.due_ns(p.component, p.port) if hasattr(p.deriver, "due_ns") else time_ns
        except Exception as exc:
            ports = self.ports[channel]
            ports.remove(p)
            if not ports:
                del self.ports[channel]
            _warn_unmade(f"/{p.component}/{p.port}", exc, time_ns)
            return
        for extra in made:  # (a write the file system refuses is the recording's failure, not the port's)
            self.target.logs[self._channel(extra)](extra.data, time_ns)

    def _channel(self, extra: Any) -> int:
        """The writer's key of a derived message's channel, registered on first use."""
        key = self._channels.get(extra.topic)
        if key is None:
            what = (extra.schema_name, extra.schema_encoding, extra.schema_data)
            schema = self._schemas.get(what)
            if schema is None:
                schema = self._schemas[what] = self._new()
                self.target.apply(("schema", schema, extra.schema_name, extra.schema_encoding, extra.schema_data))
            key = self._channels[extra.topic] = self._new()
            self.target.apply(("channel", key, extra.topic, extra.message_encoding, schema, None))
        return key

    def _new(self) -> int:
        self._next += 1
        return self._next


def _warn_unmade(what: str, exc: Exception, time_ns: int | None = None) -> None:
    when = "" if time_ns is None else f" from t = {time_ns / 1e9:g} s"
    warnings.warn(f"viewer channels of {what} are not made{when}: {type(exc).__name__}: {exc}",
                  RuntimeWarning, stacklevel=3)


_site = {"folders": (), "done": False}  # the site folders whose .pth entries deriving needs, once
_site_lock = threading.Lock()


def use_site_dirs(folders: Iterable[str]) -> None:
    """The site folders (a writer process starts without their ``.pth`` entries: an editable
    install's path) to read before anything is derived here (:func:`ensure_site`)."""
    _site["folders"] = tuple(folders)


def ensure_site() -> None:
    """Read the site folders' ``.pth`` entries, once, before a deriver or a message type is imported
    (whichever thread comes first: the preload or the first records)."""
    with _site_lock:
        if not _site["done"]:
            import site

            for folder in _site["folders"]:
                site.addsitedir(folder)
            _site["done"] = True


def preload(modules: Iterable[str]) -> None:
    """Import what deriving will need (run in the writer process while the simulation starts): the
    site folders' ``.pth`` entries (:func:`ensure_site`) and the ``modules`` (the derivers'
    recipes'), each then asked to ``warm_up()`` if it can (its first-use costs: what it loads
    lazily). Failures are left for the deriving itself to meet and report."""
    ensure_site()
    for module in modules:
        try:
            warm_up = getattr(importlib.import_module(module), "warm_up", None)
            if warm_up is not None:
                warm_up()
        except Exception:
            pass


def relay_warnings() -> None:
    """Write every warning of this process as one tagged line on its error output."""
    def show(message: Any, category: type[Warning], *args: Any, **kwargs: Any) -> None:
        text = str(message).replace("\n", " ")
        print(f"{RELAY_TAG}{category.__module__}:{category.__qualname__}\t{text}", file=sys.stderr, flush=True)

    warnings.showwarning = show


def relayed_warnings(text: str) -> list[tuple[type[Warning], str]]:
    """(category, text) of each warning relayed in a writer's error output ``text``: the writer's own
    category where this process can import it, else RuntimeWarning with the category named."""
    found: list[tuple[type[Warning], str]] = []
    for line in text.splitlines():
        if line.startswith(RELAY_TAG):
            name, _, message = line[len(RELAY_TAG):].partition("\t")
            try:
                category = message_type(tuple(name.split(":", 1)))  # type: ignore[arg-type]
            except Exception:
                category = None
            if isinstance(category, type) and issubclass(category, Warning):
                found.append((category, message))
            else:
                found.append((RuntimeWarning, f"the recording writer: {name}: {message}"))
    return found
