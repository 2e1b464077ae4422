"""Undamped free vibration about a converged equilibrium: `modes`.

The linearisation (SPACAR's convention for the eigenfrequencies of a configuration):

* **Stiffness.** The full tangent of the static problem at the solution: the beams' material and
  geometric parts and the dead loads' load stiffness (`flexmb.problem.StaticProblem.evaluate`),
  assembled on every DOF. Loads are *dead*: the applied loads, and the reactions of any
  prescribed DOF that `held` releases, keep their size and global direction during the
  vibration. In 3D the rotation DOFs are spins (``dR = skew(dphi) R``); at a node where a dead
  moment ``m`` acts, the tangent's rotation block keeps a skew-symmetric part ``-1/2 skew(m)``
  (the internal moments balance ``m`` there): a dead moment is not conservative in 3D. Then the
  eigenproblem is solved as the non-symmetric one (``scipy.linalg.eig`` / ``eigs``), not
  symmetrised; without dead moments on free rotation DOFs the tangent is symmetric to the
  solution's residual and `scipy.linalg.eigh` / ``eigsh`` solve the symmetrised problem.
* **Mass.** The consistent mass (`flexmb.fe.mass`) at the deformed configuration: beams in their
  current co-rotated frames, the links' inertia tensors turned with the links.
* **Held DOFs.** ``held="prescribed"`` (default) holds the fixed links and every prescribed DOF
  (the actuated inputs held: the modes are the parasitic ones); ``"fixed"`` (``"none"`` before 0.2) holds only the fixed
  links (the intended motion is free: its mode appears); ``"floating"`` holds nothing (the
  unsupported mechanism, with its rigid-body zero modes); a sequence of link names (all their
  DOFs) and ``(link, component)`` pairs holds the fixed links and those components, with
  components ``"x"``, ``"y"``, ``"z"`` (translations along global axes), ``"rx"``, ``"ry"``,
  ``"rz"`` (3D) or ``"rotation"`` (2D: the angle; 3D: all three). A held rotation component in 3D
  is a zero *spin* about that global axis: the link may not turn about the global z axis
  (``"rz"``), whatever its current orientation; holding all three holds its orientation.
"""

from __future__ import annotations

import functools
import warnings
import weakref

import attrs
import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack as _lapack
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ._warnings import renamed_keyword
from .errors import ModelError, ParameterError
from .fe.ideal import constrained
from .ksd.linearisation import KSD_FIXED_INTERFACE_MODES
from .linearisation import full_tangent, held_dofs, linearise, solvable_problem, stiffness_and_mass
from .plausibility import check_mass_units

__all__ = ["Modes", "modes", "stiffness_and_mass", "full_tangent", "held_dofs", "solvable_problem", "constrained",
           "KSD_FIXED_INTERFACE_MODES", "DENSE_BELOW",
           "DENSE_BELOW_NONSYMMETRIC"]

#: Free DOFs below which `modes` solves the symmetric eigenproblem dense (LAPACK ``eigh``); at and
#: above, sparse shift-invert Lanczos (``eigsh``). The two break even between 204 and 300
#: free DOFs (a 3D cantilever, 6 modes: BENCHMARKS.md, Timings moved from docstrings).
DENSE_BELOW = 250
#: The same for a non-symmetric tangent (LAPACK ``eig``, all eigenvalues, against Arnoldi ``eigs``):
#: the two break even near 90 free DOFs (the Table 1 pivot at 75 deg).
DENSE_BELOW_NONSYMMETRIC = 90



def start_vector(n: int) -> np.ndarray:
    """ARPACK's start vector (n,): fixed pseudo-random (seed 0), so that repeated `modes` and
    `flexmb.buckling` calls on one solution give the same numbers. With ARPACK's own random
    start, the conventional manipulator's buckling multipliers with ``held="fixed"`` scattered by
    2e-4 relative between calls (four multipliers within 2e-5 of each other, split into complex
    pairs by the dead moments' non-symmetric tangent part: ARPACK returned any of them)."""
    return np.random.default_rng(0).standard_normal(n)


