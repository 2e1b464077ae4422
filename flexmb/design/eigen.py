"""Responses of the linearisation about a converged equilibrium: eigenfrequency, buckling
multiplier and compliance entry, with their derivatives.

At a deformed state the tangent depends on the parameters directly and through the state:
``dK/dp = dK/dN N' + dK/du u'`` with ``u' = -K_ff^-1 b`` (the direct method,
`flexmb.design.adjoint.Sensitivity.state_rates`), contracted with the modes element by element
(`Sensitivity.tangent_forms`, `mass_forms`). Eigenvalue derivatives (Fox & Kapoor 1968; Nelson 1976):
``d lam = psi^T (dK - lam dM) phi / psi^T M phi`` with the right and left vectors ``phi``, ``psi``
(``psi = phi`` for a symmetric tangent). **Repeated eigenvalues** (a symmetric flexure's paired
modes): the eigenvalues of a cluster ``lam_1 = ... = lam_c`` (within `CLUSTER` relative) are not
differentiable, but each has directional derivatives: along ``dp`` they are the eigenvalues of
``Psi^T (dK - lam dM) Phi`` over the cluster's modes (Seyranian, Lund & Olhoff 1994; Dailey 1989),
sorted; the k-th eigenvalue's derivative is the one at its rank within the cluster. The gradient
returned is that, per parameter, along the parameter's positive direction: finite, never NaN, and
the exact one-sided derivative of the k-th (sorted) eigenvalue; it is not linear in ``dp`` (use
the cluster's mean, `frequency(..., cluster="mean")`, for a differentiable response).
"""

from __future__ import annotations

import weakref

import attrs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ModelError, ParameterError
from ..linearised import buckling as _buckling
from ..linearised import compliance as _compliance
from ..modal import held_dofs, modes
from ..rotations import cross, skew
from .base import component_index

__all__ = ["frequency", "buckling", "compliance", "CLUSTER"]

#: Eigenvalues within this relative distance are one cluster (a repeated eigenvalue): above the
#: eigensolvers' relative accuracy at the lowest modes (~1e-10, `flexmb.modal`), far below the
#: splitting of modes that are merely close.
CLUSTER = 1e-7

_MODES = weakref.WeakKeyDictionary()  # solution -> {(k, held): (Modes, cluster)}


def _cluster(values: np.ndarray, k: int) -> np.ndarray:
    """Indices (0-based) of the eigenvalues of ``values`` (sorted) clustered with the k-th (1-based)."""
    ref = values[k - 1]
    tol = CLUSTER * max(abs(ref), 1e-300)
    return np.flatnonzero(np.abs(values - ref) <= tol)


def _dense_or_sparse(A):
    return A.toarray() if hasattr(A, "toarray") else np.asarray(A)


def _left_vectors(A, B, Phi: np.ndarray, lam: float) -> np.ndarray:
    """Left vectors of ``(A - lam B) psi = 0`` for the cluster's right vectors ``Phi`` (n, c): two
    steps of inverse iteration with ``(A - s B)^T``, ``s`` next to ``lam`` (the cluster's left
    invariant subspace to ~(1e-8 lam / gap)^2)."""
    s = lam + 1e-8 * max(abs(lam), 1e-300) if lam != 0 else 1e-12
    lu = spla.splu(sp.csc_array(A - s * B))
    Psi = B.T @ Phi
    for _ in range(2):
        Psi = lu.solve(Psi, trans="T")
        Psi = Psi / np.linalg.norm(Psi, axis=0)
    return Psi


def _cluster_derivatives(forms_A, forms_B, Phi, Psi, normal, lam) -> np.ndarray:
    """(K, c) derivatives of a cluster's eigenvalues per parameter, sorted ascending: eigenvalues of
    ``N^-1 Psi^T (dA - lam dB) Phi`` with ``N = Psi^T normal Phi`` (forms: (K, c, c))."""
    Nm = Psi.T @ normal
    if Nm.shape == (1, 1):  # a simple eigenvalue: the quotients at once
        return ((forms_A - lam * forms_B)[:, 0, 0] / Nm[0, 0]).real.reshape(len(forms_A), 1)
    out = []
    for dA, dB in zip(forms_A, forms_B):
        G = np.linalg.solve(Nm, dA - lam * dB)
        if G.shape[0] == 1:
            out.append(G[0].real)
            continue
        mu = np.linalg.eigvals(G)
        out.append(np.sort(mu.real))
    return np.array(out).reshape(len(forms_A), -1)


