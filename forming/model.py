"""The discrete model of a scene: bodies, prescribed displacements, loads and constraints.

Each body has its own displacement field (:mod:`forming.bodies`); tool contacts and
skin-core interfaces are :class:`~forming.contact.base.Constraint` objects that add
their tractions to the residual of every body they act on. The model builds only what
the scene calls for: a scene without tools compiles no contact term, a frictionless
pair no tangential term. See ``docs/theory.md`` and ``docs/architecture.md``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection

import numpy as np
import ufl
from dolfinx import fem  # noqa: I001
from mpi4py import MPI

from forming import compat  # noqa: F401  (imports dolfinx the right way)
from forming.bodies import DeformableBody, make_body
from forming.contact.base import Constraint
from forming.domain import BodyDomain
from forming.history import ForceSampler, reaction_column, reaction_key
from forming.layout import Layout
from forming.log import collective_warning
from forming.mesh import bounding_box
from forming.scene import AffineDisplacement, Displacement, Scene

log = logging.getLogger(__name__)


class DirichletSet:
    """Prescribed displacements of a scene with their reaction-force forms.

    Args:
        scene: The scene.
        bodies: Its discrete bodies by name.
        residual: ``residual(body_name, w)``: the body's full residual (internal forces
            minus every external force on it) tested with ``w``; a reaction is its value
            for ``w`` = 1 on the face's dofs of one component.
    """

    def __init__(self, scene: Scene, bodies: dict, residual: Callable):
        self.items: list[tuple[Displacement, int, fem.Constant]] = []
        self.bcs: list[fem.DirichletBC] = []
        self.bc_bodies: list[str] = []  # the body of each entry of ``bcs``
        self._reaction_forms: dict[str, fem.Form] = {}
        # per reaction: its body and the indicator w (reaction = residual vector . w)
        self.reaction_weights: dict[str, tuple[str, fem.Function]] = {}
        self.affine: list[tuple[AffineDisplacement, int, fem.Function]] = []
        self._values: list[np.ndarray] = []  # views of ``items``' values (the setter: ~4 us)
        self._comm = scene.mesh.mesh.comm
        # per entry of ``bcs``: its body's displacement, its dofs there (owned), and its
        # prescribed values at them (the Constant, or the function and its own dofs)
        self._checks: list[tuple[fem.Function, np.ndarray, fem.Constant | fem.Function,
                                 np.ndarray | None]] = []
        several = len(bodies) > 1
        for d in scene.displacements:
            body = bodies[d.body]
            facets = body.domain.facets(d.region)
            if isinstance(d, AffineDisplacement):
                for comp in d.components:
                    Vc, _ = body.V.sub(comp).collapse()
                    u_bc = fem.Function(Vc)
                    dofs = fem.locate_dofs_topological((body.V.sub(comp), Vc), 2, facets)
                    self.bcs.append(fem.dirichletbc(u_bc, dofs, body.V.sub(comp)))
                    self.bc_bodies.append(d.body)
                    self._add_check(body, dofs[0], u_bc, dofs[1])
                    self.affine.append((d, comp, u_bc))
                continue
            for comp, _path in d.components():
                Vc = body.V.sub(comp)
                dofs = fem.locate_dofs_topological(Vc, 2, facets)
                const = fem.Constant(body.mesh, 0.0)
                self.bcs.append(fem.dirichletbc(const, dofs, Vc))
                self.bc_bodies.append(d.body)
                self._add_check(body, dofs, const, None)
                self.items.append((d, comp, const))
                self._values.append(const.value)
                if d.reaction:
                    w = fem.Function(body.V)
                    Vsub, _sub_map = body.V.sub(comp).collapse()
                    dofs_sub = fem.locate_dofs_topological((body.V.sub(comp), Vsub), 2, facets)[0]
                    w.x.array[dofs_sub] = 1.0
                    key = reaction_key(d.region, comp, d.body if several else None)
                    self.reaction_weights[key] = (d.body, w)
                    self._reaction_forms[key] = fem.form(
                        residual(d.body, w), entity_maps=_entity_maps(bodies) or None)

    def _add_check(self, body, dofs: np.ndarray, value, value_dofs) -> None:
        """Record a prescribed set for :meth:`held`: owned dofs, a function's matching ones."""
        imap = body.V.dofmap.index_map
        owned = dofs < imap.size_local * body.V.dofmap.index_map_bs
        self._checks.append((body.u, dofs[owned].copy(), value,
                             None if value_dofs is None else value_dofs[owned].copy()))

    def held(self) -> bool:
        """Whether every prescribed dof holds exactly its prescribed value, on every rank.

        Then the Dirichlet lifting of a residual, ``-J (g - u)`` over those dofs, is
        exactly zero and need not be assembled.
        """
        ok = True
        for u, dofs, value, value_dofs in self._checks:
            have = u.x.array[dofs]
            want = value.value if value_dofs is None else value.x.array[value_dofs]
            if not np.array_equal(have, np.broadcast_to(want, have.shape)):
                ok = False
                break
        return bool(self._comm.allreduce(ok, op=MPI.LAND))

    def set_load(self, t: float) -> None:
        """Set the prescribed values at load parameter ``t``."""
        for (d, comp, _const), value in zip(self.items, self._values, strict=True):
            value[...] = d.value(comp, t)
        for d, comp, u_bc in self.affine:
            row = np.asarray(d.gradient(t), dtype=float)[comp]
            u_bc.interpolate(lambda x, row=row: row @ x)

    @property
    def reaction_keys(self) -> list[str]:
        """Keys of the recorded reactions (``<region>_<axis>``)."""
        return list(self._reaction_forms)

    def reaction(self, key: str) -> float:
        """Static reaction force [N] on the recorded face ``key``, summed over ranks."""
        return self._comm.allreduce(fem.assemble_scalar(self._reaction_forms[key]),
                                    op=MPI.SUM)

    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """The recorded reactions, as the solver samples them [N]."""
        return {reaction_column(k): forces.reaction(k) for k in self._reaction_forms}


