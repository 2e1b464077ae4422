"""Critical points of an arc-length path: their modes, and the switch onto a bifurcated branch.

At a simple or multiple bifurcation point ``p`` of the path (``m`` eigenvalues of the symmetric
free tangent zero), the branches that meet there leave ``p`` along directions in the plane of
the path tangent and the critical modes, the null space of the tangent (Koiter 1945; Riks 1979).
The switch follows Wagner & Wriggers (1988): the predictor leaves ``p`` along a critical mode
``phi`` (``u_p + ds phi``, the load factor unchanged) and the spherical arc-length corrector
centred at ``p`` (`ArcLength.step`) brings it onto the nearest equilibrium at arc length ``ds``,
a point of the branch whose tangent is nearest ``phi``. With ``m > 1`` modes, predictors along
combinations of them (every ``pi / 4`` in the plane of two; each mode and their sum beyond)
find the branches in between (the symmetric two-leaf device's: one leaf buckled, or both).

Of the points found (and the path's own continuation), `choose` keeps the one the device
follows: the fewest negative eigenvalues (stable where a stable branch exists), then a load
factor that keeps growing (the control moves on), then the first found.
"""

from __future__ import annotations

import math

import attrs
import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

__all__ = ["BRANCHES", "ORTHOGONAL", "SAME_POINT", "branch_points", "choose", "critical_modes", "is_bifurcation",
           "multiplicity", "switch_arc"]

#: What `flexmb.trace` may do at a bifurcation point: ``"stable"`` take the branch the device
#: follows (`choose`), ``"primary"`` stay on the path it came along, ``"bifurcated"`` leave it
#: for the best other branch.
BRANCHES = ("stable", "primary", "bifurcated")

#: Two candidate points closer than this fraction of the step's arc length are the same
#: branch; a point whose chord from ``p`` turns by less than ``acos(0.9)`` = 26 deg from the
#: way the path came is that branch going back.
SAME_POINT = 0.2
_BACK = 0.9

#: A point where the load factor turns is a limit point when the load pattern works on its
#: critical mode (``phi . d r / d lam != 0``) and a bifurcation (a pitchfork met along its
#: bifurcated branch) when it does not: below this cosine between the two (in the metric and its
#: dual). A symmetric device's antisymmetric mode and symmetric load give round-off (~1e-12) and
#: the located point's offset from the bifurcation ~1e-7; a true limit point's cosine is O(1).
ORTHOGONAL = 1e-5

#: Eigenvalues nearest zero below this fraction of the largest of them (`PathPoint.near`) count
#: towards a critical point's multiplicity.
NEAR_ZERO = 1e-4

#: The first step onto a bifurcated branch moves the mechanism along the critical mode by at
#: least this fraction of its size (or turns a node by this [rad]): the path's metric is scaled
#: by the primary path's motion, which may be tiny beside the branch's (a strut's axial shortening
#: beside its bending).
SWITCH_MOTION = 0.01


#: Below this many free DOFs eigenvectors come from LAPACK's dense ``eigh``, above from
#: shift-invert ARPACK at 0 (as `flexmb.solvers.arclength.inertia`'s eigenvalues).
DENSE_EIGEN_BELOW = 400


def critical_modes(problem, metric, p, m: int) -> np.ndarray:
    """The ``m`` critical modes at ``p`` (a `PathPoint` at a critical point): eigenvectors of
    the symmetric free tangent (with hinges, on the motions they allow) for the ``m``
    eigenvalues nearest zero, as increments of every DOF (m, n_dofs), each of unit length in
    the path's metric, its largest weighted component positive (a deterministic sign)."""
    Kff = problem.evaluate(p.state, p.lam)[1]
    model = problem.model
    n = len(problem.free) - (model.hinges.n_rows if model.hinges is not None else 0)
    Z = None
    if model.hinges is not None:
        from ..fe.ideal import constrained_basis

        K = Kff.tocsr()
        Z = constrained_basis(K[n:, :n])
        Kr = (Z.T @ K[:n, :n] @ Z).tocsr()
    else:
        Kr = Kff
    vecs = _null_vectors(Kr, m)
    out = []
    for y in vecs.T:
        vf = np.zeros(len(problem.free))
        vf[:n] = y if Z is None else Z @ y
        phi = problem.full_increment(vf, np.zeros(len(problem.prescribed)))
        w = metric.weights() * phi
        phi = phi / metric.length(phi, 0.0)
        out.append(phi if w[np.argmax(np.abs(w))] > 0 else -phi)
    return np.array(out)


def multiplicity(p) -> int:
    """The number of the eigenvalues nearest zero at ``p`` (`PathPoint.near`) that vanish: those
    below `NEAR_ZERO` of the largest of them; at least 1."""
    a = np.abs(p.near)
    return max(1, int(np.sum(a <= NEAR_ZERO * a.max()))) if len(a) else 1


def is_bifurcation(problem, metric, modes: np.ndarray, g_free: np.ndarray) -> bool:
    """Whether a load factor's extremum is a bifurcation point (a pitchfork met along its
    bifurcated branch): every critical mode orthogonal to the load pattern ``g_free = d r_f / d lam``
    there (`ORTHOGONAL`), measured on the nodes' DOFs in the metric and its dual (unit-free)."""
    g = np.zeros(problem.model.n_dofs)
    g[problem.free] = g_free
    w = metric.weights()
    on = w > 0  # the nodes' DOFs (the hinges' multipliers weigh nothing)
    gw = g[on] / w[on]
    ng = float(np.linalg.norm(gw))
    if ng == 0.0:
        return True
    return all(abs(float(np.dot(phi[on], g[on]))) <= ORTHOGONAL * ng * float(np.linalg.norm(w[on] * phi[on]))
               for phi in modes)


