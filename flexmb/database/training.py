"""Training a joint database (Dwarshuis et al. 2020, Secs. 2.1, 3.1, 4.1): the joint's own FE model,
node A fixed, node B turned about z over the intended range with zero reaction in the unintended
in-plane directions, then least-squares fits of the kinematics.

2D: B free in x, y. 3D: B free in x, y; its z displacement and tilts are held at zero, which the
symmetric three-leaf cross flexure needs no force for (the reactions are recorded and checked,
`TrainingRun.max_unintended_reaction`).
"""

from __future__ import annotations

import time

import attrs
import numpy as np

from ..errors import ConvergenceError, DatabaseError, ParameterError
from ..mechanism import Mechanism
from ..rotations import logm_so3
from .eob_format import plain_parameters
from .store import MAX_POWER, JointData, Polynomial, load, mesh_hash, save, shipped

__all__ = ["TrainingRun", "simulate", "train", "verify", "DEFAULT_RANGE_DEG", "ELEMENT_POWERS", "CONSTRAINT_POWERS",
           "TRAINING", "TRAINING_SCHEMA", "training_settings", "element_rotations"]

DEFAULT_RANGE_DEG = (-75.0, 75.0)
#: Element (and node) rotations as polynomials without constant term, Eq. (4.2) taken to fifth
#: order: over +-75 deg the paper's cubic leaves 3.2e-3 rad (3D cross flexure, 3 el./leaf), the
#: quintic 1.8e-4 rad.
ELEMENT_POWERS = (1, 2, 3, 4, 5)
#: Positions of B (over D0) as full sixth-order polynomials; D/D0 - 1 even (Eq. 4.1).
CONSTRAINT_POWERS = tuple(range(7))
LENGTH_POWERS = (2, 4, 6)
#: Default training settings; a joint overrides any of them in its ``training`` class attribute.
TRAINING = {"range_deg": DEFAULT_RANGE_DEG, "step_deg": 5.0, "element_powers": ELEMENT_POWERS,
            "constraint_powers": CONSTRAINT_POWERS, "length_powers": LENGTH_POWERS}
#: The schema of a joint's ``training`` settings (`training_settings` checks it; unknown keys are
#: refused): what each key holds, its unit and its valid range.
TRAINING_SCHEMA = {
    "range_deg": "(lo, hi): the intended rotations sampled [deg], -180 <= lo < hi <= 180",
    "step_deg": "the sampling step [deg], in (0, hi - lo]",
    "element_powers": "powers of the element and node rotation fits (Eq. 4.2), distinct integers in [1, 30] "
                      "(no constant: nothing turns at rest)",
    "constraint_powers": "powers of the fits of B's position over D0 (Eq. 4.1), distinct integers in [0, 30]",
    "length_powers": "powers of the fit of D/D0 - 1 (Eq. 4.1), distinct integers in [1, 30]",
}


@attrs.frozen(eq=False)
class TrainingRun:
    """Raw training results at the sampled intended rotations ``theta`` [rad] (S,)."""

    theta: np.ndarray
    b_position: np.ndarray  # (S, dim) position of node B in the joint frame [m]
    element_rotation: np.ndarray  # (S, E) 2D chord angles, (S, E, 3) 3D rotation vectors [rad]
    node_rotation: np.ndarray  # (S, N) 2D angles, (S, N, 3) 3D rotation vectors of the internal nodes [rad]
    moment: np.ndarray  # (S,) reaction moment about z on B [N m]
    max_unintended_reaction: float  # largest |reaction| in the held unintended DOFs (3D) [N, N m]
    wall_time: float


def simulate(joint, dim: int, theta) -> TrainingRun:
    """Solve the joint's FE model at every intended rotation ``theta`` [rad], each from rest."""
    from ..solvers import solve  # the solvers use the database: import at call time

    t0 = time.perf_counter()
    m = Mechanism(dim=dim)
    m.add_link("A", fixed=True)
    m.add_link("B", position=joint.interface_b(dim))
    m.add_joint("A", "B", joint, name="joint")
    out = []
    for a in np.asarray(theta, float):
        if dim == 2:
            m.prescribe("B", rotation=a)
        else:
            m.prescribe("B", z=0.0, rotation=(0.0, 0.0, a))
        try:
            sol = solve(m, raise_on_failure=True)
        except ConvergenceError as exc:
            raise DatabaseError(f"training {joint.kind}: the FE model did not converge at {np.degrees(a):.1f} deg: "
                                f"{exc}") from None
        model = sol.compiled.problem.model
        beta = element_rotations(model, sol.state)
        rot = sol.state.rotations[2:]
        node_rot = rot if dim == 2 else logm_so3(rot)
        reaction = sol.reaction("B")
        unintended = np.abs(reaction[[2, 3, 4]]).max() if dim == 3 else 0.0
        out.append((sol.pose("B")[0], beta, node_rot, reaction[-1], unintended))
    b, beta, nodes, moment, unintended = (np.array(x) for x in zip(*out))
    return TrainingRun(np.asarray(theta, float), b, beta, nodes, moment, float(unintended.max()),
                       time.perf_counter() - t0)


