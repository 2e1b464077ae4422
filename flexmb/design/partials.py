"""Partial derivatives of the finite-element residual, tangent and mass with respect to the model's
numbers and the state, by complex step through the element kernels.

``f(x + i h dx) = f(x) + i h f'(x) dx + O(h^2)``: with ``h = 1e-30`` the imaginary part divided by
``h`` is the directional derivative to round-off, without the cancellation of a difference (Squire
& Trapp 1998; Martins, Sturdza & Alonso 2003). With the numba kernels on (`flexmb.jit`) the beams'
rows run compiled (`flexmb.fe.beam_step_jit`: the moved ends, the element, the levers in one pass per
row; the float kernels stay float64); otherwise the numpy twins of the beam kernels
(`flexmb.fe.beam2d`, `flexmb.fe.beam3d`, `flexmb.fe.mass`) carry the complex numbers (no modulus,
no comparison on the perturbed values). Both give the same numbers. A direction is evaluated only
on the elements and load rows it changes, and all directions in one batched kernel call.

Directions: ``rates`` holds ``d(field)/dp_k`` of `flexmb.design.parameters.MODEL_FIELDS` (K, ...);
state directions ``du`` (n_dofs, K) are increments in the model's DOFs (translations, 2D angles,
3D spatial spins ``dR = skew(dphi) R``).
"""

from __future__ import annotations

import numpy as np

from .. import jit
from ..fe import beam2d, beam3d
from ..rotations import rot2, skew

__all__ = ["H", "residual_rates", "tangent_blocks", "mass_blocks", "contract", "tangent_forms", "mass_forms"]

#: The complex step: far below the round-off of any model number, far above underflow.
H = 1e-30


def _changed(rate: np.ndarray) -> np.ndarray:
    """(K, n) whether row n of a field (rows (n, ...)) changes with parameter k."""
    if rate.ndim < 2 or rate.shape[1] == 0:  # an empty field (no loads, no rigid masses)
        return np.zeros((rate.shape[0], rate.shape[1] if rate.ndim > 1 else 0), dtype=bool)
    return np.any(rate.reshape(rate.shape[0], rate.shape[1], -1) != 0.0, axis=2)


def _element_rows(model, rates, du) -> tuple[np.ndarray, np.ndarray]:
    """The (direction, element) pairs a direction changes: element data, an end's offset, or (with
    ``du``) the motion of an end's master node."""
    return np.nonzero(_element_hits(model, rates, du))


def _element_hits(model, rates, du) -> np.ndarray:
    """(K, E) whether direction k changes element e (`_element_rows`)."""
    el = model.elements
    K = rates.rate("L0").shape[0]
    hit = _kept(rates, "element hits", lambda: _number_hits(model, rates)).copy()
    if du is not None:
        moving = np.any(du[: model.n_node_dofs].T.reshape(K, model.n_nodes, model.ndof) != 0.0, axis=2)
        masters = model.point_master[el.ends]
        hit |= moving[:, masters[:, 0]] | moving[:, masters[:, 1]]
    return hit


def _number_hits(model, rates) -> np.ndarray:
    """(K, E) whether parameter k changes element e's numbers or an end's offset."""
    el = model.elements
    hit = np.zeros((rates.rate("L0").shape[0], len(el.L0)), dtype=bool)
    for field in ("L0", "S", "ny0", "nz0", "alpha0"):
        r = rates.rate(field)
        if r.size:
            hit |= _changed(r)
    offset = _changed(rates.rate("point_offset"))  # (K, P)
    return hit | offset[:, el.ends[:, 0]] | offset[:, el.ends[:, 1]]


def _kept(rates, key: str, compute):
    """``compute()`` kept in the design's shared cache of ``rates`` (`ModelRates.shared`: what does not
    depend on the configuration), or computed where the rates have none."""
    shared = getattr(rates, "shared", None)
    if shared is None:
        return compute()
    if key not in shared:
        shared[key] = compute()
    return shared[key]


def _complex(value: np.ndarray, rate: np.ndarray | None) -> np.ndarray:
    return value.astype(complex) if rate is None else value + (1j * H) * rate