def _mass_times(sens, X: np.ndarray) -> np.ndarray:
    """``M X`` (n_dofs, c) with the consistent mass at the configuration (`flexmb.fe.mass.mass_matrix`)
    from its element and rigid-body blocks (the local mass kept with the model numbers: nothing of
    the model's size assembled)."""
    from ..fe.mass import element_mass, rigid_mass

    model = sens.model
    out = np.zeros_like(X)
    parts = [(model.element_dofs, element_mass(model, sens.state, sens.rates.compiled_numbers("local_mass")))]
    rigid = model.rigid_masses
    if rigid is not None and len(rigid.node):
        parts.append((model.node_dofs[rigid.node], rigid_mass(model, sens.state, rigid)))
    for dofs, blocks in parts:
        np.add.at(out, dofs, np.einsum("eij,ejc->eic", blocks, X[dofs]))
    return out


@attrs.frozen
class _Frequency:
    k: int
    held: object = "prescribed"
    cluster: str = "rank"

    def __attrs_post_init__(self):
        if isinstance(self.k, bool) or not isinstance(self.k, (int, np.integer)) or self.k < 1:
            raise ParameterError(f"frequency: k={self.k!r} must be an integer >= 1")
        if self.cluster not in ("rank", "mean"):
            raise ParameterError(f"frequency: cluster={self.cluster!r}; valid: 'rank', 'mean'")

    @property
    def name(self) -> str:
        return f"frequency({self.k})"

    def value(self, solution) -> float:
        m = self._modes(solution)[0]
        idx = _cluster(m.eigenvalues, self.k) if self.cluster == "mean" else [self.k - 1]
        lam = float(np.mean(m.eigenvalues[idx]))
        return float(np.sign(lam) * np.sqrt(abs(lam)) / (2 * np.pi))

    def _modes(self, solution):
        """`flexmb.modes` with enough modes to hold the k-th's whole cluster, and the cluster's indices
        (kept per solution: `value` and `gradient` read the same)."""
        key = (self.k, repr(self.held))
        per = _MODES.setdefault(solution, {})
        if key not in per:
            per[key] = self._solve_modes(solution)
        return per[key]

    def _solve_modes(self, solution):
        nf = solution.compiled.problem.model.n_dofs - len(held_dofs(solution, self.held, "frequency"))
        n = min(self.k + 2, nf)
        while True:
            m = modes(solution, n_modes=n, held=self.held)
            idx = _cluster(m.eigenvalues, self.k)
            if idx[-1] < n - 1 or n == nf:
                return m, idx
            n = min(2 * n, nf)

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        m, idx = self._modes(sens.solution)
        lam = float(np.mean(m.eigenvalues[idx]))
        model = sens.model
        Phi = np.zeros((model.n_dofs, len(idx)))
        Phi[: model.n_node_dofs] = m.shapes[idx].reshape(len(idx), -1).T
        Psi = self._left(sens, m, Phi, lam)
        d = _cluster_derivatives(sens.tangent_forms(Psi, Phi), sens.mass_forms(Psi, Phi), Phi, Psi,
                                 _mass_times(sens, Phi), lam)
        dlam = d.mean(axis=1) if self.cluster == "mean" else d[:, self.k - 1 - idx[0]]
        return dlam / (4 * np.pi * np.sqrt(abs(lam)))

    def _left(self, sens, m, Phi, lam):
        """The cluster's left vectors: ``Phi`` itself for a symmetric problem, else by inverse
        iteration on the solution's linearisation (`flexmb.Solution.linearisation`, ``K`` and ``M``)."""
        if m.symmetric:
            return Phi
        lin = sens.solution.linearisation(self.held, owner="frequency")
        Psi = np.zeros_like(Phi)
        Psi[lin.free] = _left_vectors(sp.csc_array(lin.K), sp.csc_array(lin.M), Phi[lin.free], lam)
        return Psi


