"""A converged equilibrium linearised on its free coordinates: `flexmb.Solution.linearisation`.

Every property of a configuration that a linearisation gives (`flexmb.modes`, `flexmb.buckling`,
`flexmb.compliance`, the design gradients) reads one `flexmb.protocols.Linearisation`: the
tangent ``K`` and mass ``M`` on the free coordinates, the map back to the mechanism's DOFs and a
solve with one kept factorisation. A solution kind supplies its own through
``Solution.linearisation`` (KSD-reduced's: `flexmb.ksd.reduced_model.ReducedLinearisation`); the
full finite-element model's is `FELinearisation`, here.

The full model's linearisation (SPACAR's convention):

* **Stiffness.** The full tangent at the solution (`full_tangent`): the beams' material and
  geometric parts, the hinges' saddle-point blocks and the dead loads' load stiffness. Loads are
  *dead*: the applied loads, and the reactions of any prescribed DOF that ``held`` releases, keep
  their size and global direction. In 3D the rotation DOFs are spins (``dR = skew(dphi) R``).
* **Mass.** The consistent mass (`flexmb.fe.mass`) at the deformed configuration.
* **Held DOFs** (`held_dofs`). ``held="prescribed"`` (default) holds the fixed links and every
  prescribed DOF; ``"fixed"`` holds only the fixed links (``"none"`` before flexmb 0.2: a deprecated alias);
  ``"floating"`` holds nothing; a sequence
  of link names (all their DOFs) and ``(link, component)`` pairs holds the fixed links and those
  components (``"x"``, ``"y"``, ``"z"``, ``"rx"``, ``"ry"``, ``"rz"``, ``"rotation"``).
* **Hinges.** The coordinates are the motions the hinges allow: ``u[free] = Z q``
  (`flexmb.fe.ideal.constrained`), the multipliers out.
"""

from __future__ import annotations

import warnings
import weakref

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ._warnings import deprecated
from .errors import ConvergenceError, ModelError, ParameterError, UnsupportedStrategyError
from .fe.assembly import SparsePattern
from .fe.ideal import constrained
from .fe.mass import mass_matrix

__all__ = ["LinearisationBase", "FELinearisation", "DenseFactor", "linearise", "full_tangent", "material_tangent", "stiffness_and_mass",
           "held_dofs", "held_and_free", "held_option", "HELD_RENAMED", "solvable_problem", "converged_problem", "RESIDUAL_MAX", "SPARSE_FROM"]

_EPS = float(np.finfo(float).eps)

#: The largest relative residual ``|K x - b| / |b|`` of a sparse solve. The sparse solvers'
#: backward-error test (`flexmb.linear`) cannot see a singular ``K``: the manipulator (Sec. 4.4,
#: 20 deg) with nothing held (``held="floating"``, a free rigid-body motion) passed it at 1e-16
#: with a relative residual of 23; its ill-conditioned but regular ``held="fixed"`` leaves 5e-8.
RESIDUAL_MAX = 1e-4
#: Coordinates from which `FELinearisation.solve` factorises sparse (below: dense LAPACK, whose
#: reciprocal condition number tells a singular tangent)
SPARSE_FROM = 220

_COMPONENTS = {2: {"x": (0,), "y": (1,), "rotation": (2,)},
               3: {"x": (0,), "y": (1,), "z": (2,), "rx": (3,), "ry": (4,), "rz": (5,), "rotation": (3, 4, 5)}}


def linearise(solution, held="prescribed", *, modal: bool = False, owner: str = "linearisation"):
    """``solution.linearisation(held, modal=, owner=)``, or `ParameterError` for anything but a
    solution (messages name the property ``owner``)."""
    if not callable(getattr(solution, "linearisation", None)) or not hasattr(solution, "compiled"):
        raise ParameterError(f"linearisation needs a Solution (flexmb.solve, sweep or trace), got "
                             f"{type(solution).__name__}: solve the mechanism first")
    return solution.linearisation(held, modal=modal, owner=owner)


def converged_problem(solution, owner: str = "modes"):
    """The problem of a converged solution (`ConvergenceError` if not converged)."""
    if not solution.converged:
        raise ConvergenceError(f"{owner} of an unconverged solution ({solution.message}): linearise about an "
                               "equilibrium", solution)
    return solution.compiled.problem


