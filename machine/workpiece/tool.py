"""The cutter as the Z-map sees it: a solid of revolution (core, corner) from the tool table."""
from __future__ import annotations

from dataclasses import dataclass


class ToolError(ValueError):
    """The selected tool cannot cut a virtual workpiece (unknown, or without a size)."""


@dataclass(frozen=True, slots=True)
class Cutter:
    """number: T word; shape flat | ball | bull; core_mm the flat bottom's radius, corner_mm the radius of
    the rounded edge (ball: core 0, corner r; flat: corner 0); flutes for 002's tooth-pass model;
    length_mm: its tip below the gauge line the machine positions (the tool table's length_mm)."""

    number: int
    shape: str
    core_mm: float
    corner_mm: float
    flutes: int
    length_mm: float = 0.0

    @property
    def radius_mm(self) -> float:
        return self.core_mm + self.corner_mm

    @property
    def diameter_mm(self) -> float:
        return 2.0 * self.radius_mm

    def describe(self) -> str:
        if self.shape == "ball":
            size = f"ball r = {self.corner_mm:g} mm"
        elif self.shape == "bull":
            size = f"bull D = {self.diameter_mm:g} mm, corner r = {self.corner_mm:g} mm"
        else:
            size = f"flat D = {self.diameter_mm:g} mm"
        return f"T{self.number} {size}" + (f", {self.length_mm:g} mm long" if self.length_mm else "")


def cutter_from_table(tools: dict, number: int) -> Cutter:
    """The tool table's entry `number` (ipo.config.Tool) as a Cutter."""
    if number not in tools:
        known = ", ".join(f"T{n}" for n in sorted(tools)) or "none"
        raise ToolError(f"tool T{number} is not in the machine file's tool table (known: {known})")
    t = tools[number]
    shape = t.shape or ("ball" if t.ball_radius_mm > 0 else "flat")
    diameter = t.diameter_mm or 2.0 * t.ball_radius_mm
    if not diameter > 0:
        raise ToolError(f"tool T{number} has no size: give tools.{number}.diameter_mm (or ball_radius_mm)")
    radius = diameter / 2.0
    if shape == "ball":
        return Cutter(number, shape, 0.0, radius, t.flutes, t.length_mm)
    if shape == "bull":
        return Cutter(number, shape, radius - t.corner_radius_mm, t.corner_radius_mm, t.flutes, t.length_mm)
    return Cutter(number, "flat", radius, 0.0, t.flutes, t.length_mm)