def _read_only(a) -> np.ndarray:
    """A read-only copy of ``a``, its dtype kept (a `Modes` is a result: no caller changes it)."""
    out = np.array(a)
    out.flags.writeable = False
    return out


@attrs.frozen(eq=False)
class Modes:
    """Vibration modes of a configuration (`modes`); its arrays are read-only copies.

    Attributes
    ----------
    frequencies
        Natural frequencies [Hz], ascending, shape (n,): ``sqrt(eigenvalue) / (2 pi)``; a negative
        entry is ``-sqrt(-eigenvalue) / (2 pi)``, an unstable direction of the equilibrium.
    eigenvalues
        ``omega^2`` [rad^2/s^2], shape (n,) (the real parts for a non-symmetric problem).
    shapes
        Mass-normalised mode shapes per FE node (n, nodes, ndof): ``phi^T M phi = 1``; columns are
        ``[dx, dy, dtheta]`` (2D) or ``[dx, dy, dz, spin_x, spin_y, spin_z]`` (3D), global axes;
        held DOFs are 0. The largest component of each shape is positive. (A KSD-reduced
        solution's are recovered on the joints' internal nodes when first read: ``modes``
        itself reads none of the joints' interior tables.)
    link_shapes
        The shapes of the links' reference points, ``{link: (n, ndof)}``.
    held
        Global DOF indices held, sorted.
    symmetric
        Whether the problem was solved as symmetric (no dead moment on a free rotation).
    solver
        ``"dense"`` or ``"sparse"``.
    solution
        The equilibrium linearised (`flexmb.plot.plot_mode` and `flexmb.export.write_mode` draw
        and write the shapes about it), or None.
    """

    frequencies: np.ndarray = attrs.field(converter=_read_only)
    eigenvalues: np.ndarray = attrs.field(converter=_read_only)
    _shapes: np.ndarray = attrs.field(converter=lambda a: a if callable(a) else _read_only(a), repr=False)
    _link_shapes: dict = attrs.field(converter=lambda d: d if callable(d) else {k: _read_only(a) for k, a in d.items()},
                                     repr=False)
    held: np.ndarray = attrs.field(converter=_read_only)
    symmetric: bool
    solver: str
    solution: object = attrs.field(default=None, repr=False)

    @property
    def link_shapes(self) -> dict:
        """The links' shapes (see the class notes), built on first use where deferred."""
        if callable(self._link_shapes):
            object.__setattr__(self, "_link_shapes", {k: _read_only(a) for k, a in self._link_shapes().items()})
        return self._link_shapes

    @property
    def shapes(self) -> np.ndarray:
        """The mode shapes per node (see the class notes), built on first use where deferred."""
        if callable(self._shapes):
            object.__setattr__(self, "_shapes", _read_only(self._shapes()))
        return self._shapes

    def __reduce__(self):  # pickled with its shapes built (a deferred recovery is a closure)
        return Modes, (self.frequencies, self.eigenvalues, self.shapes, self.link_shapes, self.held, self.symmetric,
                       self.solver, self.solution)


def _dof_name(compiled, dof: int) -> str:
    model = compiled.problem.model
    node, comp = divmod(int(dof), model.ndof)
    names = ("x", "y", "rotation") if model.dim == 2 else ("x", "y", "z", "rx", "ry", "rz")
    for link, n in compiled.link_node.items():
        if n == node:
            return f"link {link!r} {names[comp]}"
    for joint, nodes in compiled.joint_nodes.items():
        if node in set(np.asarray(nodes).tolist()):
            return f"joint {joint!r} internal node {node} {names[comp]}"
    return f"node {node} {names[comp]}"


_PLAUSIBLE_MASS = weakref.WeakKeyDictionary()  # models whose density fits E and the lengths (check_mass_units)