def _entity_maps(bodies: dict) -> list:
    """Entity maps of every body with a mesh of its own."""
    return [m for b in bodies.values() for m in b.domain.entity_maps]


def _extent_min(msh) -> float:
    """Smallest edge of the bounding box of a mesh over all ranks [mm]."""
    lo, hi = bounding_box(msh)
    return float((hi - lo).min())


class Model:
    """The discrete model of a scene: bodies, loads, tool contacts and interfaces.

    Each body has its own displacement field; the residual is one form per body
    (:meth:`residuals`), coupled through the constraints that act on several bodies.

    Attributes:
        scene: The scene.
        bodies: Discrete bodies by name, in block order.
        contacts: Tool contacts.
        interfaces: Skin-core interfaces.
        constraints: Every constraint: the contacts, then the interfaces.
        dirichlet: Prescribed displacements and their reactions.
        penalty_only: Whether the solver enforces contact by the penalty alone (explicit
            runs); the tool contacts' default penalties follow
            (:func:`~forming.contact.base.default_penalty`).

    Args:
        scene: The scene.
        penalty_only: As the attribute (:func:`forming.solver.penalty_only` of a job).
    """

    def __init__(self, scene: Scene, penalty_only: bool = False):
        from forming.contact.interface import InterfaceTerm, interface_entities
        from forming.contact.sliding import SlidingTerm
        from forming.contact.terms import ContactTerm, nodal_rule

        self.scene = scene
        self.penalty_only = penalty_only
        md = scene.mesh
        self.comm = md.mesh.comm
        self._t = self._t_committed = 0.0
        domains = {b.name: BodyDomain.create(md, b.region) for b in scene.bodies}
        self.bodies: dict[str, DeformableBody] = {
            b.name: make_body(b, scene, domains[b.name]) for b in scene.bodies}
        self.entity_maps = _entity_maps(self.bodies)
        thickness = {name: _extent_min(b.mesh) for name, b in self.bodies.items()}
        self.tractions = []
        for tr in scene.tractions:
            body = self.bodies[tr.body]
            const = fem.Constant(md.mesh, np.zeros(3))
            self.tractions.append((tr, const, body.domain.ds(tr.region)))
        self.contacts = [
            ContactTerm(c, scene.tool(c.tool), self.bodies[c.body], thickness[c.body],
                        penalty_only)
            for c in scene.contacts
        ]
        self.interfaces = []
        if scene.interfaces:
            data = [(i + 1, interface_entities(md, domains[itf.body], domains[itf.other],
                                               itf.region))
                    for i, itf in enumerate(scene.interfaces)]
            dS = ufl.Measure("dS", domain=md.mesh, subdomain_data=data)
            self.interfaces = []
            for i, itf in enumerate(scene.interfaces):
                first, second = self.bodies[itf.body], self.bodies[itf.other]
                # two quadratic faces are tied at all their 9 nodes; a quadratic face on
                # a linear one only at its corners (tying all 9 to the linear face's trace
                # locks the quadratic body: docs/theory.md section 11)
                degree = min(first.spec.degree, second.spec.degree)
                if first.spec.degree != second.spec.degree:
                    collective_warning(log, "interface %s: a quadratic body on a linear one is "
                                       "tied at the linear faces' corners only "
                                       "(docs/theory.md section 11)", itf.region)
                self.interfaces.append(InterfaceTerm(
                    itf, first, second, dS(i + 1, metadata=nodal_rule(degree)),
                    min(thickness[itf.body], thickness[itf.other]), degree))
        self.constraints: list[Constraint] = [*self.contacts, *self.interfaces]
        self.stabilisation = None
        if (spec := scene.stabilisation) is not None:
            from forming.stabilisation import ViscousStabilisation

            chosen = {n: b for n, b in self.bodies.items()
                      if not spec.bodies or n in spec.bodies}
            self.stabilisation = ViscousStabilisation(spec, chosen, md.mesh,
                                                      self.entity_maps or None)
        tests = self.test_functions()
        self.dirichlet = DirichletSet(
            scene, self.bodies, lambda name, w: self._residual_terms(tests | {name: w})[name])
        # constraints assembled outside the forms add by global index (no reaction forms:
        # a prescribed face should not carry a sliding surface)
        self.layout = Layout(self.bodies, self.comm)
        self.layout.set_prescribed(self.dirichlet.bcs, self.dirichlet.bc_bodies)
        self.sliding = [
            SlidingTerm(sl, self.bodies[sl.master], self.bodies[sl.slave], self.layout,
                        min(thickness[sl.master], thickness[sl.slave]))
            for sl in scene.sliding
        ]
        self.constraints += self.sliding
        self.self_contacts = []
        if scene.self_contacts:
            from forming.contact.selfcontact import SurfaceSelfContact

            self.self_contacts = [SurfaceSelfContact(sc, self.bodies[sc.body])
                                  for sc in scene.self_contacts]

    def surfaces_meet(self) -> str | None:
        """Why the state is not admissible to a solver that does not enforce self-contact.

        Returns:
            None while no self-contact surface meets itself; else what met (collective).
        """
        for sc in self.self_contacts:
            count, deepest = sc.meeting(sc.body.u.x.array)
            if count:
                return (f"the {sc.spec.region!r} faces of {sc.spec.body!r} meet ({count} "
                        f"nodes behind another cell's face, the deepest {-deepest:.3g} mm): "
                        "self-contact is enforced by the explicit solver only "
                        "(--set solver=explicit)")
        return None

    @property
    def t(self) -> float:
        """Load parameter of the current state."""
        return self._t

    @property
    def body(self) -> DeformableBody:
        """The first body of the scene (the only one in a single-body scene)."""
        return next(iter(self.bodies.values()))

    @property
    def names(self) -> list[str]:
        """Body names in block order."""
        return list(self.bodies)

    def bounding_box(self) -> np.ndarray:
        """Reference bounding box of the mesh, (min xyz, max xyz), over all ranks."""
        return bounding_box(self.scene.mesh.mesh)

    def tool_bounds(self) -> tuple[float, ...]:
        """Box in which tool surfaces are drawn: the body's box, padded."""
        box = self.bounding_box()
        pad = 0.35 * float(np.max(box[1] - box[0]))
        return tuple(float(v) for i in range(3) for v in (box[0, i] - pad, box[1, i] + pad))

    def tool_resolution(self) -> float:
        """Grid spacing for drawing tool surfaces [mm]."""
        b = self.tool_bounds()
        return max(b[1] - b[0], b[3] - b[2], b[5] - b[4]) / 120.0

    # -- forms -----------------------------------------------------------------------------
    def test_functions(self) -> dict[str, ufl.Argument]:
        """A test function of every body's displacement space, by body name."""
        return {n: ufl.TestFunction(b.V) for n, b in self.bodies.items()}

    def _residual_terms(self, tests: dict) -> dict[str, ufl.Form]:
        """Residual form of every body, tested with ``tests[name]``."""
        forms = {}
        for name, body in self.bodies.items():
            v = tests[name]
            form = body.residual(v)
            for tr, const, ds in self.tractions:  # only when the scene has loads
                if tr.body == name:
                    form = form - ufl.dot(const, v) * ds
            forms[name] = form
        for c in self.constraints:
            for name, r in c.residuals(tests).items():
                forms[name] = forms[name] + r
        if self.stabilisation is not None:
            for name, r in self.stabilisation.residuals(tests).items():
                forms[name] = forms[name] + r
        return forms

    def residuals(self) -> list[ufl.Form]:
        """One residual form per body, in :attr:`names` order."""
        forms = self._residual_terms(self.test_functions())
        return [forms[n] for n in self.names]

    def internal_residuals(self) -> list[ufl.Form]:
        """Internal virtual work of every body alone, in :attr:`names` order."""
        tests = self.test_functions()
        return [b.residual(tests[n]) for n, b in self.bodies.items()]

    def jacobians(self, stiffest: bool = False,
                  own: bool = True) -> list[list[ufl.Form | None]]:
        """Blocks ``J[i][j] = dF_i/du_j`` (None where body j does not enter F_i).

        Diagonal blocks use each body's consistent tangent (``stiffest``: its
        :meth:`stability_jacobian`, for the explicit time step); contact, traction-free
        interface and coupling terms are differentiated by UFL. ``own=False`` leaves
        the bodies' own tangents out (the solver computes them without forms).
        """
        tests = self.test_functions()
        trials = {n: ufl.TrialFunction(b.V) for n, b in self.bodies.items()}
        blocks: dict[tuple[str, str], ufl.Form] = {}

        def add(i: str, j: str, form) -> None:
            blocks[i, j] = form if (i, j) not in blocks else blocks[i, j] + form

        for name, body in self.bodies.items():
            tangent = body.stability_jacobian if stiffest else body.jacobian
            if own:
                add(name, name, tangent(trials[name], tests[name]))
        for c in self.constraints:
            r = c.residuals(tests)
            for i in r:  # (a constraint assembled outside the forms has none)
                for j in c.bodies:
                    add(i, j, ufl.derivative(r[i], self.bodies[j].u, trials[j]))
        if self.stabilisation is not None:
            for i, r in self.stabilisation.residuals(tests).items():
                add(i, i, ufl.derivative(r, self.bodies[i].u, trials[i]))
        return [[blocks.get((i, j)) for j in self.names] for i in self.names]

    # -- state -----------------------------------------------------------------------------
    def set_load(self, t: float) -> None:
        """Apply the loading programme at ``t`` (prescribed displacements, tool positions)."""
        self._t = t
        for b in self.bodies.values():
            b.load_increment = t - self._t_committed
            b.invalidate()
        self.dirichlet.set_load(t)
        if self.stabilisation is not None:
            self.stabilisation.set_load(t - self._t_committed)
        for tr, const, _ds in self.tractions:
            const.value[:] = tr.value(t)
        for c in self.constraints:
            c.set_load(t)

    def search_timing(self) -> dict[str, float]:
        """Rank means [s] of the contact searches and evaluations outside the forms.

        ``contact_search_s``: closest-point queries on surface-mesh tools; ``sliding_s``:
        finite sliding (search, the pairs' residuals and Jacobians), and
        ``sliding_imbalance``, its busiest rank's time over the mean (the pairs are each
        rank's own slave nodes: where one rank holds most of them, the other waits for it
        in the assembly). Each only for a scene that has such tools or interfaces.
        """
        out = {}
        shapes = [t.shape for t in self.scene.tools if t.shape.tracked]
        if shapes:
            local = sum(s.search_seconds for s in shapes)
            out["contact_search_s"] = self.comm.allreduce(local) / self.comm.size
        if self.sliding:
            local = sum(sl.seconds for sl in self.sliding)
            out["sliding_s"] = self.comm.allreduce(local) / self.comm.size
            busiest = self.comm.allreduce(local, op=MPI.MAX)
            out["sliding_imbalance"] = busiest / out["sliding_s"] if out["sliding_s"] else 1.0
        return out

    def add_residual(self, b) -> None:
        """Add the constraints assembled outside the forms to a residual vector."""
        for c in self.sliding:
            c.add_residual(b)

    def add_jacobian(self, A) -> None:
        """Add the constraints assembled outside the forms to a Jacobian matrix."""
        for c in self.sliding:
            c.add_jacobian(A)

    def track(self) -> None:
        """Every constraint follows the current configuration (before each assembly)."""
        for c in self.constraints:
            c.track()

    def commit(self, exclude: Collection[int] = ()) -> None:
        """Accept the converged state as history.

        Args:
            exclude: ``id`` of the bodies and constraints whose history the caller keeps
                itself (the explicit solver's element loops and nodal contacts).
        """
        self._t_committed = self._t
        if self.stabilisation is not None:  # first: its forces are the solve's, before
            self.stabilisation.commit()  # the bodies' history moves on
        for obj in (*self.bodies.values(), *self.constraints):
            if id(obj) not in exclude:
                obj.commit()

    def snapshot(self) -> dict:
        """Copy of the converged state (load, displacements, history, multipliers)."""
        return {
            "t": (self._t, self._t_committed),
            "bodies": [b.snapshot() for b in self.bodies.values()],
            "contacts": [c.snapshot() for c in self.constraints],
            "stabilisation": (None if self.stabilisation is None
                              else self.stabilisation.snapshot()),
        }

    def restore(self, snap: dict) -> None:
        """Return to a snapshot."""
        self._t, self._t_committed = snap["t"]
        for b, bs in zip(self.bodies.values(), snap["bodies"], strict=True):
            b.restore(bs)
        for c, cs in zip(self.constraints, snap["contacts"], strict=True):
            c.restore(cs)
        if self.stabilisation is not None:
            self.stabilisation.restore(snap["stabilisation"])

    def snapshot_layout(self) -> dict:
        """Where the arrays of :meth:`snapshot` live (a checkpoint on disk, forming.restart)."""
        return {"t": None,
                "bodies": [b.snapshot_layout() for b in self.bodies.values()],
                "contacts": [c.snapshot_layout() for c in self.constraints],
                "stabilisation": (None if self.stabilisation is None
                                  else self.stabilisation.snapshot_layout())}

    def displacements(self) -> list[np.ndarray]:
        """Copies of every body's displacement array, in :attr:`names` order."""
        return [b.u.x.array.copy() for b in self.bodies.values()]

    # -- history ---------------------------------------------------------------------------
    def history_columns(self, forces: ForceSampler) -> dict[str, float]:
        """The model's columns: smallest det F, reactions, tool forces, penetration, interfaces.

        The smallest det F at the bodies' points (``min_det_F``) and, for P1 hexahedra,
        at their elements' corners (``min_corner_det``, over the reference value).

        Each object writes its own; the model only adds the largest penetration over its
        tool contacts.
        """
        from forming.contact.terms import penetration_column
        from forming.history import merge

        row: dict[str, float] = {}
        owners: dict[str, str] = {}
        merge(row, {"min_det_F": min(b.min_det_F() for b in self.bodies.values())},
              "model", owners)
        corners = [d for b in self.bodies.values() if (d := b.track_corners()) is not None]
        if corners:
            merge(row, {"min_corner_det": min(corners)}, "model", owners)
        merge(row, self.dirichlet.history_columns(forces), "dirichlet", owners)
        for c in self.contacts:
            merge(row, c.history_columns(forces), f"contact {c.name}", owners)
        merge(row, penetration_column(self.contacts), "model", owners)
        for itf in self.interfaces:
            merge(row, itf.history_columns(forces), f"interface {itf.name}", owners)
        for sl in self.sliding:
            merge(row, sl.history_columns(forces), f"sliding {sl.name}", owners)
        if self.stabilisation is not None:
            merge(row, self.stabilisation.history_columns(), "stabilisation", owners)
        return row

    def warnings(self) -> list[str]:
        """What the bodies and constraints have to warn about (collective)."""
        out = [w for b in self.bodies.values() for w in b.warnings()]
        out += [f"contact {c.name}: friction {c.friction:g} is above 1 (the measured pairs lie "
                "between 0.23 and 0.57, docs/materials.md)"
                for c in self.constraints if c.friction > 1.0]
        out += [] if self.stabilisation is None else self.stabilisation.warnings()
        return out + [w for c in self.constraints for w in c.warnings()]

    def overlaps(self) -> list[str]:
        """Tools that overlap the blank beyond their tolerance in the current state."""
        out = []
        for c in self.contacts:
            depth = c.penetration()
            if depth > c.tolerance:
                out.append(f"tool {c.name} overlaps {c.spec.body} by {depth:.3g} mm "
                           f"(tolerance {c.tolerance:.3g} mm)")
        return out