def element_rotations(model, state) -> np.ndarray:
    """Orientation of every element from rest (Eq. 3.1), (E,) chord angles [rad] in 2D; (E, 3)
    rotation vectors in 3D of the frame (chord, mean cross-section y axis of both ends made
    perpendicular to it, their cross product) relative to that frame at rest (Sec. 3.1)."""
    el = model.elements
    ends = el.ends
    pts = model.point_positions(state)
    c = pts[ends[:, 1]] - pts[ends[:, 0]]
    c0 = model.point_x0[ends[:, 1]] - model.point_x0[ends[:, 0]]
    if model.dim == 2:
        return np.arctan2(c0[:, 0] * c[:, 1] - c0[:, 1] * c[:, 0], np.einsum("ei,ei->e", c0, c))
    R = state.rotations[model.point_master[ends]]  # (E, 2, 3, 3)
    ex = c / np.linalg.norm(c, axis=1, keepdims=True)
    ny = np.einsum("ekij,ej->ei", R, el.ny0)
    ny -= np.einsum("ei,ei->e", ny, ex)[:, None] * ex
    ny /= np.linalg.norm(ny, axis=1, keepdims=True)
    frame = np.stack([ex, ny, np.cross(ex, ny)], axis=-1)
    frame0 = np.stack([c0 / el.L0[:, None], el.ny0, el.nz0], axis=-1)
    return logm_so3(frame @ np.swapaxes(frame0, 1, 2))


def train(joint, dim: int, range_deg=None, step_deg: float | None = None, eob_table: bool = False) -> JointData:
    """Train the database of ``joint`` (a `Joint` with a FE model and a `database_key`) in ``dim``.

    The sampling (``range_deg``, ``step_deg``) and the polynomial orders default to the joint's
    ``training`` settings (`TRAINING` where it sets none), checked against `TRAINING_SCHEMA`
    (`training_settings`); the database key is `checked_key`. ``eob_table``: also tabulate the EOB
    condensation of this joint against theta (`flexmb.ksd.eob_table`; KSD-reduced then looks it
    up instead of condensing per solve, for joints with these parameters)."""
    opt = training_settings(joint, range_deg=range_deg, step_deg=step_deg)
    lo, hi = opt["range_deg"]
    key = checked_key(joint)
    theta = np.radians(np.arange(lo, hi + 0.5 * opt["step_deg"], opt["step_deg"]))
    run = simulate(joint, dim, theta)
    D0 = float(np.linalg.norm(joint.interface_b(dim)))
    pos = run.b_position / D0
    functions = {name: Polynomial.fit(theta, pos[:, k], opt["constraint_powers"])
                 for k, name in enumerate(("x/D0", "y/D0", "z/D0")[:dim])}
    functions["D/D0-1"] = Polynomial.fit(theta, np.linalg.norm(pos, axis=1) - 1.0, opt["length_powers"])
    S = len(theta)
    data = JointData(kind=joint.kind, dim=dim, parameters=plain_parameters(joint.describe()), key=key,
                     mesh_hash=mesh_hash(joint, dim), range=(float(theta[0]), float(theta[-1])), samples=theta,
                     length=D0, functions=functions,
                     elements=Polynomial.fit(theta, run.element_rotation.reshape(S, -1), opt["element_powers"]),
                     nodes=Polynomial.fit(theta, run.node_rotation.reshape(S, -1), opt["element_powers"]))
    return with_eob_table(joint, data) if eob_table else data


def training_settings(joint, *, range_deg=None, step_deg=None) -> dict:
    """The training settings of ``joint``: `TRAINING` updated by the joint class's ``training``
    (checked against `TRAINING_SCHEMA`: an unknown key or a value outside its range is refused
    with a `ParameterError` naming the joint, the key and the valid keys or range), then by
    ``range_deg`` and ``step_deg`` when given (`flexmb train --range/--step`)."""
    owner = f"{getattr(joint, 'kind', type(joint).__name__)} training"
    own = getattr(joint, "training", {})
    if not isinstance(own, dict):
        raise ParameterError(f"{owner}: the class attribute training must be a dict of the keys "
                             f"{', '.join(TRAINING_SCHEMA)}, got {type(own).__name__}")
    unknown = sorted(str(k) for k in own if k not in TRAINING_SCHEMA)
    if unknown:
        raise ParameterError(f"{owner}: unknown setting {', '.join(map(repr, unknown))}; valid: "
                             f"{', '.join(TRAINING_SCHEMA)} (see flexmb.database.TRAINING_SCHEMA)")
    given = {"range_deg": range_deg, "step_deg": step_deg}
    opt = {**TRAINING, **own, **{k: x for k, x in given.items() if x is not None}}
    try:
        lo, hi = (float(x) for x in opt["range_deg"])
    except (TypeError, ValueError):
        raise ParameterError(f"{owner}: range_deg={opt['range_deg']!r} must be {TRAINING_SCHEMA['range_deg']}") \
            from None
    if not -180.0 <= lo < hi <= 180.0:
        raise ParameterError(f"{owner}: range_deg=({lo:g}, {hi:g}) must be {TRAINING_SCHEMA['range_deg']}")
    step = opt["step_deg"]
    if isinstance(step, (bool, str, bytes)) or not isinstance(step, (int, float, np.integer, np.floating)) \
            or not 0.0 < float(step) <= hi - lo:
        raise ParameterError(f"{owner}: step_deg={step!r} must be a number in (0, {hi - lo:g}] deg (the range's width)")
    out = {"range_deg": (lo, hi), "step_deg": float(step)}
    for name, least in (("element_powers", 1), ("constraint_powers", 0), ("length_powers", 1)):
        out[name] = _powers(owner, name, opt[name], least)
    return out