def modes(solution, n_modes: int = 6, held="prescribed", *, n: int | None = None) -> Modes:
    """The ``n_modes`` lowest undamped natural frequencies [Hz] and mass-normalised mode shapes of a
    converged equilibrium, linearised as the module notes state (dead loads, mass at the deformed
    state; ``held`` as there), on the solution's own linearisation (`flexmb.Solution.linearisation`
    with its mass-carrying coordinates): the full finite-element model's (``method="conventional"``,
    ``"ksd-full"``, a path's points) or a solution kind's own.

    A KSD-reduced solution gives the reduced mechanism's modes
    (`flexmb.ksd.linearisation.ReducedLinearisation`): the links' DOFs with the reduced
    equilibrium's tangent, each joint's mass condensed with its EOB's Craig-Bampton transformation
    (constraint modes plus `KSD_FIXED_INTERFACE_MODES` fixed-interface modes), shapes recovered on
    every node when first read. Measured against the full model: the manipulator's first three
    parasitic frequencies over +-45 deg within 0.55 % (median 0.13 %), the four-bar's 0.46 % at
    d = 0.1 m (6.8 % at 0.3 m). A small dense linearisation's eigenvalues are solved alone and
    its vectors when ``shapes`` or ``link_shapes`` is first read.

    Dense LAPACK below `DENSE_BELOW` coordinates (`DENSE_BELOW_NONSYMMETRIC` for a non-symmetric
    tangent), sparse shift-invert (``scipy.sparse.linalg.eigsh``, or ``eigs``) above. Raises
    `ConvergenceError` for an unconverged solution, `ParameterError` for ``n_modes`` outside [1,
    free motions] (all of them: dense), `ModelError` for a mechanism with no free motion (all held)
    or naming a free DOF without mass. ``n``: the deprecated name of ``n_modes`` (a FutureWarning).
    """
    n = renamed_keyword("modes", "n", n, "n_modes", n_modes, 6)
    lin = linearise(solution, held, modal=True, owner="modes")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"modes: n_modes={n!r} must be an integer in [1, the number of free motions]")
    compiled, model = solution.compiled, lin.model
    K, M, Z, free = lin.K, lin.M, lin.Z, lin.free
    _check_mass_units(solution, model)
    nf = K.shape[0]
    what = "free DOFs" if Z is None else "motions the hinges allow"
    if nf == 0:
        raise ModelError(f"modes: no free motion to vibrate: every DOF is held or fixed (held={held!r}; the "
                         "default 'prescribed' holds the prescribed motions: held='fixed' releases them)")
    if n > nf:
        raise ParameterError(f"modes: n_modes={n!r} must be an integer in [1, {nf}] (the {what}: {nf})")
    _check_massive(M, Z, compiled, free)
    asym = abs(K - K.T).max()
    tol = max(10.0 * solution.tolerance, 1e-11 * abs(K).max())
    symmetric = bool(asym <= tol)
    dense = nf < (DENSE_BELOW if symmetric else DENSE_BELOW_NONSYMMETRIC) or n >= nf - 1  # ARPACK: n < nf - 1
    lam = _dense_eigenvalues(K, M, n) if lin.dense and dense and symmetric else None
    nd = model.ndof
    if lam is not None:  # the vectors (shapes, link shapes) solved when first read
        vectors = functools.lru_cache(maxsize=None)(lambda: _normalised(_dense(K, M, n, True)[1], M, Z, free, n,
                                                                        lin.size))
        shapes = lambda: _node_shapes(lin.expand(vectors().T).T, model, n)  # noqa: E731
        link_shapes = lambda: _link_rows(vectors(), compiled, nd)  # noqa: E731
        freq = np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)
        return Modes(freq, lam, shapes, link_shapes, lin.held, symmetric, "dense", solution)
    if dense:
        lam, vec = _dense(*(A.toarray() if sp.issparse(A) else A for A in (K, M)), n, symmetric)
        solver = "dense"
    else:
        lam, vec = _sparse(sp.csr_array(K), sp.csr_array(M), n, symmetric)
        solver = "sparse"
    full = _normalised(vec, M, Z, free, n, lin.size)
    freq = np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)
    link_shapes = _link_rows(full, compiled, nd)
    if lin.size == model.n_dofs:  # the generalised DOFs are the model's: the shapes as they are
        shapes = _node_shapes(full, model, n)
    else:  # a reduced model's: the interiors recovered when the shapes are first read
        def shapes():
            return _node_shapes(lin.expand(full.T).T, model, n)
    return Modes(freq, lam, shapes, link_shapes, lin.held, symmetric, solver, solution)