def solvable_problem(solution, owner: str = "modes"):
    """The solution's `StaticProblem`, if the solution is a converged full FE equilibrium
    (`UnsupportedStrategyError` for a solution that is not the full model's equilibrium, e.g.
    KSD-reduced's, or has no beam elements; `ConvergenceError` for an unconverged one)."""
    if not hasattr(solution, "compiled") or not hasattr(solution, "method"):
        raise ParameterError(f"linearisation needs a Solution (flexmb.solve, sweep or trace), got "
                             f"{type(solution).__name__}: solve the mechanism first")
    if not getattr(solution, "full_equilibrium", True):
        raise UnsupportedStrategyError(f"{owner}: the full FE equilibrium is needed: solve with method='ksd-full' or "
                                       f"'conventional' ({solution.full_equilibrium_note})")
    problem = solution.compiled.problem
    if not hasattr(problem.model, "elements"):
        raise UnsupportedStrategyError(
            f"{owner} need beam elements: this solution comes from method {solution.method!r}, whose closed-form "
            "model has none; solve with method='conventional'")
    return converged_problem(solution, owner)


def _full_pattern(model, loads):
    ed = model.element_dofs
    lr = model.node_dofs[loads.node][:, model.dim:]
    blocks = (ed, lr) if model.hinges is None else (ed, lr, model.hinge_dofs)
    rows = np.concatenate([np.broadcast_to(a[:, :, None], a.shape + a.shape[1:]).ravel() for a in blocks])
    cols = np.concatenate([np.broadcast_to(a[:, None, :], a.shape + a.shape[1:]).ravel() for a in blocks])
    return SparsePattern(rows, cols, (model.n_dofs, model.n_dofs))


def full_tangent(solution, element_tangent=None, with_loads: bool = True) -> sp.csr_array:
    """The tangent on *all* DOFs (n_dofs, n_dofs) at a converged FE solution: the elements' (or
    ``element_tangent``, (E, 2 ndof, 2 ndof) in master DOFs), the hinges' saddle-point blocks
    (without their constraint forces' part when ``element_tangent`` is given: the material tangent)
    and, ``with_loads``, the dead loads' stiffness at the solution's load factor."""
    problem = solvable_problem(solution)
    model, state = problem.model, solution.state
    Ke = model.element_response(state, tangent=True)[1] if element_tangent is None else element_tangent
    _, G = problem.external_force(state, solution.load_factor)
    G = -G if with_loads else np.zeros_like(G)
    vals = [Ke.ravel(), G.ravel()]
    if model.hinges is not None:
        vals.append(model.hinge_response(state, problem.motor_fraction(solution.load_factor),
                                         material=element_tangent is not None)[1].ravel())
    return _full_pattern(model, problem.loads).matrix(np.concatenate(vals))


def material_tangent(solution):
    """The material part ``K_m`` (N ndof, N ndof) of the tangent at the solution: the beams'
    ``T^T D^T S D T`` without their stresses' geometric part, the rigid offsets' ``d(d x f)/dphi``
    and the loads' stiffness (`FEModel.element_response`, `FEModel.transfer`)."""
    problem = solvable_problem(solution)
    model, state = problem.model, solution.state
    Fm, Ke, _, _ = model.element_response(state, tangent=True, geometric_stress=np.zeros_like)
    # element_response adds the offsets' block d f^T - (d.f) I (2D: -(d.f)) at each end's rotation
    # DOFs, from the point forces f (the translational part of Fm): take it off again
    el, dim, nd = model.elements, model.dim, model.ndof
    m = model.point_master[el.ends].ravel()
    d = model.offsets(state, m, model.point_offset[el.ends].reshape(-1, dim))
    _, G = model.transfer(Fm.reshape(-1, nd), d)
    G = G.reshape(len(el.L0), 2, nd - dim, nd - dim)
    Ke = Ke.copy()
    Ke[:, dim:nd, dim:nd] -= G[:, 0]
    Ke[:, nd + dim:, nd + dim:] -= G[:, 1]
    return full_tangent(solution, element_tangent=Ke, with_loads=False)


def stiffness_and_mass(solution) -> tuple[sp.csr_array, sp.csr_array]:
    """Tangent stiffness (`full_tangent`) and mass on *all* DOFs (N ndof, N ndof) at a converged
    FE solution (see the module notes: dead loads, mass at the deformed state)."""
    model = solvable_problem(solution).model
    return full_tangent(solution), mass_matrix(model, solution.state, model.rigid_masses)


#: Deprecated ``held`` names -> their names now (a FutureWarning each use; removed in the next release).
HELD_RENAMED = {"none": "fixed"}