def _node_state(model, state, nodes, du_rows):
    """Positions (R, dim) and rotations (R, 2, 2) / (R, 3, 3) of ``nodes``, moved by ``i H du_rows``
    (R, ndof) (None: not moved)."""
    x = state.positions[nodes].astype(complex)
    R = model.rotation_matrices(state)[nodes].astype(complex)
    if du_rows is None:
        return x, R
    x = x + (1j * H) * du_rows[:, : model.dim]
    if model.dim == 2:
        return x, rot2(state.rotations[nodes] + (1j * H) * du_rows[:, 2])
    return x, R + (1j * H) * (skew(du_rows[:, 3:]) @ R)  # exp(i H skew(w)) R to first order


def _lever(d: np.ndarray, ndof: int) -> np.ndarray:
    """Blocks T (R, ndof, ndof), ``dq_point = T dq_master``, for complex offsets ``d`` (`FEModel._lever`)."""
    T = np.tile(np.eye(ndof, dtype=complex), (len(d), 1, 1))
    if ndof == 3:
        T[:, 0, 2], T[:, 1, 2] = -d[:, 1], d[:, 0]
    else:
        T[:, 0:3, 3:6] = -skew(d)
    return T


def _elements(model, state, rates, cols, rows, du, tangent: bool, material: bool = False, du_end=None,
              stresses: bool = False, keep: dict | None = None):
    """Complex element forces (and tangents) in master DOFs of elements ``rows`` under directions
    ``cols`` (one pair per batch row) of the model numbers' ``rates`` (None: the numbers held) and
    of the state ``du`` (n_dofs, K), or ``du_end`` ((B, ndof) per end) given per row. ``stresses``:
    the complex deformations, generalised stresses and lengths ``(e, sigma, L0)`` instead; ``keep``: a
    dict that receives them beside the forces (``"e"``, ``"sigma"``, ``"L0"``)."""
    el, dim, nd = model.elements, model.dim, model.ndof
    masters = model.point_master[el.ends[rows]]  # (B, 2)
    if du_end is None and jit.enabled():
        return _compiled_rows(model, state, rates, cols, rows, du, tangent, material, stresses, keep)
    if du_end is None:
        du_end = [None, None]
        if du is not None:
            nodal = du[: model.n_node_dofs].reshape(model.n_nodes, nd, -1)
            du_end = [nodal[masters[:, i], :, cols] for i in range(2)]
    ends = []
    for i in range(2):
        pts = el.ends[rows, i]
        x, R = _node_state(model, state, masters[:, i], du_end[i])
        s = _complex(model.point_offset[pts], None if rates is None else rates.rate("point_offset")[cols, pts])
        d = np.einsum("bij,bj->bi", R, s)
        ends.append((x + d, R, d))
    geometric = np.zeros_like if material else None
    data = {}
    for field in ("L0", "S", "ny0", "nz0", "alpha0"):
        value = getattr(el, field)
        if value is not None:
            moved = rates is not None and rates.rate(field).size
            data[field] = _complex(np.asarray(value, dtype=float)[rows], rates.rate(field)[cols, rows] if moved else None)
    if dim == 2:
        # the nodes' angles themselves (their rotation matrices would lose the turn count)
        th = [_complex(state.rotations[masters[:, i]], None if du_end[i] is None else du_end[i][:, 2]) for i in range(2)]
        F, K, e, sig = beam2d.numpy_internal_force_and_tangent(ends[0][0], ends[1][0], th[0], th[1], data["alpha0"],
                                                               data["L0"], data["S"], tangent=tangent,
                                                               geometric_stress=geometric)
    else:
        F, K, e, sig = beam3d.numpy_internal_force_and_tangent(ends[0][0], ends[1][0], ends[0][1], ends[1][1],
                                                               data["ny0"], data["nz0"], data["L0"], data["S"],
                                                               tangent=tangent, geometric_stress=geometric)
    if keep is not None:
        keep.update(e=e, sigma=sig, L0=data["L0"])
    if stresses:
        return e, sig, data["L0"]
    d = np.stack([ends[0][2], ends[1][2]], axis=1).reshape(-1, dim)
    Fm, G = model.transfer(F.reshape(-1, nd), d)
    Fm = Fm.reshape(len(rows), 2 * nd)
    if not tangent:
        return Fm, None
    Tb = _lever(d, nd).reshape(len(rows), 2, nd, nd)
    T = np.zeros((len(rows), 2 * nd, 2 * nd), dtype=complex)
    T[:, :nd, :nd], T[:, nd:, nd:] = Tb[:, 0], Tb[:, 1]
    K = np.swapaxes(T, 1, 2) @ K @ T
    if material:
        return Fm, K
    G = G.reshape(len(rows), 2, nd - dim, nd - dim)
    K[:, dim:nd, dim:nd] += G[:, 0]
    K[:, nd + dim:, nd + dim:] += G[:, 1]
    return Fm, K


