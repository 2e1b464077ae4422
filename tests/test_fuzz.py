"""Fuzzing the public API with invalid values (issue 6, error-handling audit).

Hypothesis throws junk — NaN, inf, negative, zero, huge and tiny numbers, wrong shapes, strings,
None, arbitrary objects — at every joint constructor, every `Mechanism` builder method, the
solver options and the solve itself. The contract checked everywhere: the call either works or
raises a `flexmb.FlexmbError` subclass (never a bare numpy/scipy/Python error); a rejected call
leaves the mechanism exactly as it was; a solve that reports convergence has finite numbers.
"""

import pickle
import warnings

import attrs
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flexmb
from flexmb import FlexmbError
from flexmb.joints._base import UNSET
from flexmb import models

FUZZ = settings(deadline=None, database=None,  # examples and derandomisation: the active profile
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -1.0, -0.0, 1e300, 1e-300,
                                                                                     -1e-12, 2**63]),
                    st.integers(-3, 3))
junk = st.one_of(
    numbers,
    st.none(), st.booleans(), st.text(max_size=4), st.just(object()), st.just({"a": 1}),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=5),
    st.lists(st.lists(st.floats(-1, 1), min_size=2, max_size=2), min_size=1, max_size=3).map(np.array),
    st.just(np.array([1.0, np.nan, 0.0])), st.just(np.zeros((2, 2, 2))), st.just(1 + 2j),
)


def _outcome(call):
    """Run ``call``; return None or the FlexmbError; anything else fails the test."""
    try:
        call()
    except FlexmbError as exc:
        assert str(exc).strip(), "a FlexmbError without a message"
        return exc
    return None


def _snapshot(m) -> bytes:
    """Everything a Mechanism holds, as bytes (equal bytes: unchanged)."""
    return pickle.dumps((list(m.graph.nodes(data=True)), list(m.graph.edges(keys=True, data=True)), m._loads,
                         m._prescribed, m._points, m._actuation))


# -- joint constructors, over every registered joint -------------------------------------------

def _fields(kind):
    cls = flexmb.available_joints()[kind]
    return [(kind, f.alias) for f in attrs.fields(cls)] if attrs.has(cls) else []


def _required(cls) -> dict:
    """Valid values of the parameters without a default: the middle of ``parameter_ranges``."""
    return {f.alias: sum(cls.parameter_ranges[f.alias]) / 2 for f in attrs.fields(cls)
            if f.default is attrs.NOTHING or (f.default is UNSET and f.alias in cls.parameter_ranges)}


FIELDS = [kf for kind in sorted(flexmb.available_joints()) for kf in _fields(kind)]


@pytest.mark.parametrize("kind, name", FIELDS, ids=[f"{k}.{n}" for k, n in FIELDS])
@FUZZ
@given(value=junk)
@pytest.mark.slow
def test_joint_parameter_junk_is_refused_or_gives_a_finite_model(kind, name, value):
    """Every parameter of every registered joint: rejected with a FlexmbError that names it, or
    accepted and then meshed to finite points (or refused there, as a FlexmbError)."""
    cls = flexmb.available_joints()[kind]
    joint = None

    def build():
        nonlocal joint
        joint = cls(**{**_required(cls), name: value})

    exc = _outcome(build)
    if exc is not None:
        assert name in str(exc) or kind in str(exc), f"{kind}({name}={value!r}): message does not name it: {exc}"
        return
    for dim in cls.dims:
        if "fe_model" in joint.capabilities:
            mesh = []
            if _outcome(lambda: mesh.append(joint.mesh(dim))) is None:
                assert np.all(np.isfinite(mesh[0].points)), f"{kind}({name}={value!r}): non-finite mesh in {dim}D"
        if "closed_form" in joint.capabilities and dim == 2:
            _outcome(lambda: joint.closed_form(dim))


# -- the Mechanism builder ----------------------------------------------------------------------

def _pivot():
    return models.cross_flexure_pivot(elements_per_leaf=1, dim=3, rotation=0.2)