def checked_key(joint) -> dict:
    """``joint.database_key()``, checked: a non-empty dict of parameter names (text) to numbers,
    booleans or text (it names the database file and is stored in it as JSON); else a
    `ParameterError` naming the joint. Holding the mesh parameter (`flexmb.Joint.mesh_parameter`)
    is the joint's choice: data trained on another mesh are refused either way (mesh hash)."""
    key = joint.database_key()
    ok = isinstance(key, dict) and key and all(
        isinstance(k, str) and k and isinstance(x, (bool, int, float, str, np.integer, np.floating))
        and (not isinstance(x, (float, np.floating)) or np.isfinite(x)) for k, x in key.items())
    if not ok:
        raise ParameterError(f"{joint.kind}: database_key() must return a non-empty dict of parameter names to "
                             f"finite numbers or text, got {key!r}")
    return {k: (x.item() if isinstance(x, np.generic) else x) for k, x in key.items()}


def _powers(owner: str, name: str, value, least: int) -> tuple:
    ok = isinstance(value, (tuple, list)) and len(value) > 0 and all(
        isinstance(p, (int, np.integer)) and not isinstance(p, bool) and least <= p <= MAX_POWER for p in value)
    if not ok or len(set(value)) != len(value):
        raise ParameterError(f"{owner}: {name}={value!r} must be {TRAINING_SCHEMA[name]}")
    return tuple(int(p) for p in value)


def migrate(path) -> JointData:
    """Rewrite the database file ``path`` (version 2 or 3) as version 3 with the EOB condensation
    of its training joint tabulated (the joint rebuilt from the recorded kind and parameters;
    the kinematic fits are kept as they are). How the shipped data were migrated."""
    from ..registry import joint as make_joint

    data = load(path)
    joint = make_joint(data.kind, **data.parameters)
    out = with_eob_table(joint, data)
    save(out, path)
    return out


def with_eob_table(joint, data: JointData) -> JointData:
    """``data`` with the EOB condensation of ``joint`` (the joint it was trained on) tabulated
    (`flexmb.ksd.eob_table.tabulate`): how `train` and the migration of version 2 files add it."""
    from ..ksd.eob import EOBTemplate
    from ..ksd.eob_table import tabulate

    return attrs.evolve(data, eob_table=tabulate(EOBTemplate(joint, data.dim, data), plain_parameters(joint.describe())))


def verify(joint, dim: int, folder=None, *, samples: int = 3) -> JointData:
    """The database of ``joint`` (`shipped`: ``folder``, the user folder, the shipped data), checked
    against the joint's FE model re-run at ``samples`` of its trained rotations (both ends and
    evenly between): B's position over D0 and every element and node rotation must match the fits
    within the residual each fit states (plus 1e-8 for the solves' tolerance). The checksum and
    `load`'s content checks catch damaged files; this catches a file edited consistently, e.g.
    element rotations scaled and the checksum recomputed. `DatabaseError` naming the worst fit.
    Costs ``samples`` solves."""
    data = shipped(joint, dim, folder)
    idx = np.unique(np.linspace(0, len(data.samples) - 1, max(int(samples), 1)).round().astype(int))
    run = simulate(joint, dim, data.samples[idx])
    S = len(idx)
    checks = [(name, data.functions[name], run.b_position[:, k] / data.length)
              for k, name in enumerate(("x/D0", "y/D0", "z/D0")[:dim])]
    checks += [("elements", data.elements, run.element_rotation.reshape(S, -1)),
               ("nodes", data.nodes, run.node_rotation.reshape(S, -1))]
    for name, poly, exact in checks:
        if not np.size(poly.coefficients):
            continue
        err = float(np.abs(poly(run.theta).reshape(exact.shape) - exact).max())
        if err > poly.max_residual + 1e-8:
            raise DatabaseError(f"{joint.kind} database ({dim}D, {data.key}): {name} differs from the FE model by "
                                f"{err:.3g} where the fit states at most {poly.max_residual:.3g}; the file was "
                                "edited: re-create it with `flexmb train`")
    return data