def load_directions(strategy, problem, metric, p, modes: np.ndarray) -> list:
    """Unit path tangents ``(t, t_lam)`` at the bifurcation point ``p`` of the branch through it
    along which the load factor changes: ``K t = -d r / d lam`` solved on the complement of the
    critical ``modes`` (the load pattern does not work on them there), both ways."""
    t = strategy.rate(problem, p.state, p.lam)
    if t is None:
        return []
    for phi in modes:  # the singular solve's null-space part: removed in the metric
        t = t - metric.dot(phi, t) / metric.dot(phi, phi) * phi
    if not np.all(np.isfinite(t)):
        return []
    n = metric.length(t, 1.0)
    return [(t / n, 1.0 / n), (-t / n, -1.0 / n)]


def switch_arc(metric, modes: np.ndarray) -> float:
    """The arc length along the critical ``modes`` (each of unit length in the metric) that moves a
    node by `SWITCH_MOTION` of the mechanism's size (translations) or radians (rotations)."""
    motion = max(float(np.max(np.abs(metric.weights() * phi))) for phi in modes) * metric.scale
    return SWITCH_MOTION / motion if motion > 0 else 0.0


def _null_vectors(K, m: int) -> np.ndarray:
    """Eigenvectors (n, m) of the symmetric part of ``K`` for its ``m`` eigenvalues nearest zero."""
    n = K.shape[0]
    if n < DENSE_EIGEN_BELOW:
        A = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
        ev, V = sla.eigh(0.5 * (A + A.T))
        return V[:, np.argsort(np.abs(ev))[:m]]
    A = (0.5 * (K + K.T)).tocsc()
    ev, V = spla.eigsh(A, k=min(m, n - 1), sigma=0.0, which="LM")
    return V[:, np.argsort(np.abs(ev))]


def directions(modes: np.ndarray) -> list[np.ndarray]:
    """Predictor directions in the span of ``modes`` (m, N): both signs of the mode (m = 1); every
    pi / 4 in the plane of two; each mode and the sum of all, both signs, beyond."""
    m = len(modes)
    if m == 1:
        return [modes[0], -modes[0]]
    if m == 2:
        return [math.cos(t) * modes[0] + math.sin(t) * modes[1] for t in np.arange(8) * math.pi / 4]
    total = modes.sum(axis=0) / math.sqrt(m)
    return [s * d for d in (*modes, total) for s in (1.0, -1.0)]


def branch_points(strategy, problem, metric, p, came_from, modes: np.ndarray, ds: float) -> tuple:
    """Points at arc length ``ds`` from the critical point ``p`` on the branches that leave it,
    ``(own, others)``: the path's own continuation (along its secant from ``came_from``; None if
    its corrector failed) and one point per predictor along the critical modes (`directions`)
    and along the branch whose load factor changes there (`load_directions`) whose corrector
    converged to a new branch: not the way the path came, not a point found already. Each
    `PathPoint` has its direction (the way it runs away from ``p``) and stability."""
    incoming = metric.difference(came_from.state, p.state), came_from.lam - p.lam
    found = []
    # p's own tangent is any vector of the null space (the tangent is singular there): the path
    # goes on along its secant from the point before
    n = metric.length(*incoming)
    own = strategy.step(problem, metric, attrs.evolve(p, tangent=-incoming[0] / n, tangent_lam=-incoming[1] / n,
                                                      direction=1.0, dlam_ds=-incoming[1] / n), ds)
    if own is not None:
        found.append(own)
    predictors = [(d, 0.0) for d in directions(modes)] + load_directions(strategy, problem, metric, p, modes)
    for d, dl in predictors:
        start = attrs.evolve(p, tangent=d, tangent_lam=dl, direction=1.0, dlam_ds=dl)
        q = strategy.step(problem, metric, start, ds)
        if q is None:
            continue
        chord = metric.difference(q.state, p.state), q.lam - p.lam
        if _cosine(metric, chord, incoming) > _BACK:
            continue  # the branch the path came along, going back
        if any(_distance(metric, q, f) < SAME_POINT * ds for f in found):
            continue
        found.append(q)
    return own, found[1:] if own is not None else found


def choose(p, own, others: list, branch: str):
    """The point the path goes on with (`branch_points`' ``own`` or one of ``others``), by
    ``branch`` (`BRANCHES`): ``own`` when nothing else qualifies (or None if that failed too)."""
    if branch == "primary" or not others:
        return own
    pool = others if branch == "bifurcated" or own is None else [own] + others
    return min(pool, key=lambda c: (c.negative, c.lam < p.lam, pool.index(c)))


def _cosine(metric, a, b) -> float:
    """The cosine of the angle between two increments ``(du, dlam)`` in the path's metric."""
    dot = metric.dot(a[0], b[0]) + metric.psi2 * a[1] * b[1]
    na = math.sqrt(metric.dot(a[0], a[0]) + metric.psi2 * a[1] * a[1])
    nb = math.sqrt(metric.dot(b[0], b[0]) + metric.psi2 * b[1] * b[1])
    return dot / (na * nb) if na > 0 and nb > 0 else 0.0


def _distance(metric, a, b) -> float:
    """The arc-length distance between two path points."""
    return metric.length(metric.difference(b.state, a.state), b.lam - a.lam)
