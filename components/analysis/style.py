"""Shared looks of the figures and the animation: stage colours and names, the stone's colour."""

from __future__ import annotations

from components.messages import StageId
from components.visuals import STONE_COLOR

STAGE_COLORS = {  # one colour per stage, the same in every figure and in the animation's text
    StageId.APPROACH: "#4c72b0",
    StageId.HIT: "#c44e52",
    StageId.SLIDE: "#dd8452",
    StageId.FLY_AWAY: "#55a868",
    StageId.SINK: "#8172b3",
    StageId.REST: "#937860",
    StageId.FLOAT: "#64b5cd",
    StageId.LEFT_POND: "#b0b0b0",
    StageId.GROUND: "#c7a46b",
}
UNKNOWN_STAGE_COLOR = "#7f7f7f"  # before the first stage message
STAGE_LABELS = {s: s.name.lower().replace("_", "-") for s in StageId}

WATER_LINE_COLOR = "#1f77b4"
STONE_RGB = STONE_COLOR[:3]  # as in the viewer channels
TRAIL_COLOR = "#404040"


def stage_color(stage: int) -> str:
    """The colour of a stage id (grey for none / unknown)."""
    try:
        return STAGE_COLORS[StageId(stage)]
    except ValueError:
        return UNKNOWN_STAGE_COLOR
