"""The EOB condensation tabulated against the intended rotation.

KSD-reduced needs per joint the condensed stiffness and force of node B with node A held
(Eq. 2.4) and the recovery of the internal nodes (Eq. 2.6): `flexmb.ksd.eob.EOBTemplate.evaluate`
assembles the EOB and solves the interior (Craig-Bampton) for them, most of a KSD-reduced solve
(BENCHMARKS.md, KSD-reduced with the tabulated EOB condensation). They depend on theta alone, up to terms exactly linear in node B's near position,
so they are sampled once on a grid (`tabulate`, stored in the joint's database file,
`flexmb.database.eob_format`) and interpolated (`Lookup`).

Grid and degree, measured on three_x_infinity (3D, 3 el./leaf, +-45 deg) against direct
evaluation at 60 random angles, largest error relative to each quantity's largest entry:
cubic splines on 0.25 deg 2.9e-9 (K_T) / 1.1e-8 (recovery), on 1 deg 1.4e-6 / 3.8e-6; quintic
on 1 deg 7.5e-9 / 1.8e-8; degree 7 on 1 deg 1.0e-10 / 2.8e-10 (a Chebyshev series needs degree
> 48 for 1e-6: the condensation varies too locally). Default: degree 7 on a 1 deg grid, halved
where needed for 1e-9 (`tabulate`): 91 samples of 1320 numbers for that joint, 0.96 MB in the
database's side file.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_interp_spline

from ..database.eob_format import NAMES, EOBTable
from ..database.eob_format import plain_parameters
from ..errors import DatabaseError
from .eob import EOB
from .geometry import ACTIVE

__all__ = ["tabulate", "Lookup", "lookup_for", "layout", "STEP_DEG", "FINEST_DEG", "DEGREE", "TOL"]

STEP_DEG = 1.0  # first grid step [deg]
FINEST_DEG = 0.125  # finest grid step [deg]
DEGREE = 7  # spline degree
TOL = 1e-9  # interpolation error accepted, relative to each quantity's largest entry
#: how far beyond the grid's ends [rad] the table is used: step 1's roundoff (the kinematic solve's
#: 1e-9 rad, as `flexmb.solvers.ksd` accepts a trained range)
SLACK = 1e-9


def _sample(tpl, theta: np.ndarray) -> dict:
    """The quantities of `flexmb.database.eob_format` at ``theta`` (S,): {name: (S, rows, cols)}."""
    S, dim = len(theta), tpl.dim
    zero = tpl.evaluate(theta, np.zeros((S, dim)), held_a=True)
    unit = [tpl.evaluate(theta, np.tile(np.eye(dim)[k], (S, 1)), held_a=True) for k in range(dim)]
    parts = {"K_T": zero.K_T, "F0": zero.F_hat_T[..., None],
             "G": np.stack([u.F_hat_T - zero.F_hat_T for u in unit], axis=-1),
             "RK": zero.recover[:, :, :-1], "r0": zero.recover[:, :, -1:],
             "rG": np.stack([u.recover[:, :, -1] - zero.recover[:, :, -1] for u in unit], axis=-1),
             "P0": zero.node_position[:, 2:]}
    return parts


def tabulate(tpl, parameters: dict, step_deg: float | None = None, degree: int = DEGREE,
             tol: float = TOL) -> EOBTable:
    """Sample the condensation of ``tpl`` (an `EOBTemplate`) over its database's range;
    ``parameters`` the joint's (`Joint.describe`) that the table belongs to. ``step_deg`` None:
    from `STEP_DEG`, halved (to at most `FINEST_DEG`) until the spline through the grid
    reproduces the samples half-way between to ``tol`` relative to each quantity's largest entry,
    i.e. where its error is largest (the 2D cross flexure needs 0.5 deg: a sharp feature near
    2 deg; three_x_infinity 1 deg)."""
    lo, hi = tpl.data.range

    def grid(step):
        return np.linspace(lo, hi, int(round((hi - lo) / np.radians(step))) + 1)

    def rows(theta):
        parts = _sample(tpl, theta)
        return parts, np.concatenate([parts[n].reshape(len(theta), -1) for n in NAMES], axis=1)

    step = STEP_DEG if step_deg is None else step_deg
    theta = grid(step)
    parts, values = rows(theta)
    while step_deg is None and step > FINEST_DEG:
        mid = 0.5 * (theta[1:] + theta[:-1])
        _, between = rows(mid)
        err = np.abs(make_interp_spline(theta, values, k=degree, axis=0)(mid) - between)
        scale = np.maximum(np.abs(values).max(axis=0), 1e-300)
        at, worst = 0, 0.0
        for n in NAMES:  # error relative to each quantity's largest entry
            w = parts[n].shape[1] * parts[n].shape[2]
            worst = max(worst, float(err[:, at:at + w].max(initial=0.0) / scale[at:at + w].max(initial=1e-300)))
            at += w
        if worst <= tol:
            break
        step /= 2
        theta = grid(step)
        parts, values = rows(theta)
    layout = tuple((n, parts[n].shape[1], parts[n].shape[2]) for n in NAMES)
    values.flags.writeable = False
    return EOBTable(dict(parameters), theta, degree, layout, values)


def lookup_for(tpl, joint):
    """A `Lookup` of the table in ``tpl``'s database when it belongs to this very ``joint`` (same
    `Joint.describe` parameters), else None (the condensation is then computed per solve)."""
    table = getattr(tpl.data, "eob_table", None)
    if table is None or _stiffness_parameters(table.parameters) != _stiffness_parameters(
            plain_parameters(joint.describe())):
        return None
    expected = layout(tpl)
    if tuple(table.layout) != expected:  # both paths would read it by the mesh's sizes: refuse
        bad = [f"{n} {(r, c)} (the mesh's {(er, ec)})" for (n, r, c), (_, er, ec) in zip(table.layout, expected)
               if (r, c) != (er, ec)]
        raise DatabaseError(f"the EOB table {table.source or ''} does not fit the joint's mesh ({tpl.n_nodes} nodes, "
                            f"{tpl.nd} DOFs a node): {', '.join(bad)}; re-create it with `flexmb train --eob-table`")
    return Lookup(tpl, table)


def layout(tpl) -> tuple:
    """The (name, rows, cols) of each tabulated quantity (`NAMES`) for ``tpl``'s mesh, as `_sample`
    gives them: K_T (nd, nd), F0 (nd, 1), G (nd, dim), RK (n_i nd, nd), r0 (n_i nd, 1), rG
    (n_i nd, dim), P0 (n_i, dim), n_i = the internal nodes."""
    nd, dim, ni = tpl.nd, tpl.dim, tpl.n_nodes - 2
    sizes = ((nd, nd), (nd, 1), (nd, dim), (ni * nd, nd), (ni * nd, 1), (ni * nd, dim), (ni, dim))
    return tuple((n, r, c) for n, (r, c) in zip(NAMES, sizes))


#: joint parameters that do not enter the EOB condensation (mass, strength)
_NOT_STIFFNESS = frozenset({"density", "yield_stress"})


def _stiffness_parameters(parameters: dict) -> dict:
    """The parameters the condensation depends on: those set (an unset option such as ``nu=None``,
    with ``G`` given, changes nothing) other than mass and strength."""
    return {k: v for k, v in parameters.items() if v is not None and k not in _NOT_STIFFNESS}


class Lookup:
    """Interpolation of an `EOBTable` for one template (the spline built once)."""

    def __init__(self, tpl, table: EOBTable):
        self.tpl, self.table = tpl, table
        self.range = (float(table.theta[0]), float(table.theta[-1]))
        self._spline = make_interp_spline(table.theta, table.values, k=table.degree, axis=0)

    def compiled(self, theta: np.ndarray, b_position: np.ndarray, at: np.ndarray | None = None, K=None, F_hat=None):
        """`__call__`'s quantities through `flexmb.ksd.reduced_jit.eob_lookup` (one call instead of
        ~40 numpy ones) for the joints ``at`` (None: all) of ``theta`` (J,) and ``b_position``
        (J, >= dim): their stiffness and force into rows ``at`` of ``K`` (J, 6, 6) and ``F_hat``
        (J, 6) in 3D form (`ACTIVE`; new zero arrays when None); returns ``K``, ``F_hat``,
        ``recover`` (Jg, n_i nd, nd + 1), the internal nodes' near positions (Jg, n_i, dim) and
        orientations (3D: matrices (Jg, n_i, 3, 3); 2D: angles (Jg, n_i))."""
        from .reduced_jit import eob_lookup_new

        tpl = self.tpl
        dim, ni = tpl.dim, tpl.n_nodes - 2
        t, coef, k, root, powers, ocoef, emb = self.kernel_args()
        theta = np.ascontiguousarray(theta, dtype=float)
        J = len(theta)
        at = np.arange(J) if at is None else at
        K = np.zeros((J, 6, 6)) if K is None else K
        F_hat = np.zeros((J, 6)) if F_hat is None else F_hat
        recover, x_int, R_int, a_int = eob_lookup_new(t, coef, k, theta, np.ascontiguousarray(b_position, dtype=float),
                                                      at, root, powers, ocoef, emb, K, F_hat, ni, dim)
        return K, F_hat, recover, x_int, (R_int if dim == 3 else a_int)

    def kernel_args(self) -> tuple:
        """`flexmb.ksd.reduced_jit.eob_lookup`'s table and template arguments, contiguous, built once:
        the spline's knots, coefficients (n, values) and degree, the internal nodes' root flags,
        their orientations' polynomial powers and coefficients, the active components."""
        try:
            return self._compiled_args
        except AttributeError:
            tpl = self.tpl
            c = np.ascontiguousarray
            comp = 1 if tpl.dim == 2 else 3
            assert tuple(n for n, *_ in self.table.layout) == NAMES
            args = self._compiled_args = (
                c(self._spline.t, dtype=float), c(self._spline.c.reshape(len(self._spline.c), -1), dtype=float),
                int(self._spline.k), c(tpl.root, dtype=np.int64), c(tpl._powers, dtype=float),
                c(tpl._coef[:, comp * tpl.n_elements:], dtype=float), ACTIVE[tpl.dim])
            return args

    def covers(self, theta: np.ndarray) -> bool:
        """Whether every ``theta`` [rad] lies on the grid's range (else: evaluate directly), up to
        `SLACK` beyond its ends (the spline's end polynomials continued there). Without the slack
        the end of the range was decided by roundoff: the manipulator's location case at 45 deg
        reaches 45 deg plus 4e-16 rad or minus 5e-16 by the order of step 1's sums, and the
        direct evaluation there (differing by the table's 1e-9) moved node positions by 2e-12
        relative and cost a direct condensation more."""
        lo, hi = self.range
        return all(lo - SLACK <= t <= hi + SLACK for t in np.ravel(theta).tolist())  # a few joints: no ufuncs

    def __call__(self, theta: np.ndarray, b_position: np.ndarray) -> EOB:
        """The condensation at ``theta`` (J,) with node B's near position ``b_position`` (J, dim),
        as an `EOB` evaluated with node A held whose element-level fields (``rotation``, ``K0``,
        ``q_hat``, ``lever``, ``K_nodes``, ``F_hat_nodes``, ``marker_position``) are None: what
        KSD-reduced reads (``K_T``, ``F_hat_T``, ``recover``, the nodes' near poses)."""
        tpl = self.tpl
        p = self.table.split(self._spline(theta))
        b = np.asarray(b_position, dtype=float)
        F = p["F0"][..., 0] + (p["G"] @ b[..., None])[..., 0]
        rec = np.concatenate([p["RK"], p["r0"] + p["rG"] @ b[..., None]], axis=2)
        J = len(theta)
        x = np.zeros((J, tpl.n_nodes, tpl.dim))
        x[:, 1] = b
        x[:, 2:] = p["P0"] + np.where(tpl.root[:, None] == 1, b[:, None, :], 0.0)
        _, _, node_angle, Rn = tpl.orientations(theta, elements=False)
        return EOB(None, None, None, None, None, None, p["K_T"], F, rec, x, node_angle, Rn, None)
