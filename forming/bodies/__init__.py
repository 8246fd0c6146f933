"""Deformable bodies: solids with quadrature-point kernels, and fabric layers.

A new kind of body implements :class:`~forming.bodies.base.DeformableBody` (most
members come with :class:`~forming.bodies.base.BodyBase`) and is chosen by its
material in :func:`make_body`.
"""

from __future__ import annotations

from forming.bodies.base import BodyBase, DeformableBody
from forming.bodies.fabric import FabricBody
from forming.bodies.solid import PlasticState, SolidBody
from forming.domain import BodyDomain
from forming.materials.fabric import NonCrimpFabric
from forming.scene import Body, Scene

__all__ = ["BodyBase", "DeformableBody", "FabricBody", "PlasticState", "SolidBody",
           "make_body"]


def make_body(spec: Body, scene: Scene, domain: BodyDomain) -> DeformableBody:
    """The discrete body for a scene body: a fabric layer or a (plastic) solid."""
    if isinstance(spec.material, NonCrimpFabric):
        return FabricBody(spec, scene, domain)
    return SolidBody(spec, scene, domain)
