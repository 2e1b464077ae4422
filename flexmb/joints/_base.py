"""The `Joint` base class every joint plugin subclasses, and the mesh a joint hands to the model."""

from __future__ import annotations

import abc
from typing import ClassVar

import attrs
import numpy as np

from ..errors import UnsupportedStrategyError
from ..materials import STEEL, resolve

__all__ = ["Joint", "JointMesh", "ClosedForm", "MaterialJoint", "UNSET", "INTERNAL", "SIDE_A", "SIDE_B", "FLEXURE_MODELS"]

INTERNAL, SIDE_A, SIDE_B = 0, 1, 2


@attrs.frozen(eq=False)
class JointMesh:
    """A joint's finite-element model in its own frame (interface node A at the origin).

    Attributes
    ----------
    points
        Point coordinates [length], shape (n, dim), in the joint frame.
    side
        (n,) ints: `INTERNAL` (a free FE node), `SIDE_A` / `SIDE_B` (rigidly attached to the
        link on the joint's A / B side: connector blocks are exact rigid constraints).
    elements
        (E, 2) point indices of the beam elements.
    sections
        One `flexmb.sections.Section` per element.
    ny0
        (E, 3) local y axis of each element's cross-section in the joint frame (3D only; ``None`` in 2D).
    body
        (n,) ints or ``None``: `INTERNAL` points with the same ``body >= 0`` form one rigid
        intermediate body (exact rigid constraints, one FE node at the body's first point);
        ``-1`` marks a point that is a node of its own. ``None``: every internal point is a node.
    stress_sections
        One `flexmb.sections.Section` per element, or ``None`` (default: the element's own
        section): the section where the element's stresses are recovered (`flexmb.fe.stress`,
        the plausibility checks), e.g. its thinnest in a variable section, whose stiffness
        ``sections`` averages over the element (see docs/plugins.md).
    """

    points: np.ndarray
    side: np.ndarray
    elements: np.ndarray
    sections: tuple
    ny0: np.ndarray | None = None
    body: np.ndarray | None = None
    stress_sections: tuple | None = None


#: Wrench models of a constant-stiffness flexure (Cammarata et al. 2022): balance of the flexure in the
#: undeformed configuration (Eq. 15) or with the tip displacement in the moment arm (Eq. 17).
FLEXURE_MODELS = ("linear", "partial-nonlinear")


@attrs.frozen(eq=False)
class ClosedForm:
    """A planar flexure as a constant end stiffness (Cammarata et al. 2022, Secs. 2-3).

    The flexure is clamped at node A (joint frame origin, the *first* section S_if) and its
    end section S_fj sits at ``end`` [length] in the joint frame, rotated by ``end_angle`` [rad]
    (A_f of Eq. 16). ``stiffness`` K_f (3, 3) maps the end's displacement and rotation
    psi_f = [x', phi] to the end wrench [F_x, F_y, M], both in the undeformed end frame (Eq. 1).
    ``model`` is one of `FLEXURE_MODELS`.
    """

    stiffness: np.ndarray
    end: np.ndarray
    end_angle: float
    model: str = "partial-nonlinear"


class Joint(abc.ABC):
    """Base class of flexure joints, the edges of a `flexmb.Mechanism`.

    A subclass sets ``kind`` (its entry-point name in the ``flexmb.joints`` group) and
    ``dims`` (the mechanism dimensions it supports), and implements the models it offers;
    ``capabilities`` lists them so a strategy that needs one the joint lacks fails with a clear
    `UnsupportedStrategyError`. Joints are immutable values (use ``attrs.evolve`` to vary one).

    Capabilities used by the shipped strategies:

    ``"fe_model"``
        `mesh` returns the joint's beam-element model (conventional method).
    ``"closed_form"``
        `closed_form` returns a constant end stiffness (planar; ``method="newton"``).
    ``"database"``
        `database_key` names the shape parameters its trained kinematic data depend on
        (`flexmb.database`; KSD strategies).
    """

    kind: ClassVar[str] = ""
    dims: ClassVar[tuple[int, ...]] = (2, 3)
    #: Valid ranges ``{name: (low, high)}`` of shape parameters that `flexmb.testing` draws
    #: from (parameters not listed keep their defaults; required parameters must be listed).
    parameter_ranges: ClassVar[dict[str, tuple[float, float]]] = {}
    #: Intended rotation [rad] up to which the joint is meant to work, for the conformance tests.
    motion_range: ClassVar[float] = 0.3
    #: Database training settings overriding `flexmb.database.TRAINING` (``range_deg``,
    #: ``step_deg``, ``element_powers``, ``constraint_powers``, ``length_powers``), checked against
    #: `flexmb.database.TRAINING_SCHEMA` (unknown keys refused; docs/plugins.md).
    training: ClassVar[dict] = {}
    #: Name of the integer parameter that sets the number of beam elements of `mesh` (e.g.
    #: ``"elements_per_leaf"``): `flexmb.discretisation.refined` multiplies it to refine the mesh.
    #: None: the joint's mesh cannot be refined (its discretisation error cannot be estimated).
    mesh_parameter: ClassVar[str | None] = None

    @property
    def capabilities(self) -> frozenset[str]:
        """What the joint offers the solvers: ``"fe_model"`` (a `mesh`), ``"closed_form"``, ``"database"``."""
        caps = set()
        if type(self).mesh is not Joint.mesh:
            caps.add("fe_model")
        if type(self).closed_form is not Joint.closed_form:
            caps.add("closed_form")
        if type(self).database_key is not Joint.database_key:
            caps.add("database")
        return frozenset(caps)

    @abc.abstractmethod
    def interface_b(self, dim: int) -> np.ndarray:
        """Position of interface node B in the joint frame [length], shape (dim,); node A is the origin."""

    def mesh(self, dim: int) -> JointMesh:
        """The joint's finite-element model in its own frame (see `JointMesh`)."""
        raise UnsupportedStrategyError(
            f"joint kind {self.kind!r} has no finite-element model; it offers {sorted(self.capabilities)}"
        )

    def element_count(self, dim: int) -> int | None:
        """The number of beam elements `mesh` will hold, when known without meshing (flexmb then
        refuses a model too big to solve before building it); None: not known (the default)."""
        return None

    def closed_form(self, dim: int) -> ClosedForm:
        """The joint as a constant-stiffness flexure between its two links (see `ClosedForm`)."""
        raise UnsupportedStrategyError(
            f"joint kind {self.kind!r} has no closed-form model; it offers {sorted(self.capabilities)}"
        )

    def database_key(self) -> dict:
        """The dimensionless shape parameters that select the joint's trained database file."""
        raise UnsupportedStrategyError(
            f"joint kind {self.kind!r} has no joint database; it offers {sorted(self.capabilities)}"
        )

    def kinematic_constraints(self, dim: int) -> tuple[str, ...]:
        """Constraints on the unintended motion for the KSD kinematic step, named from
        `flexmb.ksd.constraints.NAMES`: by default node B's offsets from A as trained functions of
        the intended rotation (Eq. 2.1) and, in 3D, no out-of-plane offset and no tilt."""
        return ("x", "y") if dim == 2 else ("z", "tilt_x", "tilt_y", "x", "y")

    def describe(self) -> dict:
        """Parameters as a plain dict (for tables, JSON and error messages)."""
        return attrs.asdict(self) if attrs.has(type(self)) else {}


