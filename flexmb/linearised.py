"""Properties of a converged equilibrium from its linearisation: `buckling` multipliers and the
`compliance` of a link's point (SPACAR's buckling load multipliers and CMglob / CMloc).

Both use the full tangent of `flexmb.modal` (dead loads, prescribed DOFs held by default, the
``held`` argument as in `flexmb.modes`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import _validate as v
from ._warnings import renamed_keyword
from .errors import ModelError, ParameterError
from .linearisation import DenseFactor, RESIDUAL_MAX, _consistent, linearise, material_tangent  # noqa: F401 (re-exported)
from .modal import DENSE_BELOW, start_vector
from .results import estimated

__all__ = ["buckling", "compliance", "material_tangent", "RESIDUAL_MAX"]


def _solve_dense(K: np.ndarray, rhs: np.ndarray, ill_conditioned: str = "warn") -> np.ndarray:
    """``scipy.linalg.solve(K, rhs)`` bit for bit, by the factorisation it would choose called
    through LAPACK directly (`flexmb.linearisation.DenseFactor`): ``LinAlgError`` for an exactly
    singular ``K``, `scipy.linalg.LinAlgWarning` where its reciprocal condition number is below
    eps (``ill_conditioned="raise"``: raised as the exception)."""
    return DenseFactor(K, ill_conditioned).solve(rhs)


#: Eigenvalues ``mu`` of ``K_s phi = mu K_m phi`` below this fraction of the largest |mu| are zero
#: to working precision (round-off of eps times K_m's condition; measured -3.9e-19 against 0.012
#: for a 16-element cantilever in tension): no buckling multiplier.
MU_ROUNDOFF = 1e-10


@estimated("buckling")
def buckling(solution, n_buckling: int = 1, held="prescribed", base=None, *, n: int | None = None) -> np.ndarray:
    """The ``n_buckling`` lowest positive buckling multipliers of the solution's loads and prescribed
    motions, linearised about its deformed state: ``(K_m + lam K_s) phi = 0`` with ``K_m`` the
    material tangent (`material_tangent`) and ``K_s = K_t - K_m`` the part proportional to the
    current stresses and loads (geometric and load stiffness), both at the solution. ``lam = 1``:
    the solution itself is critical; ``lam`` times the loads is the linearised critical load. Where
    the pre-buckling path is linear (stresses proportional to the load) this is the classical
    linear buckling analysis (e.g. Bathe 2014, Sec. 6.8.2). Returns an array (n,), ascending;
    ``inf`` where fewer than ``n_buckling`` positive multipliers exist (no buckling under this load
    direction). ``n``: the deprecated name of ``n_buckling`` (a FutureWarning).

    ``base``: a converged solution of the same mechanism under a preload (e.g. a prescribed turn
    with the variable force off) that stays as it is: then ``K_m`` is the full tangent at
    ``base`` and ``K_s = K_t(solution) - K_t(base)`` the change the load increment from ``base``
    to ``solution`` makes, so ``base + lam (solution - base)`` is the critical load (the
    linearised pre-buckling analysis about a preloaded state; the secant of the tangent, exact
    where the tangent is linear in the increment). Without it, a prescribed turn's stresses are
    scaled with the loads.

    A KSD-reduced solution has none (`UnsupportedStrategyError`: solve with ``method="ksd-full"``).
    Measured on the Table 1 cross flexure (5 el./leaf) pushed along its axis by 100 N: the
    reduced mechanism's Craig-Bampton basis (6 fixed-interface modes per joint) with the full
    model's geometric stiffness at step 4's positions and the EOBs' axial forces gives the
    critical force +0.02 % (turn free) and +2.9 % (turn held) unturned, but -23 % and +2.4 %
    turned 20 deg; the converged state's tangent on that basis still +11 % (turn free): neither
    the stress-free EOBs nor the basis carry a turned joint's buckling.
    """
    n = renamed_keyword("buckling", "n", n, "n_buckling", n_buckling, 1)
    lin = linearise(solution, held, owner="buckling")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"buckling: n_buckling={n!r} must be an integer in [1, the number of free motions]")
    Km = lin.material_tangent(base)  # the solution kind's: KSD-reduced has none
    Kt = lin.K
    nf = Kt.shape[0]
    if nf == 0:
        raise ModelError(f"buckling: no free motion to buckle: every DOF is held or fixed (held={held!r}; the "
                         "default 'prescribed' holds the prescribed motions: held='fixed' releases them)")
    if n > nf:
        raise ParameterError(f"buckling: n_buckling={n!r} must be an integer in [1, {nf}] (the "
                             f"{'free DOFs' if lin.Z is None else 'motions the hinges allow'}: {nf})")
    Ks = (Kt - Km).tocsr() if sp.issparse(Kt) else np.asarray(Kt - Km)  # a dense linearisation's: arrays
    if (Ks.nnz == 0 if sp.issparse(Ks) else Ks.size == 0) or abs(Ks).max() == 0.0:
        return np.full(n, np.inf)  # no stress, no load: nothing to buckle
    return _positive_multipliers(_multipliers(Ks, Km, n, nf), n)


def _multipliers(Ks, Km, n: int, nf: int) -> np.ndarray:
    """The finite eigenvalues ``mu`` of ``K_s phi = mu K_m phi`` (``mu = -1/lam``: the critical,
    smallest positive ``lam`` has the most negative ``mu``): dense below `DENSE_BELOW`, else the
    ``2 n + 8`` ARPACK finds."""
    tol = 1e-11 * abs(Km).max()
    symmetric = bool(abs(Ks - Ks.T).max() <= tol and abs(Km - Km.T).max() <= tol)
    if nf < DENSE_BELOW or n >= nf - 2 or not sp.issparse(Ks):  # ARPACK: fewer than nf - 1 eigenvalues
        A, B = (X.toarray() if sp.issparse(X) else np.asarray(X) for X in (Ks, Km))
        try:
            mu = sla.eigh(0.5 * (A + A.T), 0.5 * (B + B.T), eigvals_only=True) if symmetric else sla.eigvals(A, B)
        except np.linalg.LinAlgError:  # K_m not positive definite (an unstable base): the general problem
            mu = sla.eigvals(A, B)
    else:
        # ARPACK to 1e-10 relative (its default, machine precision, did not finish on a
        # 10 000-DOF manipulator)
        k = min(nf - 2, 2 * n + 8)
        if symmetric:
            mu = spla.eigsh((0.5 * (Ks + Ks.T)).tocsc(), k=k, M=(0.5 * (Km + Km.T)).tocsc(), which="SA",
                            return_eigenvectors=False, tol=1e-10, v0=start_vector(nf))
        else:  # nu = 1/lam of K_m^-1 (-K_s): the largest real parts are the critical multipliers
            lu = spla.splu(Km.tocsc())
            op = spla.LinearOperator(Km.shape, matvec=lambda x: lu.solve(-(Ks @ x)), dtype=float)
            mu = -spla.eigs(op, k=k, which="LR", return_eigenvectors=False, tol=1e-10, v0=start_vector(nf))
    mu = np.asarray(mu)
    return mu[np.isfinite(mu)]


def _positive_multipliers(mu: np.ndarray, n: int) -> np.ndarray:
    """The ``n`` smallest positive multipliers ``lam = -1/mu`` of the eigenvalues ``mu`` of
    ``K_s phi = mu K_m phi`` (real ones; inf where fewer exist). A mu that is zero to working
    precision (`MU_ROUNDOFF`) is none: a cantilever pulled along its axis (stress stiffening only)
    gave mu = -3.9e-19 beside 0.012, i.e. lam = 7.8e17 instead of inf."""
    real = mu[np.abs(mu.imag) <= 1e-9 * np.abs(mu).max()].real if np.iscomplexobj(mu) else mu
    zero = MU_ROUNDOFF * (np.abs(real).max() if real.size else 0.0)
    lam = np.sort(-1.0 / real[real < -zero])
    out = np.full(n, np.inf)
    out[: min(n, len(lam))] = lam[:n]
    return out


@estimated("compliance")
def compliance(solution, link: str, point=None, axes: str = "global", held="prescribed") -> np.ndarray:
    """Compliance (6, 6) in 3D, (3, 3) in 2D, of a point of ``link`` at the solution's deformed
    state with the ``held`` DOFs held (as in `flexmb.modes`; default the prescribed ones): the point's displacement and rotation [m, rad] per unit
    force and moment [N, N m] applied there (moments about the point), ``C = T K_ff^-1 T^T`` with
    the rigid lever ``T`` from the link's node to the point and ``K_ff`` the full tangent on the
    free DOFs (dead loads). ``point``: a named point of the link (`Mechanism.add_point`) or its
    undeformed global position [m] (default: the link's reference point). ``axes``: ``"global"``
    (SPACAR's CMglob) or ``"link"`` (CMloc: the link's current axes). Held components of the
    link's node give zero rows and columns.

    A KSD-reduced solution gives the reduced mechanism's compliance: ``K_ff`` is then the tangent
    of KSD step 3's equilibrium on the links' DOFs (`flexmb.ksd.reduced_model.reduced_tangent`: each
    joint's Craig-Bampton EOB stiffness at its near configuration, carried through the joints'
    current frames). Measured against the full model at the conventional solution: the
    manipulator's end link over +-45 deg within 0.72 % (median 0.16 %), the four-bar's top link
    0.95 % at d = 0.1 m and 7.3 % at 0.3 m; the joints' stress stiffening is not in the EOB's
    material stiffness (a cross flexure turned 0.3 rad: rotation compliance +1.46 %)."""
    lin = linearise(solution, held, owner="compliance")
    compiled, model, state = solution.compiled, lin.model, solution.state
    if link not in compiled.link_node:
        raise ModelError(f"compliance: no link named {link!r}; links: {', '.join(compiled.link_node)}")
    if axes not in ("global", "link"):
        raise ParameterError(f"compliance: axes={axes!r}; valid: 'global', 'link'")
    node = compiled.link_node[link]
    dim, nd = model.dim, model.ndof
    if point is None:
        offset = np.zeros(dim)
    elif isinstance(point, str):
        owner, offset = compiled.points.get(point, (None, None))
        if owner != link:
            raise ModelError(f"compliance: link {link!r} has no point named {point!r}")
    else:
        offset = v.vector(f"compliance of link {link!r}", "point", point, dim) - model.x0[node]
    C_node = _node_compliance(lin, model.node_dofs[node], link, held)
    if offset.any():
        T = model._lever(model.offsets(state, np.array([node]), offset[None]))[0]  # point motion = T node motion
        C = T @ C_node @ T.T
    else:  # the node itself: T = I (the same numbers without the lever's assembly)
        C = C_node
    if axes == "link":
        R = model.rotation_matrices(state)[node]
        B = np.eye(nd)
        B[:dim, :dim] = R
        if dim == 3:
            B[3:, 3:] = R
        C = B.T @ C @ B
    return C


def _node_compliance(lin, dofs: np.ndarray, link: str, held) -> np.ndarray:
    """The compliance (nd, nd) of a link's node DOFs ``dofs`` from the linearisation: ``Z K^-1 Z^T``
    on its free ones, zero rows and columns for the held ones (`ModelError` for a singular ``K``)."""
    free, Z = lin.free, lin.Z
    cols = np.searchsorted(free, dofs)
    is_free = (cols < len(free)) & (free[np.minimum(cols, len(free) - 1)] == dofs)
    C_node = np.zeros((len(dofs), len(dofs)))
    if not is_free.any():
        return C_node
    rhs = np.zeros((len(free), int(is_free.sum())))
    rhs[cols[is_free], np.arange(rhs.shape[1])] = 1.0
    if Z is not None:
        rhs = Z.T @ rhs
    singular = (f"compliance of link {link!r}: the tangent on the free DOFs is singular (held={held!r} leaves a "
                "rigid-body motion free, or the equilibrium is critical)")
    try:
        X = lin.solve(rhs)
    except (np.linalg.LinAlgError, sla.LinAlgWarning, RuntimeError, ArithmeticError) as exc:
        raise ModelError(singular) from exc
    if not np.all(np.isfinite(X)):
        raise ModelError(singular)
    if Z is not None:
        X = Z @ X
    C_node[np.ix_(is_free, is_free)] = X[cols[is_free]]
    return C_node