def _node_shapes(full, model, n):
    """Shapes on the model's DOFs (n, n_dofs) per node (n, nodes, ndof) (hinge multipliers out)."""
    nd = model.ndof
    return full[:, :model.n_nodes * nd].reshape(n, model.n_nodes, nd)


def _check_mass_units(solution, model) -> None:
    """`flexmb.plausibility.check_mass_units` once per model that passes it (warned: each call)."""
    if len(model.elements.L0) and model not in _PLAUSIBLE_MASS:
        with warnings.catch_warnings(record=True) as caught:  # a model's sections are checked once
            warnings.simplefilter("always")
            check_mass_units(solution, model, stacklevel=4)
        if caught:  # warned: again, as the caller's filters take it (each call)
            check_mass_units(solution, model, stacklevel=4)
        else:
            _PLAUSIBLE_MASS[model] = True


def _check_massive(M, Z, compiled, free) -> None:
    """`ModelError` naming the free directions (or hinge motions) that carry no mass."""
    nf = M.shape[0]
    dM = M.diagonal()
    scale = float(dM.max(initial=0.0))
    massive = dM > 1e-14 * scale
    massless = np.flatnonzero(~massive) if scale > 0 and not massive.all() else \
        np.zeros(0, dtype=np.int64) if scale > 0 else np.arange(nf)
    if len(massless) and Z is not None:
        raise ModelError(f"modes: {len(massless)} of the motions the hinges allow carry no mass; give the links "
                         "mass (add_link(..., mass=, inertia=)) or the joints (their sections) density, or hold them (held=...)")
    if len(massless):
        listed = ", ".join(_dof_name(compiled, free[i]) for i in massless[:6])
        raise ModelError(f"modes: {len(massless)} free direction(s) carry no mass: {listed}"
                         f"{' ...' if len(massless) > 6 else ''}; give the links mass (add_link(..., mass=, "
                         "inertia=)) or the joints (their sections) density, or hold those DOFs (held=...)")


def _normalised(vec, M, Z, free, n, size):
    """Eigenvectors on the coordinates (nf, n) -> mass-normalised (eigh's are already), on all
    ``size`` generalised DOFs (n, size) through ``Z`` (the coordinates' basis), held ones 0, the
    largest component on the DOFs positive (after ``Z``: the convention does not depend on the
    basis)."""
    norm = np.sqrt(np.einsum("ik,ik->k", vec, M @ vec))
    vec = vec / norm
    if Z is not None:
        vec = Z @ vec
    big = np.argmax(np.abs(vec), axis=0)
    vec = vec * np.sign(vec[big, np.arange(vec.shape[1])])
    full = np.zeros((n, size))
    full[:, free] = vec.T
    return full


def _link_rows(full, compiled, nd):
    """The links' reference points' rows of shapes ``full`` (n, DOFs): their nodes' DOFs (which
    lead a KSD-reduced vector as they do the full one, `flexmb.ksd.reduced_model`)."""
    return {link: full[:, node * nd:(node + 1) * nd].copy() for link, node in compiled.link_node.items()}


def _dense_eigenvalues(K, M, n):
    """`_dense`'s eigenvalues alone for a symmetric problem (LAPACK without the vectors; the same
    to ~1e-15), the same mass check;
    None where it would fall back to the direct form (an unstable equilibrium)."""
    _definite_mass(M)
    sigma = _shift(K, M)
    Ks = K - sigma * M
    try:
        mu = _highest_pairs(M, 0.5 * (Ks + Ks.T), n, vectors=False)[0]
    except np.linalg.LinAlgError:
        return None
    return sigma + 1.0 / mu[::-1]


