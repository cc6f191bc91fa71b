"""The derived channels' schemas are told apart by their whole definition, not their name alone: two
derived messages naming a schema alike with other fields each get their own schema record, and a
schema used again is written once."""

from cosim.record.derive import Derivation, DerivedMessage


class Target:
    """Keeps what the derivation writes."""

    def __init__(self):
        self.logs = {}
        self.records = []

    def apply(self, record):
        self.records.append(record)


def message(topic: str, fields: bytes) -> DerivedMessage:
    return DerivedMessage(topic, "viewer.Marker", "jsonschema", fields, "json", b"{}")


def test_a_schema_named_alike_with_other_fields_is_its_own():
    target = Target()
    derivation = Derivation(target)
    first = derivation._channel(message("/a", b'{"type": "object", "properties": {"x": {}}}'))
    second = derivation._channel(message("/b", b'{"type": "object", "properties": {"y": {}}}'))
    third = derivation._channel(message("/c", b'{"type": "object", "properties": {"x": {}}}'))
    schemas = [r for r in target.records if r[0] == "schema"]
    channels = {r[2]: r[4] for r in target.records if r[0] == "channel"}
    assert len(schemas) == 2  # /a and /c share theirs
    assert [s[4] for s in schemas] == [b'{"type": "object", "properties": {"x": {}}}',
                                       b'{"type": "object", "properties": {"y": {}}}']
    assert channels["/a"] == channels["/c"] != channels["/b"]
    assert len({first, second, third}) == 3