CALLS = {
    "add_link name": lambda m, x: m.add_link(x, position=(0.0, 0.0, 0.0)),
    "add_link position": lambda m, x: m.add_link("C", position=x),
    "add_link fixed": lambda m, x: m.add_link("C", fixed=x),
    "add_joint joint": lambda m, x: m.add_joint("A", "B", x),
    "add_joint origin": lambda m, x: m.add_joint("A", "B", "leaf_spring", origin=x),
    "add_joint rotation": lambda m, x: m.add_joint("A", "B", "leaf_spring", rotation=x),
    "add_joint parameter": lambda m, x: m.add_joint("A", "B", "leaf_spring", length=x),
    "add_joint link": lambda m, x: m.add_joint(x, "B", "leaf_spring"),
    "apply_force force": lambda m, x: m.apply_force("B", x),
    "apply_force point": lambda m, x: m.apply_force("B", (1.0, 0.0, 0.0), point=x),
    "apply_force link": lambda m, x: m.apply_force(x, (1.0, 0.0, 0.0)),
    "apply_moment": lambda m, x: m.apply_moment("B", x),
    "prescribe x": lambda m, x: m.prescribe("B", x=x),
    "prescribe rotation": lambda m, x: m.prescribe("B", rotation=x),
    "prescribe link": lambda m, x: m.prescribe(x, x=0.0),
    "set_actuation direction": lambda m, x: m.set_actuation("B", x),
    "set_actuation value": lambda m, x: m.set_actuation("B", (1.0, 0.0, 0.0), value=x),
    "add_point position": lambda m, x: m.add_point("B", "p", x),
    "add_point name": lambda m, x: m.add_point("B", x, (0.0, 0.0, 0.0)),
    "fix": lambda m, x: m.fix(x),
}


@pytest.mark.parametrize("call", sorted(CALLS))
@FUZZ
@given(value=junk)
def test_mechanism_builders_refuse_junk_and_leave_the_mechanism_unchanged(call, value):
    m = _pivot()
    before = _snapshot(m)
    exc = _outcome(lambda: CALLS[call](m, value))
    if exc is not None:
        assert _snapshot(m) == before, f"{call}({value!r}) was refused but changed the mechanism"


# -- solver options and the solve ----------------------------------------------------------------

OPTIONS = ["tol", "max_iter", "divergence", "min_step", "initial_step", "max_rotation", "raise_on_failure",
           "kinematic_tol", "strict_range", "tangent", "database"]


@pytest.mark.parametrize("method", ["conventional", "ksd-reduced", "ksd-full"])
@FUZZ
@given(option=st.sampled_from(OPTIONS), value=junk)
def test_solver_option_junk_is_refused_before_solving(method, option, value):
    """A bad option value is a FlexmbError (ParameterError or UnsupportedStrategyError), and a
    solve it does not stop either converges with finite numbers or says it did not."""
    m = _pivot()
    before = _snapshot(m)
    sol = []
    # a coarse smallest step bounds the work of options that make every step hard (max_iter=1:
    # only the predictor can be accepted, and the default 1e-5 allows 1e5 steps, about a minute)
    steps = {} if option == "min_step" or method == "ksd-reduced" else {"min_step": 0.01}
    exc = _outcome(lambda: sol.append(flexmb.solve(m, method=method, **{**steps, option: value})))
    assert _snapshot(m) == before
    if exc is None and sol[0].converged:
        assert np.all(np.isfinite(sol[0].node_positions())) and np.all(np.isfinite(sol[0].reaction("B")))


@FUZZ
@given(method=junk)
def test_method_junk_is_refused(method):
    assert isinstance(_outcome(lambda: flexmb.solve(_pivot(), method=method)), flexmb.UnsupportedStrategyError)


