"""Property tests of the error boundary: random values in any scene field, random damage to a
recording. Whatever goes in, a command exits 0, 1 or 2; on an error its stderr starts with one
'error:' line (a ScenarioError lists one problem per indented line below it), never a traceback
and never an 'internal error' (an exception nobody turned into a clear message)."""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cosim.cli import main
from cosim.runner import run_scene
from cosim.scenario import loads

BASE = {
    "name": "prop",
    "dt": 0.001,
    "until": 0.02,
    "components": {"src": {"type": "tests.toys:Source"}, "g": {"type": "tests.toys:Gain", "gain": 2.0}},
    "connections": ["src.out -> g.x"],
    "record": {"checkpoint_every": 0.01},
}

# where a value may land: (path of keys, whether the run is still short whatever the value is)
FIELDS = [
    (("name",), True), (("dt",), False), (("until",), False), (("description",), True),
    (("on_unstable",), True), (("components",), True), (("components", "src"), True),
    (("components", "src", "type"), True), (("components", "src", "rate"), True),
    (("components", "g", "gain"), True), (("components", "g", "every"), True),
    (("components", "g", "step"), True), (("components", "g", "on_unstable"), True),
    (("components", "g", "bogus"), True), (("connections",), True), (("record",), True),
    (("record", "checkpoint_every"), True), (("record", "every"), True), (("record", "visual_rate"), True),
    (("record", "channels"), True),
]

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**30), max_value=10**30),
    st.floats(allow_nan=True, allow_infinity=True), st.floats(min_value=1e-18, max_value=1e-6),
    st.sampled_from([0, 1, -1, 1e308, -1e308, 1e-15, 5e-4, 1e21, "5e-4", "1e21", "", "..", "../x", "a/b",
                     "x\n", "tests.toys:Gain", "os:system", "RigidBody", "src.out -> g.x", "error", "substep"]),
    st.text(max_size=20),
)
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                      max_leaves=8)


def put(data: dict, path: tuple[str, ...], value) -> dict:
    node = data
    for key in path[:-1]:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    node[path[-1]] = value
    return data


def cli(*argv: str) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exit_:  # argparse
            code = exit_.code
    return code, err.getvalue()


def assert_clean(code: int, err: str) -> None:
    assert code in (0, 1, 2), (code, err)
    assert "Traceback" not in err and "internal error" not in err, err
    if code:
        lines = err.rstrip("\n").splitlines()
        assert lines and lines[0].startswith("error: "), err
        assert all(line.startswith("  ") for line in lines[1:]), err


def write(folder: Path, text: str, name: str = "scene.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(field=st.sampled_from(FIELDS), value=values)
def test_any_value_in_any_scene_field_is_a_clean_exit(field, value):
    """`cosim validate` (and, where the run stays short, `cosim run`) with one field set to anything."""
    path_keys, short = field
    data = put(yaml.safe_load(yaml.safe_dump(BASE)), path_keys, value)
    with tempfile.TemporaryDirectory() as tmp:
        scene = write(Path(tmp), yaml.safe_dump(data, allow_unicode=True))
        assert_clean(*cli("validate", str(scene)))
        if short:
            assert_clean(*cli("run", str(scene), "-o", str(Path(tmp) / "r.mcap"), "-q"))


@settings(max_examples=60, deadline=None)
@given(key=st.sampled_from(["dt", "until", "name", "components.g.gain", "components.g.every",
                            "record.checkpoint_every", "record.visual_rate", "nope.deeper"]),
       raw=st.one_of(st.text(max_size=12), st.sampled_from(["1e21", "1e-15", "[[[[", "{a: *b}", "!!python/none",
                                                            "&a [*a]", "0x10", ".inf", "-.nan"])))
def test_any_set_override_is_a_clean_exit(key, raw):
    """`--set KEY=anything` is a clean exit too (YAML tags, aliases, unclosed brackets included)."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = write(Path(tmp), yaml.safe_dump(BASE))
        assert_clean(*cli("validate", str(scene), "--set", f"{key}={raw}"))


@settings(max_examples=40, deadline=None)
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=200).map(lambda b: b.decode("latin-1")),
                      st.sampled_from(["[" * 300, "{" * 300, "a: &a [*a, *a]", "dt: !!binary AAAA", "- - -"])))
def test_any_scene_text_is_a_clean_exit(text):
    """Whatever a scene file holds, validate ends cleanly."""
    with tempfile.TemporaryDirectory() as tmp:
        assert_clean(*cli("validate", str(write(Path(tmp), text))))


_GOOD: list[bytes] = []


def good_recording() -> bytes:
    if not _GOOD:
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "good.mcap"
            run_scene(loads(yaml.safe_dump(BASE)), out, progress=False)
            _GOOD.append(out.read_bytes())
    return _GOOD[0]


damage = st.one_of(
    st.tuples(st.just("flip"), st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(1, 255)),
                                        min_size=1, max_size=5)),
    st.tuples(st.just("cut"), st.floats(0, 1, exclude_max=True)),
    st.tuples(st.just("insert"), st.tuples(st.floats(0, 1), st.binary(min_size=1, max_size=64))),
    st.tuples(st.just("replace"), st.binary(max_size=300)),
)


def damaged(data: bytes, how) -> bytes:
    kind, arg = how
    if kind == "flip":
        out = bytearray(data)
        for where, mask in arg:
            out[int(where * len(out))] ^= mask
        return bytes(out)
    if kind == "cut":
        return data[: int(arg * len(data))]
    if kind == "insert":
        where, extra = arg
        at = int(where * len(data))
        return data[:at] + extra + data[at:]
    return b"\x89MCAP0\r\n" + arg


@settings(max_examples=80, deadline=None)
@given(how=damage, command=st.sampled_from(["inspect", "replay"]))
def test_any_damage_to_a_recording_is_one_line(how, command):
    """Random flips, cuts, insertions or a foreign body: inspect and replay exit 2 with one line
    (or 0 where the damage left every byte that matters intact)."""
    data = good_recording()
    bad = damaged(data, how)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bad.mcap"
        path.write_bytes(bad)
        code, err = cli(command, str(path))
    assert_clean(code, err)
    assert code in (0, 2), err
    if code:
        assert len(err.strip().splitlines()) == 1, err
    elif bad != data:
        assert how[0] == "flip"  # only a flip can leave the file readable (e.g. a CRC field set to 0: not kept)