def held_option(held, owner: str = "modes"):
    """``held`` with a deprecated name (`HELD_RENAMED`) replaced by its new one, with a
    ``FutureWarning`` naming both; anything else unchanged (`held_dofs` checks it)."""
    if isinstance(held, str) and held in HELD_RENAMED:
        deprecated(f"{owner}(held={held!r})", f"held={HELD_RENAMED[held]!r}", ": the fixed links held, nothing else")
        return HELD_RENAMED[held]
    return held


def held_dofs(solution, held, owner: str = "modes") -> np.ndarray:
    """Sorted global DOF indices that ``held`` (module notes) holds; errors name ``owner``."""
    held = held_option(held, owner)
    compiled = solution.compiled
    problem, model = compiled.problem, compiled.problem.model
    if isinstance(held, str) and held in ("prescribed", "floating"):  # the fixed links' DOFs not needed
        return np.unique(problem.prescribed) if held == "prescribed" else np.zeros(0, dtype=np.int64)
    fixed = [compiled.link_node[name] for name in compiled.fixed]
    ground = model.node_dofs[fixed].ravel() if fixed else np.zeros(0, dtype=np.int64)
    if isinstance(held, str):
        if held == "fixed":
            return np.unique(ground)
        raise ParameterError(f"{owner}: held={held!r}; valid: 'prescribed', 'fixed', 'floating' or a sequence of "
                             "links and (link, component) pairs")
    try:
        items = list(held)
    except TypeError:
        raise ParameterError(f"{owner}: held={held!r} is not a string or a sequence") from None
    out = [ground] + [_held_item(compiled, model, item, owner) for item in items]
    return np.unique(np.concatenate(out).astype(np.int64))


def _held_item(compiled, model, item, owner: str) -> np.ndarray:
    """The DOFs one item of a ``held`` sequence names: a link, or a (link, component) pair."""
    if isinstance(item, str):
        link, which = item, None
    elif isinstance(item, (tuple, list)) and len(item) == 2:
        link, which = item
    else:
        raise ParameterError(f"{owner}: held item {item!r} is neither a link name nor a (link, component) pair")
    if not isinstance(link, str) or link not in compiled.link_node:
        raise ModelError(f"{owner}: held names no link {link!r}; links: {', '.join(compiled.link_node)}")
    dofs = model.node_dofs[compiled.link_node[link]]
    comps = _COMPONENTS[model.dim]
    if which is None:
        return dofs
    if which in comps:
        return dofs[list(comps[which])]
    raise ParameterError(f"{owner}: held component {which!r} of link {link!r}; valid: {', '.join(comps)}")


_HELD = weakref.WeakKeyDictionary()


def held_and_free(solution, held, owner: str = "modes"):
    """`held_dofs` and the free DOFs (sorted, read-only), kept per compiled mechanism for the named
    ``held`` ("prescribed", "fixed", "floating": a visible share of a KSD-reduced ``modes`` otherwise)."""
    held = held_option(held, owner)
    compiled = solution.compiled
    key = held if isinstance(held, str) else None
    per = _HELD.setdefault(compiled, {})
    if key is None or key not in per:
        held_idx = held_dofs(solution, held, owner)
        keep = np.ones(compiled.problem.model.n_dofs, dtype=bool)
        keep[held_idx] = False
        out = held_idx, np.flatnonzero(keep)  # not np.setdiff1d, whose sort was a visible share
        if key is None:
            return out
        for a in out:
            a.flags.writeable = False
        per[key] = out
    return per[key]


