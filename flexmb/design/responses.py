"""Differentiable responses of a converged equilibrium: each owns its value and its derivative.

A response is an object with ``name``, ``value(solution) -> float`` and
``gradient(sensitivity, method) -> (K,)`` (`flexmb.design.adjoint.Sensitivity`). Responses that
are functions of the state and the model numbers, ``J(u, N)``, give their partials ``dJ/du`` and
``dJ/dN N'`` and let the sensitivity choose adjoint or direct; the eigen- and compliance
responses (`flexmb.design.eigen`) use the state's rates and the tangent's directional derivative.

Components: ``"x"``, ``"y"``, ``"z"`` (translations, global axes) and ``"rx"``, ``"ry"``, ``"rz"``
(3D rotations about global axes) or ``"rotation"`` (2D).
"""

from __future__ import annotations

import attrs
import numpy as np

from ..errors import ModelError, ParameterError
from ..rotations import cross
from .adjoint import left_jacobian
from .base import Response, component_index
from .eigen import buckling, compliance, frequency
from .stress import stress

__all__ = ["reaction", "displacement", "position", "rotation", "mass", "frequency", "buckling", "compliance", "stress",
           "Response", "component_index"]

def _node(solution, link: str, owner: str) -> int:
    nodes = solution.compiled.link_node
    if link not in nodes:
        raise ModelError(f"{owner}: no link named {link!r}; links: {', '.join(nodes)}")
    return nodes[link]


def _point_index(solution, link: str, point, owner: str):
    """The row of named ``point`` of ``link`` in the compiled points (None for the link's reference)."""
    if point is None:
        return None
    names = list(solution.compiled.points)
    if point not in names:
        raise ModelError(f"{owner}: no point named {point!r}; points: {', '.join(names) or 'none'}")
    if solution.compiled.points[point][0] != link:
        raise ModelError(f"{owner}: point {point!r} belongs to link {solution.compiled.points[point][0]!r}, "
                         f"not {link!r}")
    return names.index(point)


@attrs.frozen
class _Reaction(Response):
    link: str
    component: str

    @property
    def name(self) -> str:
        return f"reaction({self.link}, {self.component})"

    def _dof(self, solution) -> int:
        model = solution.compiled.problem.model
        dof = int(model.node_dofs[_node(solution, self.link, "reaction")][component_index(model.dim, self.component,
                                                                                         "reaction")])
        if dof not in set(solution.compiled.problem.prescribed.tolist()):
            raise ModelError(f"reaction: {self.link!r} {self.component!r} is a free DOF (its reaction is the residual, "
                             "~0); a reaction is defined at a fixed or prescribed DOF")
        return dof

    def value(self, solution) -> float:
        return float(solution.residual[self._dof(solution)])

    def partials(self, sens):
        dof = self._dof(sens.solution)
        return sens.row(dof), sens.residual_rates[dof]


def reaction(link: str, component: str) -> Response:
    """The reaction [N or N m] at a fixed or prescribed DOF of ``link`` (`flexmb.Solution.reaction`):
    the force or moment that holds it, e.g. the actuation moment of a prescribed rotation;
    ``component`` as in the module notes. Its derivative includes the reaction's direct
    dependence on the model (``dr_p/dN``) and the free state's and prescribed DOFs' motion."""
    return _Reaction(link, component)