def _rate_rows(rates, field: str, cols, index, shape) -> np.ndarray:
    """The rates of ``field`` at ``index`` per batch row (zeros where the field does not move)."""
    r = None if rates is None else rates.rate(field)
    if r is None or not r.size:
        return np.zeros(shape)
    return r[(cols,) + index] if isinstance(index, tuple) else r[cols, index]


def _compiled_rows(model, state, rates, cols, rows, du, tangent: bool, material: bool, stresses: bool,
                   keep: dict | None = None):
    """`_elements` by the compiled rows of `flexmb.fe.beam_step_jit` (one pass per row: the complex
    state, offsets, element, levers): the same numbers as the numpy path."""
    from ..fe import beam_step_jit

    el, dim, nd = model.elements, model.dim, model.ndof
    ends = el.ends[rows]
    masters = model.point_master[ends]  # (B, 2)
    B = len(rows)
    if du is None:
        du_end = np.zeros((B, 2, nd))
    else:
        nodal = du[: model.n_node_dofs].reshape(model.n_nodes, nd, -1)
        du_end = np.stack([nodal[masters[:, i], :, cols] for i in range(2)], axis=1)
    s = model.point_offset[ends]
    ds = _rate_rows(rates, "point_offset", cols[:, None], ends, s.shape)
    L0, S = el.L0[rows], el.S[rows]
    data = [L0, _rate_rows(rates, "L0", cols, rows, L0.shape), S, _rate_rows(rates, "S", cols, rows, S.shape)]
    x = state.positions[masters]
    if dim == 2:
        a0 = np.asarray(el.alpha0, dtype=float)[rows]
        F, K, e, sig = beam_step_jit.rows_2d(x, state.rotations[masters], du_end, s, ds, a0,
                                             _rate_rows(rates, "alpha0", cols, rows, a0.shape), *data, H, tangent,
                                             material)
    else:
        frames = []
        for field in ("ny0", "nz0"):
            v = np.asarray(getattr(el, field), dtype=float)[rows]
            frames += [v, _rate_rows(rates, field, cols, rows, v.shape)]
        F, K, e, sig = beam_step_jit.rows_3d(x, state.rotations[masters], du_end, s, ds, *frames, *data, H, tangent,
                                             material)
    if keep is not None:
        keep.update(e=e, sigma=sig, L0=_complex(L0, data[1]))
    if stresses:
        return e, sig, _complex(L0, data[1])
    return F, K


def _load_rows(problem, rates, du):
    loads = problem.loads
    K = rates.rate("L0").shape[0]
    hit = np.zeros((K, len(loads.node)), dtype=bool)
    for field in ("load_offset", "load_force", "load_moment"):
        hit |= _changed(rates.rate(field))
    if du is not None and len(loads.node):
        m = problem.model
        moving = np.any(du[: m.n_node_dofs].T.reshape(K, m.n_nodes, m.ndof)[:, :, m.dim:] != 0.0, axis=2)
        hit |= moving[:, loads.node]
    return np.nonzero(hit)