@pytest.mark.parametrize("method", ["conventional", "ksd-reduced", "ksd-full"])
@FUZZ
@given(rotation=st.floats(-1e6, 1e6, allow_nan=False), force=st.floats(-1e9, 1e9, allow_nan=False))
def test_any_finite_motion_and_load_solves_reports_failure_or_refuses(method, rotation, force):
    """Extreme but finite input: a converged answer is finite, a failure is reported (flag and
    message) or refused as a FlexmbError (e.g. a rotation outside the trained range); the
    mechanism is never changed. Few solve steps so a hopeless case fails fast."""
    m = models.cross_flexure_pivot(elements_per_leaf=1, dim=3, rotation=0.0)
    m.prescribe("B", z=0.0, rotation=(0.0, 0.0, rotation))
    m.apply_force("B", (force, 0.0, 0.0))
    before = _snapshot(m)
    sol = []
    options = {"max_iter": 8} if method == "ksd-full" else {}
    if method == "conventional":
        options = {"max_iter": 8, "min_step": 0.05}
    exc = _outcome(lambda: sol.append(flexmb.solve(m, method=method, **options)))
    assert _snapshot(m) == before
    if exc is None:
        s = sol[0]
        if s.converged:
            assert np.all(np.isfinite(s.node_positions())) and np.all(np.isfinite(s.reaction("B")))
        else:
            assert s.message and len(s.residual_history) >= 0


# -- the workflow API: sweeps, studies, tables, plots, export --------------------------------------

def _solved():
    return flexmb.solve(models.cross_flexure_pivot(elements_per_leaf=1, dim=2, rotation=0.2))


def _double(x):
    return 2 * x


WORKFLOW = {
    "sweep values": lambda x: flexmb.sweep(models.cross_flexure_pivot(elements_per_leaf=1, dim=2), x,
                                           motion=("B", "rotation"), max_iter=5),
    "sweep motion": lambda x: flexmb.sweep(models.cross_flexure_pivot(elements_per_leaf=1, dim=2), [0.1], motion=x),
    "sweep start": lambda x: flexmb.sweep(models.gripper(), [1.0], start=x, method="newton"),
    "grid": lambda x: flexmb.grid(a=x),
    "parameter_study designs": lambda x: flexmb.parameter_study(_double, x, executor="serial"),
    "parameter_study executor": lambda x: flexmb.parameter_study(_double, [{"x": 1.0}], executor=x),
    "Table": lambda x: flexmb.Table({"a": x, "b": [1.0]}),
    "read_csv": lambda x: flexmb.read_csv(x),
    "Table.to_csv": lambda x: flexmb.Table({"a": [1.0]}).to_csv(x),
    "plot_force_curve": lambda x: flexmb.plot.plot_force_curve(x, [1.0, 2.0]),
    "plot_mechanism": lambda x: flexmb.plot.plot_mechanism(x),
    "plot_map": lambda x: flexmb.plot.plot_map(x, "a", "b", "c"),
    "write_vtk path": lambda x: flexmb.export.write_vtk(_solved(), x),
    "write_vtk solution": lambda x: flexmb.export.write_vtk(x, "out.vtu"),
}


@pytest.mark.parametrize("call", sorted(WORKFLOW))
@FUZZ
@given(value=junk)
def test_workflow_functions_refuse_junk_with_flexmb_errors(call, value, tmp_path_factory, monkeypatch):
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    monkeypatch.chdir(tmp_path_factory.mktemp("fuzz"))
    _outcome(lambda: WORKFLOW[call](value))


# -- studies, sweeps and tables keep what the user had (issue 20) ---------------------------------

cells = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**62, 2**62), st.text(max_size=6),
                  st.booleans(), st.none())
column_names = st.one_of(st.text(max_size=4), st.integers(-3, 3))


@FUZZ
@given(columns=st.dictionaries(column_names, st.one_of(st.lists(cells, max_size=4), junk), max_size=4))
def test_a_table_keeps_every_column_as_given_or_refuses_and_leaves_the_input_alone(columns):
    before = pickle.dumps(columns)
    made = []
    exc = _outcome(lambda: made.append(flexmb.Table(columns)))
    assert pickle.dumps(columns) == before  # nothing the user had is changed
    if exc is None:
        table = made[0]
        assert list(table) == [str(k) for k in columns]  # no column lost or merged
        for k, values in columns.items():
            got = table[str(k)]
            assert len(got) == len(values)
            for a, b in zip(got.tolist(), list(values)):  # each cell as given: no number turned into text
                assert a == b or (a != a and b != b) or (isinstance(b, float) and a == b), (a, b)
                assert isinstance(a, str) == isinstance(b, str)


def _round_trippable(text: str) -> bool:
    """Text that read_csv's documented rule keeps as text (not a number as Python writes it, not a
    boolean, not "nan"/"inf")."""
    from flexmb.table import _FLOAT

    return not _FLOAT.fullmatch(text) and text not in ("True", "False")