class _Unset:
    """The default of a material keyword: not given (None is a value: ``yield_stress=None``)."""

    def __repr__(self) -> str:
        return "UNSET"

    def __reduce__(self):
        return "UNSET"


#: A material keyword not given.
UNSET = _Unset()


def _material_keyword(name: str):
    """An init-only material keyword (``E``, ``G``, ``nu``, ``density``, ``yield_stress``): folded
    into ``material`` when the joint is made, then `UNSET` (reads go to the `Material`)."""
    return attrs.field(default=UNSET, alias=name, eq=False, repr=False)


@attrs.frozen(kw_only=True, cache_hash=True)
class MaterialJoint(Joint):
    """A joint made of one `flexmb.Material`: the base of the shipped flexures.

    ``material``: a `flexmb.Material` or a catalogue name (`flexmb.materials.CATALOGUE`, SI; in a
    mechanism with declared units give it to `flexmb.Mechanism.add_joint`, which resolves it in
    them). The keywords ``E``, ``G``, ``nu``, ``density``, ``yield_stress`` still work: alone they
    complete the joint's default material (`default_material`), beside ``material`` they replace
    its values (so ``attrs.evolve(joint, E=...)`` works). The checks are the `Material`'s, once.
    ``joint.E``, ``.G``, ``.density``, ``.yield_stress`` read the material.
    """

    #: The material of a joint given none (None: ``E`` is required, ``G`` from `default_shear`).
    default_material: ClassVar = STEEL

    material: object = STEEL
    _E: object = _material_keyword("E")
    _G: object = _material_keyword("G")
    _nu: object = _material_keyword("nu")
    _density: object = _material_keyword("density")
    _yield_stress: object = _material_keyword("yield_stress")

    def __attrs_post_init__(self):
        given = {k: getattr(self, f"_{k}") for k in ("E", "G", "nu", "density", "yield_stress")}
        material = resolve(self.kind, self.material, {k: x for k, x in given.items() if x is not UNSET},
                           self.default_material, self.default_shear)
        object.__setattr__(self, "material", material)
        for k in given:
            object.__setattr__(self, f"_{k}", UNSET)

    @staticmethod
    def default_shear(E: float) -> float | None:
        """The shear modulus of a joint given only ``E`` and no material (None: ``G`` or ``nu`` required)."""
        return None

    @property
    def E(self) -> float:
        """Young's modulus of the material."""
        return self.material.E

    @property
    def G(self) -> float:
        """Shear modulus of the material."""
        return self.material.G

    @property
    def nu(self) -> None:
        """None: Poisson's ratio is stored as ``G`` (``joint.material.nu`` reads it)."""
        return None

    @property
    def density(self) -> float:
        """Mass density of the material."""
        return self.material.density

    @property
    def yield_stress(self) -> float | None:
        """Yield stress of the material, or None."""
        return self.material.yield_stress

    def describe(self) -> dict:
        """The shape parameters and the material's numbers as one flat dict (``E``, ``G``,
        ``density``, ``yield_stress``; ``nu`` None), as the joints' separate fields gave it."""
        out = {}
        for a in attrs.fields(type(self)):
            if a.init and not a.name.startswith("_") and a.name != "material":
                value = getattr(self, a.name)
                out[a.name] = attrs.asdict(value) if attrs.has(type(value)) else value
        out.update(E=self.E, G=self.G, nu=None, density=self.density, yield_stress=self.yield_stress)
        return out