def frequency(k: int, held="prescribed", cluster: str = "rank"):
    """The ``k``-th natural frequency [Hz] (1-based, ascending) of the linearised free vibration
    (`flexmb.modes` with ``held``). At a repeated eigenvalue the derivative is the one-sided
    directional derivative of the k-th frequency per parameter (module notes); ``cluster="mean"``:
    the mean of the k-th frequency's cluster's eigenvalues instead, a differentiable response."""
    return _Frequency(k, held, cluster)


def _inverse_iteration(A, B, shift: float, c: int, seed: int = 0, transpose: bool = False) -> np.ndarray:
    """``c`` vectors of the pencil ``A phi = -mu B phi`` nearest ``mu = shift`` (right, or left with
    ``transpose``): block inverse iteration with ``(A + shift B)^-1 B`` (each step multiplies the
    wanted part by ~1e8 over the rest), orthonormalised."""
    Ash = (A + shift * B).tocsc()
    lu = spla.splu(Ash)
    X = np.random.default_rng(seed).standard_normal((A.shape[0], c))
    Bt = B.T.tocsr() if transpose else B
    for _ in range(4):
        X = lu.solve(Bt @ X, trans="T" if transpose else "N")
        X, _ = np.linalg.qr(X)
    return X


@attrs.frozen
class _Buckling:
    k: int
    held: object = "prescribed"

    def __attrs_post_init__(self):
        if isinstance(self.k, bool) or not isinstance(self.k, (int, np.integer)) or self.k < 1:
            raise ParameterError(f"buckling: k={self.k!r} must be an integer >= 1")

    @property
    def name(self) -> str:
        return f"buckling({self.k})"

    def value(self, solution) -> float:
        return float(_buckling(solution, n_buckling=self.k, held=self.held)[self.k - 1])

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        sol = sens.solution
        lin = sol.linearisation(self.held, owner="buckling")  # K_t and K_m on the free DOFs
        free = lin.free
        n = min(self.k + 2, len(free))
        mu = _buckling(sol, n_buckling=n, held=self.held)
        if not np.isfinite(mu[self.k - 1]):
            raise ModelError(f"buckling({self.k}): no {self.k}-th positive multiplier (inf): no derivative")
        idx = _cluster(mu, self.k)
        lam = float(np.mean(mu[idx]))
        Kt, Km = sp.csc_array(lin.K), sp.csc_array(lin.material_tangent())
        Ks = (Kt - Km).tocsc()
        shift = lam * (1.0 + 1e-8)
        Phi = np.zeros((sens.model.n_dofs, len(idx)))
        Psi = np.zeros_like(Phi)
        Phi[free] = _inverse_iteration(Km, Ks, shift, len(idx))
        Psi[free] = _inverse_iteration(Km, Ks, shift, len(idx), transpose=True)
        dKt, dKm = sens.tangent_forms(Psi, Phi), sens.tangent_forms(Psi, Phi, material=True)
        normal = np.zeros_like(Phi)
        normal[free] = -(Ks @ Phi[free])
        d = _cluster_derivatives((1.0 - lam) * dKm + lam * dKt, np.zeros_like(dKt), Phi, Psi, normal, 0.0)
        return d[:, self.k - 1 - idx[0]]


def buckling(k: int = 1, held="prescribed"):
    """The ``k``-th lowest positive buckling multiplier [-] of the solution's loads and prescribed
    motions (`flexmb.buckling` with ``held``, without ``base``): ``(K_m + mu K_s) phi = 0``.
    Its derivative: ``d mu = -psi^T (dK_m + mu dK_s) phi / psi^T K_s phi`` with both tangents'
    total changes (the state's included); repeated multipliers as the module notes say."""
    return _Buckling(k, held)