typed_columns = st.one_of(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=4),
                          st.lists(st.integers(-2**62, 2**62), min_size=1, max_size=4),
                          st.lists(st.booleans(), min_size=1, max_size=4),
                          st.lists(st.text(max_size=6).filter(_round_trippable), min_size=1, max_size=4))


@FUZZ
@given(columns=st.lists(typed_columns, min_size=1, max_size=3).filter(lambda c: len({len(x) for x in c}) == 1))
def test_a_table_comes_back_from_csv_with_the_same_cells_and_types(columns, tmp_path_factory):
    """Numbers stay numbers (floats bit for bit), text stays text ('007' is not 7), booleans stay booleans."""
    table = flexmb.Table({f"c{i}": c for i, c in enumerate(columns)})
    back = flexmb.read_csv(table.to_csv(tmp_path_factory.mktemp("csv") / "t.csv"))
    assert list(back) == list(table)
    for name in table:
        a, b = table[name], back[name]
        assert a.dtype.kind == b.dtype.kind or (a.dtype.kind == "U" and b.dtype.kind == "O"), (a, b)
        if a.dtype.kind == "f":
            np.testing.assert_array_equal(a, b)  # NaN == NaN here
        else:
            assert a.tolist() == b.tolist()


def _study_design(x=0.0, fail=0, **rest):
    """A design function that fails in the ways a user's can: raises, returns junk, or works."""
    if fail == 1:
        raise ValueError("bad design")
    if fail == 2:
        return {"y": [x, x]}  # not a scalar
    if fail == 3:
        return {1: x}  # not a name
    if fail == 4:
        return object()  # not a scalar (one scalar, e.g. text, is the column "value")
    return {"y": 2 * x if isinstance(x, (int, float)) else 0.0}


designs_strategy = st.lists(st.fixed_dictionaries({"x": st.one_of(st.floats(allow_nan=True), st.text(max_size=3),
                                                                   st.lists(st.integers(), max_size=2)),
                                                   "fail": st.integers(0, 4)}), max_size=5)


@FUZZ
@given(designs=st.one_of(designs_strategy, junk), on_error=st.sampled_from(["record", "raise"]))
def test_a_study_returns_one_row_per_design_or_a_flexmb_error_and_never_changes_the_designs(designs, on_error):
    before = pickle.dumps(designs)
    out = []
    exc = _outcome(lambda: out.append(flexmb.parameter_study(_study_design, designs, executor="serial",
                                                            on_error=on_error)))
    assert pickle.dumps(designs) == before
    table = out[0] if out else getattr(exc, "table", None)
    if table is not None:  # a result or an error carrying the table: every design has its row
        assert table.n_rows == len(designs)
        for i, d in enumerate(designs):
            x = table["x"][i]
            assert x == d["x"] or (x != x and d["x"] != d["x"]) or list(x) == d["x"]
            assert (table["error"][i] == "") == (d["fail"] == 0) or table["error"][i].startswith("cancelled")


@FUZZ
@given(values=st.one_of(st.lists(st.floats(-2.0, 2.0), min_size=1, max_size=4).map(np.array), junk))
def test_a_sweep_keeps_a_solution_per_value_or_refuses_and_changes_nothing(values):
    """Angles to +-2 rad (beyond the database's 75 deg): a KSD sweep keeps every value, refused
    ones as non-converged Solutions; the mechanism and the values array are not changed."""
    m = models.cross_flexure_pivot(elements_per_leaf=1, dim=2)
    m.prescribe("B", rotation=0.0)
    before, values_before = _snapshot(m), pickle.dumps(values)
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exc = _outcome(lambda: out.append(flexmb.sweep(m, values, motion=("B", "rotation"), method="ksd-reduced")))
    assert _snapshot(m) == before and pickle.dumps(values) == values_before
    valid = isinstance(values, np.ndarray) and values.ndim == 1 and len(values) and np.isfinite(values).all()
    assert exc is None or not valid, exc  # finite angles: never refused, whatever one of them does
    if exc is None:
        result = out[0]
        assert len(result) == len(values)
        for sol in result:
            assert sol.converged or sol.message
