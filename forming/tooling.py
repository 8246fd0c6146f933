"""The paper's tool sets around a blank: tools, their load paths and contact pairs.

Each builder takes a :class:`~forming.blanks.Blank` (a core alone or a sandwich), so the
same tooling serves the core, the sandwich and, later, meso-scale blanks.
"""

from __future__ import annotations

from typing import Literal

from forming.blanks import Blank
from forming.contact.shapes import AnnularPlate, HemisphericalPunch
from forming.scene import Contact, Linear, Tool

Stick = Literal["augmented", "elastic_slip"]


def hemisphere_tools(blank: Blank, punch_diameter: float = 100.0, die_diameter: float = 144.0,
                     edge_radius: float = 10.0, stroke: float = 50.0, friction: float = 0.36,
                     holder: bool = False, stick: Stick = "augmented"
                     ) -> tuple[tuple[Tool, ...], tuple[Contact, ...]]:
    """Hemispherical punch, die with a round opening and optional blank holder.

    The paper's "Core bending" set (Fig. 10): the punch travels ``stroke`` down from the
    blank's top; die and holder are fixed annular plates with edge radius
    ``edge_radius`` around an opening of ``die_diameter``.

    Returns:
        The tools (punch, die, holder) and the contacts of the blank's upper and lower
        bodies with them.
    """
    hole = die_diameter / 2
    tools = [Tool("punch", HemisphericalPunch((0.0, 0.0, blank.top), punch_diameter / 2,
                                              length=150.0), z=Linear(-stroke)),
             Tool("die", AnnularPlate((0.0, 0.0, blank.bottom), hole, edge_radius, side=-1))]
    contacts = [Contact(blank.upper, "top", "punch", friction=friction, stick=stick),
                Contact(blank.lower, "bottom", "die", friction=friction, stick=stick)]
    if holder:
        tools.append(Tool("holder", AnnularPlate((0.0, 0.0, blank.top), hole, edge_radius,
                                                 side=1)))
        contacts.append(Contact(blank.upper, "top", "holder", friction=friction, stick=stick))
    return tuple(tools), tuple(contacts)