@attrs.frozen
class _Compliance:
    link: str
    row: str
    column: str
    point: object = None
    axes: str = "global"
    held: object = "prescribed"

    @property
    def name(self) -> str:
        return f"compliance({self.link}, {self.row}, {self.column})"

    def value(self, solution) -> float:
        dim = solution.compiled.problem.model.dim
        i, j = (component_index(dim, c, "compliance") for c in (self.row, self.column))
        return float(_compliance(solution, self.link, self.point, self.axes, self.held)[i, j])

    def _offset(self, sens):
        """The point's undeformed offset from the link's node and its rate per parameter (K, dim)."""
        comp, model = sens.solution.compiled, sens.model
        node = comp.link_node[self.link]
        K = len(sens.names)
        if self.point is None:
            return np.zeros(model.dim), np.zeros((K, model.dim))
        if isinstance(self.point, str):
            names = list(comp.points)
            if self.point not in names or comp.points[self.point][0] != self.link:
                raise ModelError(f"compliance: link {self.link!r} has no point named {self.point!r}")
            return np.asarray(comp.points[self.point][1]), sens.rates.rate("points")[:, names.index(self.point)]
        return np.asarray(self.point, dtype=float) - model.x0[node], -sens.rates.rate("x0")[:, node]

    def gradient(self, sens, method: str = "auto") -> np.ndarray:
        sol, model = sens.solution, sens.model
        dim, nd = model.dim, model.ndof
        if self.link not in sol.compiled.link_node:
            raise ModelError(f"compliance: no link named {self.link!r}")
        i, j = (component_index(dim, c, "compliance") for c in (self.row, self.column))
        node = sol.compiled.link_node[self.link]
        dofs = model.node_dofs[node]
        held = held_dofs(sol, self.held, "compliance") if not (isinstance(self.held, str) and
                                                                self.held == "prescribed") else sens.prescribed
        free = np.setdiff1d(np.arange(model.n_dofs), held)
        E = np.zeros((model.n_dofs, nd))
        E[dofs, np.arange(nd)] = 1.0
        X, Y = np.zeros((model.n_dofs, nd)), np.zeros((model.n_dofs, nd))  # K^-1 E and K^-T E
        if held is sens.prescribed:
            X[free], Y[free] = sens.solve(E[free]), sens.solve(E[free], transpose=True)
        else:  # the solution's linearisation with these DOFs held (`flexmb.Solution.linearisation`)
            lin = sol.linearisation(self.held, owner="compliance")
            free = lin.free
            X[free], Y[free] = lin.solve(E[free]), lin.solve(E[free], transpose=True)
        for Z in (X, Y):
            Z[:, np.isin(dofs, held)] = 0.0  # held components of the node: zero rows and columns
        C_node = E.T @ X  # (nd, nd) = E^T K^-1 E on the free components
        dC_node = -sens.tangent_forms(Y, X)  # -E^T K^-1 dK K^-1 E = -Y^T dK X (K not symmetric), (K, nd, nd)
        s, ds = self._offset(sens)
        R = model.rotation_matrices(sens.state)[node]
        d = R @ s
        w = sens.state_rates[dofs[dim:]].T  # (K, nrot): the node's spin (2D: angle) per parameter
        dd = (cross(w, d) if dim == 3 else w * np.array([-d[1], d[0]])) + ds @ R.T
        T, dT = model._lever(d[None])[0], model._lever(dd) - np.eye(nd)  # the lever is affine in the offset
        C = T @ C_node @ T.T
        dC = dT @ C_node @ T.T + T @ dC_node @ T.T + T @ C_node @ np.swapaxes(dT, 1, 2)
        if self.axes == "link":
            B = np.eye(nd)
            B[:dim, :dim] = R
            if dim == 3:
                B[3:, 3:] = R
            dB = np.zeros((len(w), nd, nd))
            for k, wk in enumerate(w):
                dR = (np.array([[0.0, -1.0], [1.0, 0.0]]) * wk[0]) @ R if dim == 2 else skew(wk) @ R
                dB[k, :dim, :dim] = dR
                if dim == 3:
                    dB[k, 3:, 3:] = dR
            dC = np.swapaxes(dB, 1, 2) @ C @ B + B.T @ dC @ B + B.T @ C @ dB
        elif self.axes != "global":
            raise ParameterError(f"compliance: axes={self.axes!r}; valid: 'global', 'link'")
        return dC[:, i, j]


def compliance(link: str, row: str, column: str, point=None, axes: str = "global", held="prescribed"):
    """Entry (``row``, ``column``) of the compliance of ``link``'s point (`flexmb.compliance`:
    displacement per unit load at the point, ``held`` DOFs held, dead loads; ``point``, ``axes`` as
    there). Its derivative: ``dC = -T X^T dK X T^T`` (``X = K_ff^-1 E``) with the lever's and, for
    ``axes="link"``, the link axes' turn with the state; a support stiffness is ``1 / C_ii``."""
    return _Compliance(link, row, column, point, axes, held)