def _loads(problem, state, rates, cols, rows, du, lam: float):
    """Complex master wrenches and load-stiffness blocks of load ``rows`` under directions ``cols``."""
    m, loads = problem.model, problem.loads
    du_rows = None
    if du is not None:
        du_rows = du[: m.n_node_dofs].reshape(m.n_nodes, m.ndof, -1)[loads.node[rows], :, cols]
    _, R = _node_state(m, state, loads.node[rows], du_rows)
    d = np.einsum("bij,bj->bi", R, _complex(loads.offset[rows], rates.rate("load_offset")[cols, rows]))
    force = _complex(loads.force[rows], rates.rate("load_force")[cols, rows])
    moment = _complex(loads.moment[rows], rates.rate("load_moment")[cols, rows])
    w0 = problem._wrench0[rows]
    wrench = w0 + lam * (np.concatenate([force, moment], axis=1) - w0)
    return m.transfer(wrench, d)


def residual_rates(problem, state, rates, du: np.ndarray | None = None, lam: float = 1.0,
                   keep: dict | None = None) -> np.ndarray:
    """``dr/dp_k`` (n_dofs, K) of the residual ``f_int - lam f_ext`` on all DOFs at ``state`` held
    fixed, through the model numbers' ``rates`` (and, with ``du`` (n_dofs, K), along the state's
    directions too). ``keep``: a dict that receives the element rows' directions and elements
    (``"cols"``, ``"rows"``) and their complex deformations, stresses and lengths (`_elements`)."""
    m = problem.model
    K = rates.rate("L0").shape[0]
    out = np.zeros((m.n_dofs, K))
    cols, rows = _element_rows(m, rates, du)
    if keep is not None:
        keep.update(cols=cols, rows=rows)
    if len(rows):
        Fm, _ = _elements(m, state, rates, cols, rows, du, tangent=False, keep=keep)
        np.add.at(out, (m.element_dofs[rows], cols[:, None]), Fm.imag / H)
    cols, rows = _load_rows(problem, rates, du)
    if len(rows):
        w, _ = _loads(problem, state, rates, cols, rows, du, lam)
        np.add.at(out, (m.node_dofs[problem.loads.node[rows]], cols[:, None]), -w.imag / H)
    return out


def tangent_blocks(problem, state, rates, du: np.ndarray, lam: float = 1.0, material: bool = False) -> list:
    """The directional derivatives ``dK_k`` of the full tangent on all DOFs (elements and dead loads'
    stiffness, as `flexmb.modal.full_tangent`) along the model numbers' ``rates`` and the state
    directions ``du`` (n_dofs, K), as element blocks: ``[(directions (B,), DOFs (B, n), blocks (B, n,
    n)), ...]`` (`contract` forms ``V^T dK_k W`` from them). ``material``: of the material tangent
    instead (`flexmb.linearised.material_tangent`: no stresses' geometric part, no offsets'
    ``d(d x f)/dphi``, no load stiffness)."""
    m = problem.model
    parts = []
    cols, rows = _element_rows(m, rates, du)
    if len(rows):
        _, Ke = _elements(m, state, rates, cols, rows, du, tangent=True, material=material)
        parts.append((cols, m.element_dofs[rows], Ke.imag / H))
    if material:  # the material tangent has no load stiffness
        return parts
    cols, rows = _load_rows(problem, rates, du)
    if len(rows):
        _, G = _loads(problem, state, rates, cols, rows, du, lam)
        parts.append((cols, m.node_dofs[problem.loads.node[rows]][:, m.dim:], -G.imag / H))
    return parts