@attrs.frozen
class _Position(Response):
    link: str
    component: str
    point: str | None = None
    relative: bool = True  # displacement (minus the undeformed position) or position

    @property
    def name(self) -> str:
        kind = "displacement" if self.relative else "position"
        return f"{kind}({self.link}{'' if self.point is None else '.' + self.point}, {self.component})"

    def _where(self, solution):
        model = solution.compiled.problem.model
        owner = "displacement" if self.relative else "position"
        c = component_index(model.dim, self.component, owner)
        if c >= model.dim:
            raise ParameterError(f"{owner}: component={self.component!r} is a rotation; use flexmb.responses.rotation")
        return model, _node(solution, self.link, owner), c, _point_index(solution, self.link, self.point, owner)

    def _offset(self, solution, row):
        model = solution.compiled.problem.model
        return np.zeros(model.dim) if row is None else np.asarray(list(solution.compiled.points.values())[row][1])

    def value(self, solution) -> float:
        model, n, c, row = self._where(solution)
        s = self._offset(solution, row)
        R = model.rotation_matrices(solution.state)[n]
        x = solution.state.positions[n] + R @ s
        return float(x[c] - (model.x0[n, c] + s[c] if self.relative else 0.0))

    def partials(self, sens):
        model, n, c, row = self._where(sens.solution)
        s = self._offset(sens.solution, row)
        R = model.rotation_matrices(sens.state)[n]
        dJ_du = np.zeros(model.n_dofs)
        dofs = model.node_dofs[n]
        dJ_du[dofs[c]] = 1.0
        d = R @ s  # the point's current offset: d(R s) = dphi x (R s)
        if model.dim == 2:
            dJ_du[dofs[2]] = -d[1] if c == 0 else d[0]
        else:
            dJ_du[dofs[3:]] = -cross(np.eye(3)[c], d)  # e_c . (dphi x d) = dphi . (d x e_c)
        K = len(sens.names)
        dJ_dN = np.zeros(K)
        if row is not None:
            dJ_dN += sens.rates.rate("points")[:, row] @ (R[c] - (np.eye(model.dim)[c] if self.relative else 0.0))
        if self.relative:
            dJ_dN -= sens.rates.rate("x0")[:, n, c]
        return dJ_du, dJ_dN


def displacement(link: str, component: str, point: str | None = None) -> Response:
    """The displacement [m] of ``link``'s reference point (or named ``point``, `Mechanism.add_point`)
    along a global axis: current minus undeformed position."""
    return _Position(link, component, point, True)


def position(link: str, component: str, point: str | None = None) -> Response:
    """The current position [m] of ``link``'s reference point (or named ``point``) along a global axis."""
    return _Position(link, component, point, False)


@attrs.frozen
class _Rotation(Response):
    link: str
    component: str

    @property
    def name(self) -> str:
        return f"rotation({self.link}, {self.component})"

    def _where(self, solution):
        model = solution.compiled.problem.model
        c = component_index(model.dim, self.component, "rotation")
        if c < model.dim:
            raise ParameterError(f"rotation: component={self.component!r} is a translation; use "
                                 "flexmb.responses.displacement")
        return model, _node(solution, self.link, "rotation"), c

    def value(self, solution) -> float:
        model, _, c = self._where(solution)
        return float(solution.rotation_vector(self.link)[c - model.dim])

    def partials(self, sens):
        model, n, c = self._where(sens.solution)
        dJ_du = np.zeros(model.n_dofs)
        dofs = model.node_dofs[n][model.dim:]
        if model.dim == 2:
            dJ_du[dofs[0]] = 1.0
        else:  # w = log(R): dw = J_l(w)^-1 dphi
            w = sens.solution.rotation_vector(self.link)
            dJ_du[dofs] = np.linalg.inv(left_jacobian(w))[c - 3]
        return dJ_du, np.zeros(len(sens.names))


def rotation(link: str, component: str) -> Response:
    """The rotation of ``link`` [rad] since the undeformed state: the angle in 2D (``"rotation"``),
    a component of the rotation vector ``log(R)`` in 3D (``"rx"``, ``"ry"``, ``"rz"``)."""
    return _Rotation(link, component)


@attrs.frozen
class _Mass(Response):
    name = "mass"

    def value(self, solution) -> float:
        from .parameters import model_numbers

        m = model_numbers(solution.compiled, "rigid_mass")
        return float(np.sum(model_numbers(solution.compiled, "rho_A") * solution.compiled.problem.model.elements.L0)
                     + np.sum(m))

    def partials(self, sens):
        from .parameters import model_numbers

        c, r = sens.solution.compiled, sens.rates
        dm = r.rate("rigid_mass")
        dJ_dN = r.rate("rho_A") @ c.problem.model.elements.L0 + r.rate("L0") @ model_numbers(c, "rho_A")
        if dm.size:
            dJ_dN = dJ_dN + dm.sum(axis=1)
        return np.zeros(sens.model.n_dofs), dJ_dN


def mass() -> Response:
    """The mechanism's mass [kg]: the beams' ``density A L0`` and the links' rigid masses (connector
    blocks inside joints are rigid and massless in the model)."""
    return _Mass()
