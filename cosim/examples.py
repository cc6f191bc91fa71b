"""Two tiny components for demos and the framework-overhead benchmark (no physics involved).

    ping.out --> pong.inp --> pong.out -(delay)-> ping.inp

``Ping`` adds one to what it receives; ``Pong`` halves it, so the loop settles at 1.
"""

from __future__ import annotations

from cosim.component import Component, Port
from cosim.messages import Message, message


@message
class Number(Message):
    """A plain number (no unit)."""

    value: float


class Ping(Component):
    """out = inp + 1."""

    inputs = {"inp": Port(Number, "the number to add one to", required=True)}
    outputs = {"out": Port(Number)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"out": Number(inputs["inp"].value + 1.0)}


class Pong(Component):
    """out = inp / 2."""

    inputs = {"inp": Port(Number, "the number to halve", required=True)}
    outputs = {"out": Port(Number)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"out": Number(inputs["inp"].value * 0.5)}