def contract(parts: list, K: int, V: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``V^T dA_k W`` (K, a, b) from the element blocks ``parts`` of `tangent_blocks` / `mass_blocks`
    (``V`` (n_dofs, a), ``W`` (n_dofs, b); the identity gives ``dA_k`` itself): no matrix of the
    model's size is formed."""
    out = np.zeros((K, V.shape[1], W.shape[1]))
    for cols, dofs, blocks in parts:
        _contract(out, cols, dofs, blocks, V, W)
    return out


def tangent_forms(problem, state, rates, du: np.ndarray, V: np.ndarray, W: np.ndarray, lam: float = 1.0,
                  material: bool = False) -> np.ndarray:
    """``V^T dK_k W`` (K, a, b) (`tangent_blocks` contracted)."""
    return contract(tangent_blocks(problem, state, rates, du, lam, material), du.shape[1], V, W)


class _RowModel:
    """A model whose every batch row is an element (or a rigid body) on nodes of its own, complex:
    what `flexmb.fe.mass` reads of a model (``dim``, ``ndof``, ``elements``, ``point_master``,
    ``point_offset``, ``offsets``, ``_lever``), so one call evaluates all (direction, row) pairs."""

    def __init__(self, dim: int, offsets: np.ndarray, elements=None):
        self.dim, self.ndof = dim, 3 if dim == 2 else 6
        self.point_offset = offsets  # (P, dim) complex, point p on node p
        self.point_master = np.arange(len(offsets))
        self.elements = elements

    def rotation_matrices(self, state):
        return rot2(state.rotations) if self.dim == 2 else state.rotations

    def offsets(self, state, master, offset0):
        return np.einsum("kij,kj->ki", self.rotation_matrices(state)[master], offset0)

    def _lever(self, d):
        return _lever(d, self.ndof)


def _row_state(model, state, nodes, du_rows):
    """A complex `State` of the row nodes ``nodes`` moved by ``i H du_rows`` (None: not moved)."""
    from ..fe.model import State

    x, R = _node_state(model, state, nodes, du_rows)
    if model.dim == 2:
        rot = _complex(state.rotations[nodes], None if du_rows is None else du_rows[:, 2])
        return State(x, rot)
    return State(x, R)


def mass_forms(problem, state, rates, du: np.ndarray, V: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``V^T dM_k W`` (K, a, b) (`mass_blocks` contracted; with the compiled kernels the beams' rows
    give their forms directly, `flexmb.fe.beam_step_jit.mass_rows_3d`, no block formed)."""
    K = du.shape[1]
    if not jit.enabled():
        return contract(mass_blocks(problem, state, rates, du), K, V, W)
    m = problem.model
    out = contract(mass_blocks(problem, state, rates, du, elements=False), K, V, W)
    cols, rows = _mass_rows(m, rates, du)
    if len(rows):
        dofs = m.element_dofs[rows]
        nodal = du[: m.n_node_dofs].reshape(m.n_nodes, m.ndof, -1)
        _sum_rows(out, cols, _compiled_mass_rows(m, state, rates, cols, rows, nodal, V[dofs], W[dofs]))
    return out


def _mass_rows(model, rates, du):
    """The (direction, element) pairs whose mass a direction changes (local mass, `_element_hits`)."""
    return np.nonzero(_kept(rates, "local mass hits", lambda: _changed(rates.rate("local_mass")))
                      | _element_hits(model, rates, du))


def mass_blocks(problem, state, rates, du: np.ndarray, elements: bool = True) -> list:
    """The directional derivatives ``dM_k`` of the consistent mass at the configuration
    (`flexmb.fe.mass.mass_matrix`: beams in their co-rotated frames, the links' rigid bodies) along
    the model numbers' ``rates`` (local mass, offsets, frames, rigid masses) and the state's
    directions ``du`` (n_dofs, K), as element blocks (`tangent_blocks`); ``elements=False``: the
    rigid bodies' alone."""
    import attrs

    from ..fe.mass import RigidMasses, element_mass, rigid_mass

    m = problem.model
    K, nd = du.shape[1], m.ndof
    out = []
    el = m.elements
    cols, rows = _mass_rows(m, rates, du) if elements else (np.zeros(0, dtype=int), np.zeros(0, dtype=int))
    nodal = du[: m.n_node_dofs].reshape(m.n_nodes, nd, -1)
    if len(rows) and jit.enabled():
        out.append((cols, m.element_dofs[rows], _compiled_mass_rows(m, state, rates, cols, rows, nodal)))
    elif len(rows):
        ends = el.ends[rows]  # (B, 2) points
        masters = m.point_master[ends]
        off = _complex(m.point_offset[ends], rates.rate("point_offset")[cols[:, None], ends])
        ny0 = None if el.ny0 is None else _complex(el.ny0[rows], rates.rate("ny0")[cols, rows])
        view = _RowModel(m.dim, off.reshape(-1, m.dim),
                         attrs.evolve(el, ends=np.arange(2 * len(rows)).reshape(-1, 2), ny0=ny0, L0=el.L0[rows]))
        st = _row_state(m, state, masters.ravel(), nodal[masters.ravel(), :, np.repeat(cols, 2)])
        local = _complex(rates.compiled_numbers("local_mass")[rows], rates.rate("local_mass")[cols, rows])
        out.append((cols, m.element_dofs[rows], element_mass(view, st, local).imag / H))
    rigid = m.rigid_masses
    if rigid is not None and len(rigid.node):
        hit = np.zeros((K, len(rigid.node)), dtype=bool)
        for f in ("rigid_mass", "rigid_inertia", "rigid_offset"):
            hit |= _changed(rates.rate(f))
        hit |= np.any(du[: m.n_node_dofs].T.reshape(K, m.n_nodes, nd)[:, rigid.node] != 0.0, axis=2)
        cols, rows = np.nonzero(hit)
        if len(rows):
            body = RigidMasses(np.arange(len(rows)), _complex(rigid.offset[rows], rates.rate("rigid_offset")[cols, rows]),
                               _complex(rigid.mass[rows], rates.rate("rigid_mass")[cols, rows]),
                               _complex(rigid.inertia[rows], rates.rate("rigid_inertia")[cols, rows]))
            st = _row_state(m, state, rigid.node[rows], nodal[rigid.node[rows], :, cols])
            Mr = rigid_mass(_RowModel(m.dim, np.zeros((len(rows), m.dim), dtype=complex)), st, body).imag / H
            out.append((cols, m.node_dofs[rigid.node[rows]], Mr))
    return out


def _compiled_mass_rows(model, state, rates, cols, rows, nodal, V=None, W=None) -> np.ndarray:
    """`mass_blocks`' element rows (B, 2 ndof, 2 ndof) by `flexmb.fe.beam_step_jit` (the complex step's
    derivative: imaginary parts over `H`); with ``V``, ``W`` (B, 2 ndof, a / c) their forms (B, a, c)."""
    from ..fe import beam_step_jit

    el = model.elements
    ends = el.ends[rows]
    masters = model.point_master[ends]
    du_end = np.stack([nodal[masters[:, i], :, cols] for i in range(2)], axis=1)
    s = model.point_offset[ends]
    ds = _rate_rows(rates, "point_offset", cols[:, None], ends, s.shape)
    local = rates.compiled_numbers("local_mass")[rows]
    dlocal = _rate_rows(rates, "local_mass", cols, rows, local.shape)
    x = state.positions[masters]
    if model.dim == 2:
        M = beam_step_jit.mass_rows_2d(x, state.rotations[masters], du_end, s, ds, local, dlocal, H, V, W)
    else:
        ny0 = np.asarray(el.ny0, dtype=float)[rows]
        M = beam_step_jit.mass_rows_3d(x, state.rotations[masters], du_end, s, ds, ny0,
                                       _rate_rows(rates, "ny0", cols, rows, ny0.shape), local, dlocal, H, V, W)
    return M.imag / H


def _contract(out: np.ndarray, cols: np.ndarray, dofs: np.ndarray, blocks: np.ndarray, V, W) -> None:
    """``out[cols[b]] += V[dofs[b]]^T blocks[b] W[dofs[b]]`` for every row b (the rows summed per
    direction by one product with their indicator matrix)."""
    _sum_rows(out, cols, np.swapaxes(V[dofs], 1, 2) @ (blocks @ W[dofs]))


def _sum_rows(out: np.ndarray, cols: np.ndarray, rows: np.ndarray) -> None:
    """``out[cols[b]] += rows[b]`` (rows (B, a, c)) by one product with the rows' indicator matrix."""
    one = np.zeros((out.shape[0], len(cols)))
    one[cols, np.arange(len(cols))] = 1.0
    out += (one @ rows.reshape(len(cols), -1)).reshape(out.shape)
