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
follows: the fewest negative eigenvalues (stable where a stable branch exists), then, where the
path's own continuation is unstable, a branch that leaves it (a device's imperfections grow the
critical mode: it snaps along the bifurcated branch, as the shallow arches do), then a load
factor that keeps growing (the control moves on), then the first found.
"""

from __future__ import annotations

import math

import attrs
import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

__all__ = ["BRANCHES", "ORTHOGONAL", "SAME_POINT", "ASYMMETRIC", "branch_points", "choose", "critical_modes",
           "is_bifurcation", "multiplicity", "switch_arc", "is_asymmetric"]

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

#: A bifurcation is asymmetric (Koiter 1945: the critical state itself unstable, a snap under any
#: control) when the branches leaving along opposite critical modes ``+phi``, ``-phi`` change the
#: load factor with opposite signs, each by more than this fraction of the load factor there and
#: their sizes within a factor 2 (a symmetric pitchfork's change the same sign, a flat one's
#: round-off: the perfect Euler strut's 3e-10 of its step; Roorda's frame: +-5.8e-5 of its step).
ASYMMETRIC = 1e-8

#: The eigenvalues that vanish at a critical point stand apart from the others nearest zero
#: (`PathPoint.near`) by a gap: consecutive magnitudes (floored at `NEAR_FLOOR` of the largest)
#: whose ratio is the widest and at least `NEAR_GAP`; without such a gap, those below `NEAR_ZERO`
#: of the largest. A fixed fraction alone failed where the vanishing eigenvalues sit at the
#: tangent's round-off: Qiu's double beam at its second (double) bifurcation, met at the load
#: factor's turn on the branch where both halves buckle, has ``[-3.6e-9, 3.0e-9, 2.76e-5,
#: 2.76e-5]`` (40 el./half, numpy kernels; 1.7e-9 with the compiled ones): 1.1e-4 of the next
#: pair, above `NEAR_ZERO`, counted as a simple point whose switch missed the path beyond.
NEAR_ZERO = 1e-4
NEAR_GAP = 1e2
NEAR_FLOOR = 1e-6

#: The first step onto a bifurcated branch moves the mechanism along the critical mode by at
#: least this fraction of its size (or turns a node by this [rad]): the path's metric is scaled
#: by the primary path's motion, which may be tiny beside the branch's (a strut's axial shortening
#: beside its bending).
SWITCH_MOTION = 0.01

#: A critical mode's sign: its first weighted component (DOF order) at least this fraction of
#: its largest is positive (`critical_modes`).
SIGN_FRACTION = 0.5

#: Below this many free DOFs eigenvectors come from LAPACK's dense ``eigh``, above from
#: shift-invert ARPACK at 0 (as `flexmb.solvers.arclength.inertia`'s eigenvalues).
DENSE_EIGEN_BELOW = 400


def critical_modes(problem, metric, p, m: int) -> np.ndarray:
    """The ``m`` critical modes at ``p`` (a `PathPoint` at a critical point): eigenvectors of
    the symmetric free tangent (with hinges, on the motions they allow) for the ``m``
    eigenvalues nearest zero, as increments of every DOF (m, n_dofs), each of unit length in
    the path's metric, its sign such that its first weighted component (in DOF order) above
    `SIGN_FRACTION` of its largest is positive (the largest alone may tie between a buckled
    leaf's two equal and opposite peaks: round-off flipped it between the compiled and numpy
    kernels, and the branch a double bifurcation's switch chose with it)."""
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
        w = np.abs(metric.weights() * phi)
        phi = phi / metric.length(phi, 0.0)
        first = np.flatnonzero(w >= SIGN_FRACTION * w.max())[0]
        out.append(phi if phi[first] > 0 else -phi)
    return np.array(out)


def multiplicity(p) -> int:
    """The number of the eigenvalues nearest zero at ``p`` (`PathPoint.near`) that vanish: those
    below the widest gap between consecutive magnitudes when it is at least `NEAR_GAP` (magnitudes
    floored at `NEAR_FLOOR` of the largest: one eigenvalue of a pair crossing zero exactly must not
    open a gap of its own), else those below `NEAR_ZERO` of the largest; at least 1."""
    a = np.sort(np.abs(p.near))
    if len(a) == 0 or a[-1] == 0.0:
        return 1
    if len(a) > 1:
        f = np.maximum(a, NEAR_FLOOR * a[-1])
        ratios = f[1:] / f[:-1]
        i = int(np.argmax(ratios))
        if ratios[i] >= NEAR_GAP:
            return i + 1
    return max(1, int(np.sum(a <= NEAR_ZERO * a[-1])))


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


def branch_points(strategy, problem, metric, p, came_from, modes: np.ndarray, ds: float,
                  switch: float | None = None) -> tuple:
    """Points on the branches that leave the critical point ``p``, ``(own, others)``: the
    path's own continuation (along its secant from ``came_from``, at arc length ``ds``; None if
    its corrector failed) and one point per predictor along the branch whose load factor changes
    there (`load_directions`, at ``ds``) and along the critical modes (`directions`, at
    ``switch``, default ``ds``) whose corrector converged to a new branch: not the way the path
    came, not a point found already, and whether the bifurcation is asymmetric (`is_asymmetric`
    of the mode predictors' load-factor changes): ``(own, others, asymmetric)``. Each `PathPoint`
    has its direction (the way it runs away from ``p``) and stability."""
    incoming = metric.difference(came_from.state, p.state), came_from.lam - p.lam
    found = []
    # p's own tangent is any vector of the null space (the tangent is singular there): the path
    # goes on along its secant from the point before
    n = metric.length(*incoming)
    own = strategy.step(problem, metric, attrs.evolve(p, tangent=-incoming[0] / n, tangent_lam=-incoming[1] / n,
                                                      direction=1.0, dlam_ds=-incoming[1] / n), ds)
    if own is not None:
        found.append(own)
    switch = ds if switch is None else switch
    along = directions(modes)
    predictors = [(d, 0.0, switch) for d in along] + \
        [(d, dl, ds) for d, dl in load_directions(strategy, problem, metric, p, modes)]
    changes = []  # the load factor's change along each mode predictor (None: no point)
    for k, (d, dl, length) in enumerate(predictors):
        q = strategy.step(problem, metric, attrs.evolve(p, tangent=d, tangent_lam=dl, direction=1.0, dlam_ds=dl),
                          length)
        if k < len(along):
            changes.append(None if q is None else q.lam - p.lam)
        if q is None:
            continue
        chord = metric.difference(q.state, p.state), q.lam - p.lam
        if _cosine(metric, chord, incoming) > _BACK:
            continue  # the branch the path came along, going back
        if any(_distance(metric, q, f) < SAME_POINT * length for f in found):
            continue
        found.append(q)
    return own, found[1:] if own is not None else found, is_asymmetric(changes, len(modes), p.lam)


def is_asymmetric(changes: list, m: int, lam: float) -> bool:
    """Whether the load-factor ``changes`` along the mode predictors (`directions` of ``m``
    modes, in order; None where the corrector failed) of a bifurcation at load factor ``lam``
    show an asymmetric bifurcation: a pair of opposite directions whose changes have opposite
    signs, comparable sizes and exceed `ASYMMETRIC` of ``lam`` (see there)."""
    pairs = [(0, 1)] if m == 1 else [(k, k + 4) for k in range(4)] if m == 2 else \
        [(k, k + 1) for k in range(0, len(changes) - 1, 2)]
    floor = ASYMMETRIC * max(abs(lam), 1e-300)
    for i, j in pairs:
        a, b = changes[i], changes[j]
        if a is None or b is None or a * b >= 0.0:
            continue
        if min(abs(a), abs(b)) > floor and min(abs(a), abs(b)) >= 0.5 * max(abs(a), abs(b)):
            return True
    return False


def choose(p, own, others: list, branch: str):
    """The point the path goes on with (`branch_points`' ``own`` or one of ``others``), by
    ``branch`` (`BRANCHES`): ``own`` when nothing else qualifies (or None if that failed too)."""
    if branch == "primary" or not others:
        return own
    pool = others if branch == "bifurcated" or own is None else [own] + others
    return min(pool, key=lambda c: (c.negative, c is own and c.negative > 0, c.lam < p.lam, pool.index(c)))


def _cosine(metric, a, b) -> float:
    """The cosine of the angle between two increments ``(du, dlam)`` in the path's metric."""
    dot = metric.dot(a[0], b[0]) + metric.psi2 * a[1] * b[1]
    na = math.sqrt(metric.dot(a[0], a[0]) + metric.psi2 * a[1] * a[1])
    nb = math.sqrt(metric.dot(b[0], b[0]) + metric.psi2 * b[1] * b[1])
    return dot / (na * nb) if na > 0 and nb > 0 else 0.0


def _distance(metric, a, b) -> float:
    """The arc-length distance between two path points."""
    return metric.length(metric.difference(b.state, a.state), b.lam - a.lam)