class DenseFactor:
    """A dense ``K`` factorised once for any number of solves with ``K`` or ``K^T``.

    The factorisation `scipy.linalg.solve` chooses, called through LAPACK directly: for a
    non-symmetric ``K`` the LU, for an exactly symmetric one Cholesky or, indefinite,
    Bunch-Kaufman (upper triangle), as scipy tries them. The first solve with ``K`` is LAPACK's
    driver (``dgesv``, ``dposv``; ``dsytrf`` + ``dsytrs``), bit for bit `scipy.linalg.solve`'s
    answer without its structure detection and checks per call (a third of
    the KSD-reduced manipulator's ``compliance``); it keeps the factors, and every later solve (or a
    first with ``K^T``) runs LAPACK's triangular solves (``dgetrs`` ...) on them: the same
    factorisation, whose OpenBLAS solve kernels may round the last bit differently from the
    driver's. Raises ``LinAlgError`` for an exactly singular ``K`` and, where the reciprocal
    condition number is below eps, warns `scipy.linalg.LinAlgWarning` as scipy does
    (``ill_conditioned="raise"``: raises it). Non-finite input: ``ValueError`` (scipy's)."""

    def __init__(self, K: np.ndarray, ill_conditioned: str = "warn"):
        self.K = np.asarray(K, dtype=float)
        if not np.isfinite(self.K).all():
            raise ValueError("array must not contain infs or NaNs")
        self.ill_conditioned = ill_conditioned
        self.symmetric = bool(np.array_equal(self.K, self.K.T))
        self.kind = None  # "lu", "cholesky" or "ldl" once factorised
        self.rcond = np.nan

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``x`` with ``K x = b`` (``K^T x = b`` when ``transpose``), ``b`` (n,) or (n, k)."""
        b = np.asarray(b, dtype=float)
        if not np.isfinite(b).all():
            raise ValueError("array must not contain infs or NaNs")
        lapack = sla.lapack
        if self.kind is None:
            x = self._factorise(b, transpose and not self.symmetric)
            if x is not None:
                return x
        if self.kind == "lu":
            x, info = lapack.dgetrs(self.lu, self.piv, b, trans=1 if transpose else 0)
        elif self.kind == "cholesky":
            x, info = lapack.dpotrs(self.lu, b, lower=0)
        else:
            x, info = lapack.dsytrs(self.lu, self.piv, b, lower=0)
        if info != 0:
            raise ValueError(f"LAPACK solve: illegal value in argument {-info}")
        return x

    def _factorise(self, b, transpose: bool):
        """Factorise ``K`` (and check its condition); the solution of ``K x = b`` where the driver
        gave it, else None (the kept factors solve)."""
        K, lapack, x = self.K, sla.lapack, None
        anorm = np.abs(K).sum(axis=0).max() if len(K) else 0.0
        if not self.symmetric:
            if transpose:
                self.lu, self.piv, info = lapack.dgetrf(K)
            else:
                self.lu, self.piv, x, info = lapack.dgesv(K, b)
            if info > 0:
                raise np.linalg.LinAlgError("A singular matrix detected: slice(s) [0] are singular.")
            self.kind, rcond = "lu", lapack.dgecon(self.lu, anorm)[0]
        else:
            self.lu, x, info = lapack.dposv(K, b, lower=0)
            if info == 0:
                self.kind, rcond = "cholesky", lapack.dpocon(self.lu, anorm)[0]
            else:  # not positive definite: Bunch-Kaufman, as scipy then
                lwork = int(lapack.dsytrf_lwork(len(K), lower=0)[0])
                self.lu, self.piv, info = lapack.dsytrf(K, lower=0, lwork=max(lwork, 1))
                if info > 0:
                    raise np.linalg.LinAlgError("A singular matrix detected: slice(s) [0] are singular.")
                self.kind, rcond, x = "ldl", lapack.dsycon(self.lu, self.piv, anorm, lower=0)[0], None
        self.rcond = float(rcond)
        if len(K) and self.rcond < _EPS:
            message = f"An ill-conditioned matrix detected: slice 0 has rcond = {rcond}."
            if self.ill_conditioned == "raise":
                self.kind = None  # every solve raises again
                raise sla.LinAlgWarning(message)
            warnings.warn(message, sla.LinAlgWarning, stacklevel=4)
        return x


def _consistent(K, X, rhs) -> None:
    """Raise ``numpy.linalg.LinAlgError`` unless ``X`` solves ``K X = rhs`` to `RESIDUAL_MAX`
    relative to ``rhs`` (a singular ``K``: no solution)."""
    if not np.linalg.norm(K @ X - rhs) <= RESIDUAL_MAX * np.linalg.norm(rhs):
        raise np.linalg.LinAlgError("the sparse solve leaves a residual: the matrix is singular")


class LinearisationBase:
    """What every `flexmb.protocols.Linearisation` here shares: ``K`` built by the constructor,
    ``M`` by ``_mass()`` when first read, ``place``."""

    _K = _M = Z = None

    @property
    def K(self):
        """The tangent on the coordinates (n, n), dead loads included."""
        return self._K

    @property
    def M(self):
        """The mass on the coordinates (n, n) at the deformed state, built when first read."""
        if self._M is None:
            self._M = self._mass()
        return self._M

    def place(self, q: np.ndarray) -> np.ndarray:
        """Coordinate vectors (n, k) on the generalised DOFs (size, k), held ones (and hinge
        multipliers) 0."""
        q = np.asarray(q, dtype=float).reshape(self._K.shape[0], -1)
        out = np.zeros((self.size, q.shape[1]))
        out[self.free] = q if self.Z is None else self.Z @ q
        return out


class FELinearisation(LinearisationBase):
    """The full finite-element model's `flexmb.protocols.Linearisation` at a converged solution.

    The generalised DOFs are the model's (``size = n_dofs``); ``free`` the free node DOFs (held
    ones and hinge multipliers out), ``Z`` the hinges' allowed motions (None without hinges). ``K``
    (CSR) is built here, the mass, buckling's material tangent and the factorisation when first
    asked for. ``modal`` changes nothing: these coordinates carry the mass already."""

    dense = False

    def __init__(self, solution, held="prescribed", *, modal: bool = False, owner: str = "linearisation"):
        self.problem = problem = solvable_problem(solution, owner)
        self.solution, self.compiled, self.state = solution, solution.compiled, solution.state
        self.model = model = problem.model
        self.held, free = held_and_free(solution, held, owner)
        self.size = model.n_dofs
        K = self.full = full_tangent(solution)  # all DOFs: the design gradients read its prescribed rows too
        self.free, self.Z = constrained(model, free, K, solution.state)  # hinges: their motions, multipliers out
        self._K = self._restricted(K)
        self._factor = None

    def _restricted(self, A) -> sp.csr_array:
        """``A`` (n_dofs, n_dofs) on the coordinates: ``Z^T A_ff Z``, CSR."""
        A = A[self.free][:, self.free].tocsr()
        return A if self.Z is None else (self.Z.T @ A @ self.Z).tocsr()

    def _mass(self) -> sp.csr_array:
        """The consistent mass on the coordinates (`flexmb.fe.mass.mass_matrix`)."""
        return self._restricted(mass_matrix(self.model, self.state, self.model.rigid_masses))

    def material_tangent(self, base=None) -> sp.csr_array:
        """Buckling's ``K_m`` on the coordinates: the material tangent at the solution
        (`material_tangent`), or with ``base`` (a converged solution of the same mechanism) the
        full tangent at ``base`` (`ModelError` if its nodes or elements differ)."""
        if base is None:
            return self._restricted(material_tangent(self.solution))
        bmodel = solvable_problem(base).model
        model = self.model
        if bmodel.n_dofs != model.n_dofs or not np.array_equal(bmodel.x0, model.x0) or \
                len(bmodel.elements.L0) != len(model.elements.L0):
            raise ModelError("buckling: base is not a solution of the same mechanism (its nodes or elements differ)")
        return self._restricted(full_tangent(base))

    def expand(self, v: np.ndarray) -> np.ndarray:
        """Generalised DOF vectors (n_dofs, k) on the model's DOFs: the same (a copy)."""
        return np.array(v, dtype=float).reshape(self.size, -1)

    def solve(self, b: np.ndarray, transpose: bool = False) -> np.ndarray:
        """``x`` with ``K x = b`` (``transpose``: ``K^T x = b``), ``b`` (n,) or (n, k), one
        factorisation kept for every solve: below `SPARSE_FROM` coordinates `DenseFactor` (its
        condition number raised as `scipy.linalg.LinAlgWarning` when below eps: a singular
        tangent), above a sparse solve checked to `RESIDUAL_MAX` (`numpy.linalg.LinAlgError`):
        ``K x = b`` by the problem's solver (`flexmb.problem.StaticProblem.solve_linear`, its
        analysis kept), ``K^T x = b`` by a kept SuperLU."""
        K = self._K
        if K.shape[0] < SPARSE_FROM:
            if self._factor is None:
                self._factor = DenseFactor(K.toarray(), ill_conditioned="raise")
            return self._factor.solve(b, transpose)
        if not transpose:
            with warnings.catch_warnings():
                warnings.simplefilter("error", sla.LinAlgWarning)
                # CSC, as `flexmb.compliance` always passed it: the solver reads it as K^T's CSR and
                # its refinement against K makes the solve exact; CSR would move compliance by
                # ~1e-12 relative (measured: manipulator 4e-13, four-bar 5 el./leaf 8e-12)
                x = self.problem.solve_linear(K.tocsc(), b)
        else:
            if self._factor is None:
                self._factor = spla.splu(K.tocsc())
            x = self._factor.solve(np.asarray(b, dtype=float), trans="T")
        _consistent(K.T if transpose else K, x, b)
        return x