def _definite_mass(M) -> None:
    """Raise `ModelError` unless the dense ``M`` is positive definite (LAPACK ``dpotrf``: np.linalg.cholesky's
    test without its overhead)."""
    if _lapack.dpotrf(M, lower=1, clean=0)[1] != 0:
        raise ModelError("modes: the mass matrix on the free DOFs is singular (a combination of free directions "
                         "carries no mass); hold it or give the parts mass")


def _dense(K, M, n, symmetric):
    _definite_mass(M)
    # Inverted (shift-invert) form M x = mu (K - sigma M) x, lambda = sigma + 1/mu: the lowest
    # modes come out with *relative* accuracy. On K x = lambda M x directly LAPACK's error is
    # eps * lambda_max, and a leaf's axial/bending stiffness ratio (12 L^2/t^2 per element) makes
    # lambda_max/lambda_1 ~ 1e12: measured 1e-5 noise on a cantilever's first frequency at L/t = 1e4.
    sigma = _shift(K, M)
    Ks = K - sigma * M
    if symmetric:
        try:
            mu, vec = _highest_pairs(M, 0.5 * (Ks + Ks.T), n)
        except np.linalg.LinAlgError:  # K - sigma M indefinite: an unstable equilibrium; direct form
            return sla.eigh(0.5 * (K + K.T), M, subset_by_index=[0, n - 1])
        return sigma + 1.0 / mu[::-1], vec[:, ::-1]
    mu, vec = sla.eig(M, Ks)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = sigma + 1.0 / mu
    lam = np.where(np.isfinite(lam), lam, np.inf)
    order = np.argsort(lam.real)[:n]
    return lam.real[order], _real(vec[:, order])


@functools.lru_cache(maxsize=64)
def _sygvx_lwork(nf: int) -> int:
    """LAPACK's optimal work size of ``dsygvx`` for order ``nf`` (queried once per order)."""
    return int(_lapack.dsygvx_lwork(nf, uplo="L")[0])


def _highest_pairs(A, B, n, vectors: bool = True):
    """The ``n`` highest eigenpairs of ``A x = mu B x`` (``B`` definite): what
    ``scipy.linalg.eigh(A, B, subset_by_index=[nf - n, nf - 1])`` returns, by the same LAPACK
    ``dsygvx`` called directly (without scipy's checks). Raises `numpy.linalg.LinAlgError` where eigh would."""
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise ValueError("array must not contain infs or NaNs")
    nf = len(A)
    lwork = _sygvx_lwork(nf)
    mu, vec, m, _, info = _lapack.dsygvx(A, B, itype=1, jobz="V" if vectors else "N", range="I", il=nf - n + 1,
                                         iu=nf, uplo="L", lwork=lwork)
    if info != 0:  # B not definite (info > nf) or not converged
        raise np.linalg.LinAlgError(f"dsygvx info={info}")
    return mu[:m], vec[:, :m]


def _shift(K, M) -> float:
    """A shift just below zero, ``-1e-10 max|K| / max M_ii``: K - sigma M is definite for a stable
    equilibrium (rigid-body zero modes included) and the lowest modes keep relative accuracy."""
    return -1e-10 * float(abs(K).max() / M.diagonal().max())


def _real(vec):
    """Real vectors from complex eigenvectors of real eigenvalues (any complex phase removed)."""
    big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
    return (vec * (np.abs(big) / big)).real


def _sparse(K, M, n, symmetric):
    # shift below the spectrum (K + s M is then definite for a stable equilibrium; zero modes allowed)
    sigma = _shift(K, M)
    if symmetric:
        lam, vec = spla.eigsh(0.5 * (K + K.T).tocsc(), k=n, M=M.tocsc(), sigma=sigma, which="LM",
                              v0=start_vector(K.shape[0]))
    else:
        lam, vec = spla.eigs(K.tocsc(), k=n, M=M.tocsc(), sigma=sigma, which="LM", v0=start_vector(K.shape[0]))
        lam, vec = lam.real, _real(vec)
    order = np.argsort(lam)
    return lam[order], vec[:, order]
