"""Mechanism files (issue 30 item 1): `flexmb.save` / `flexmb.load` round trips that solve bit for
bit like the original, hypothesis-made mechanisms, and hostile files refused with one clear error
(and exit code 2 from ``flexmb solve FILE``)."""

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import flexmb
from flexmb import cli, files, models, registry
from flexmb.files import MechanismFileError

PLUGIN = Path(__file__).parent / "plugin_pkg"


def same_solution(a, b) -> None:
    """Two solutions equal bit for bit: iterations, residual history, every node, every reaction."""
    assert a.converged and b.converged
    assert a.iterations == b.iterations and a.method == b.method
    assert np.array_equal(a.residual_history, b.residual_history, equal_nan=True)
    assert np.array_equal(a.node_positions(), b.node_positions())
    for link in a.compiled.link_node:
        assert np.array_equal(a.reaction(link), b.reaction(link)), link
        assert np.array_equal(a.rotation_vector(link), b.rotation_vector(link)), link


def round_trip(m, tmp_path, name="m.json"):
    path = flexmb.save(m, tmp_path / name)
    loaded = flexmb.load(path)
    assert files.dumps(loaded) == path.read_text()  # the loaded mechanism writes the same file
    return loaded


MODELS = {
    "cantilever": lambda: _loaded_cantilever(),
    "cross_flexure_3d": lambda: models.cross_flexure_pivot(rotation=0.4),
    "cross_flexure_2d": lambda: models.cross_flexure_pivot(dim=2, rotation=0.4, elements_per_leaf=5),
    "fourbar": lambda: models.fourbar(displacement=0.1, moment=0.2),
    "gripper": lambda: models.gripper(force=20.0),
    "manipulator_joint": lambda: models.manipulator("joint", 0.3),
    "manipulator_location": lambda: models.manipulator("location", -0.2),
}
METHODS = {"gripper": ("newton", "conventional"), "fourbar": ("conventional", "ksd-full"),
           "manipulator_joint": ("conventional", "ksd-reduced")}


def _loaded_cantilever():
    m = models.cantilever(elements=6, dim=3, section=flexmb.rectangle(0.02, 1e-3, 200e9, 76.9e9))
    m.apply_force("tip", (0.0, -5.0, 1.0), point=(0.1, 0.0, 0.01))
    m.apply_moment("tip", (0.1, 0.0, 0.2))
    m.add_point("tip", "probe", (0.12, 0.01, 0.0))
    m.set_actuation("tip", (0.0, 0.0, 3.0), value=2.0, point=(0.1, 0.003, 0.0))
    return m


def test_every_model_in_flexmb_models_is_covered():
    # every public builder of flexmb.models (a function returning a Mechanism) has a case in MODELS: a
    # new model fails here until it is round-tripped too
    import inspect

    builders = {n for n in models.__all__ if inspect.isfunction(getattr(models, n))
                and inspect.signature(getattr(models, n)).return_annotation in ("Mechanism", flexmb.Mechanism)}
    assert builders == {"cantilever", "cross_flexure_pivot", "fourbar", "gripper", "manipulator"}


@pytest.mark.parametrize("name", list(MODELS))
def test_every_model_round_trips_to_bit_identical_solutions(name, tmp_path):
    m = MODELS[name]()
    loaded = round_trip(m, tmp_path)
    assert loaded.units == m.units and list(loaded.links) == list(m.links) and list(loaded.joints) == list(m.joints)
    for method in METHODS.get(name, ("conventional",)):
        same_solution(flexmb.solve(m, method=method), flexmb.solve(loaded, method=method))


def hinged_fourbar(dim):
    """Four rigid links on four hinges, one a torsion spring and one a motor (test_hinge's, as a
    user builds it), with a load on the coupler."""
    z = [] if dim == 2 else [0.0]
    m = flexmb.Mechanism(dim=dim)
    m.add_link("ground", position=[0.0, 0.0] + z, fixed=True)
    m.add_link("crank", position=[0.0, 0.0] + z, mass=0.1, inertia=1e-4 if dim == 2 else np.diag([1e-4, 2e-4, 2.5e-4]))
    m.add_link("coupler", position=[0.03, 0.04] + z)
    m.add_link("rocker", position=[0.1, 0.0] + z)
    m.add_joint("ground", "crank", "hinge", angle=0.3, name="motor")
    m.add_joint("crank", "coupler", "hinge", k=2.0, origin=[0.03, 0.04] + z, name="A")
    m.add_joint("coupler", "rocker", "leaf_spring", origin=[0.03, 0.04] + z, rotation=-0.2 if dim == 2 else
                [0.0, 0.0, -0.2], length=float(np.hypot(0.07, 0.02)), elements=4, name="leaf")
    m.add_joint("rocker", "ground", "hinge", k=1.0, origin=[0.1, 0.0] + z, name="O4")
    m.apply_force("coupler", [0.0, -1.0] + z)
    return m


@pytest.mark.parametrize("dim", [2, 3])
def test_hinged_mechanisms_round_trip_to_bit_identical_solutions(dim, tmp_path):
    m = hinged_fourbar(dim)
    loaded = round_trip(m, tmp_path)
    same_solution(flexmb.solve(m), flexmb.solve(loaded))
    np.testing.assert_array_equal(flexmb.modes(flexmb.solve(m), n_modes=1, held="fixed").frequencies,
                                  flexmb.modes(flexmb.solve(loaded), n_modes=1, held="fixed").frequencies)


@pytest.fixture
def single_leaf():
    """The third-party plugin joint of tests/plugin_pkg, registered for this test as a session
    joint (test_plugin_package installs it as a package with its entry point)."""
    sys.path.insert(0, str(PLUGIN))
    try:
        from flexmb_notch import SingleLeaf

        flexmb.register_joint("single_leaf", SingleLeaf, clobber=True)
        yield SingleLeaf
    finally:
        registry._session.pop("single_leaf", None)
        sys.path.remove(str(PLUGIN))
        sys.modules.pop("flexmb_notch", None)


def test_a_third_party_plugin_joint_round_trips(single_leaf, tmp_path):
    m = flexmb.Mechanism(dim=2)
    m.add_link("ground", fixed=True)
    m.add_link("tip", position=(0.08, 0.0))
    m.add_joint("ground", "tip", "single_leaf", length=0.08, thickness=8e-4, name="leaf")
    m.apply_moment("tip", 0.05)
    loaded = round_trip(m, tmp_path)
    assert type(loaded.joints["leaf"]) is single_leaf and loaded.joints["leaf"] == m.joints["leaf"]
    same_solution(flexmb.solve(m), flexmb.solve(loaded))
    registry._session.pop("single_leaf")
    with pytest.raises(MechanismFileError, match=r"joints\[0\].kind: no joint 'single_leaf' is registered"):
        flexmb.load(tmp_path / "m.json")


def test_a_declared_mechanism_with_named_materials_round_trips(tmp_path):
    from test_units import guided_stage

    m = guided_stage("mm-N-MPa")
    text = files.dumps(m)
    doc = json.loads(text)
    assert doc["units"] == "mm-N-MPa" and list(doc["materials"]) == ["spring_steel"]
    assert doc["materials"]["spring_steel"]["E"] == flexmb.material("spring_steel", "mm-N-MPa").E
    loaded = round_trip(m, tmp_path)
    same_solution(flexmb.solve(m), flexmb.solve(loaded))
    # a hand-written file may name a catalogue material without a table entry: resolved in its units
    del doc["materials"]
    assert flexmb.files.from_dict(doc).joints["leaf_spring_1"].material == flexmb.material("spring_steel", "mm-N-MPa")


# -- hypothesis: mechanisms a user could build -------------------------------------------------------

finite = st.floats(-0.05, 0.05, allow_nan=False, allow_subnormal=False)


@st.composite
def mechanisms(draw):
    """A planar or spatial chain of 1-3 links on leaf springs, cross flexures or hinges, placed and
    turned anywhere, with masses, a prescribed motion, loads, points and an actuation."""
    dim = draw(st.sampled_from([2, 3]))
    units = draw(st.sampled_from([None, "SI"]))
    m = flexmb.Mechanism(dim=dim, units=units)
    z = [] if dim == 2 else [draw(finite)]
    m.add_link("L0", position=[draw(finite), draw(finite)] + z, fixed=True)
    n = draw(st.integers(1, 3))
    for i in range(1, n + 1):
        m.add_link(f"L{i}", position=[draw(finite) + 0.1 * i, draw(finite)] + z, mass=draw(st.floats(0, 1)),
                   inertia=draw(st.floats(0, 1e-3)) if dim == 2 else None)
        kind = draw(st.sampled_from(["leaf_spring", "cross_flexure", "hinge"]))
        params = {"leaf_spring": {"length": draw(st.floats(0.05, 0.2)), "elements": draw(st.integers(1, 4)),
                                  "nu": draw(st.floats(0.1, 0.45))},
                  "cross_flexure": {"angle": draw(st.floats(0.4, 1.2)), "elements_per_leaf": draw(st.integers(1, 3)),
                                    "material": draw(st.sampled_from(["peek", "ti6al4v", "silicon"]))},
                  "hinge": {"k": draw(st.floats(0.0, 10.0))}}[kind]
        angle = draw(st.floats(-math.pi, math.pi))
        rotation = angle if dim == 2 else [draw(st.floats(-1, 1)), draw(st.floats(-1, 1)), angle]
        m.add_joint(f"L{i - 1}", f"L{i}", kind, origin=[draw(finite), draw(finite)] + z, rotation=rotation, **params)
    last = f"L{n}"
    m.prescribe(last, x=draw(finite))
    m.apply_force(last, [draw(finite) for _ in range(dim)], point=[draw(finite) for _ in range(dim)])
    m.apply_moment(last, draw(finite) if dim == 2 else [draw(finite) for _ in range(3)])
    m.add_point(last, "p", [draw(finite) for _ in range(dim)])
    m.set_actuation(last, [draw(finite) + 0.1 for _ in range(dim)], value=draw(finite), point=[0.01] * dim)
    return m


@pytest.mark.slow  # ~13 s: 40 mechanisms, each compiled and solved twice
@settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(m=mechanisms())
def test_hypothesis_mechanisms_round_trip_exactly(m):
    text = files.dumps(m)
    loaded = files.loads(text)
    assert files.dumps(loaded) == text
    assert loaded.dim == m.dim and loaded.units == m.units
    for name, lk in m.links.items():
        other = loaded.link(name)
        assert np.array_equal(other.position, lk.position) and other.mass == lk.mass and other.fixed == lk.fixed
    for (la, oa, fa, ma), (lb, ob, fb, mb) in zip(m.loads, loaded.loads):
        assert la == lb and np.array_equal(oa, ob) and np.array_equal(fa, fb) and np.array_equal(ma, mb)
    assert m.joints == loaded.joints  # joints are values: equal parameters and material
    for a, b in zip(m.graph.edges(keys=True, data=True), loaded.graph.edges(keys=True, data=True)):
        assert a[:3] == b[:3]
        assert np.array_equal(a[3]["placement"].rotation, b[3]["placement"].rotation)
        assert np.array_equal(a[3]["placement"].origin, b[3]["placement"].origin)
    assert m.actuation["value"] == loaded.actuation["value"]
    assert np.array_equal(m.actuation["direction"], loaded.actuation["direction"])
    # the compiled problems are the same numbers: node positions and the residual at a state
    pa, pb = m.compile().problem, loaded.compile().problem
    assert np.array_equal(pa.model.x0, pb.model.x0)
    assert np.array_equal(pa.prescribed, pb.prescribed)
    with warnings.catch_warnings():  # a drawn mechanism may be far from solvable: the same either way
        warnings.simplefilter("ignore")
        sa, sb = flexmb.solve(m, max_iter=4), flexmb.solve(loaded, max_iter=4)
    assert sa.iterations == sb.iterations
    assert np.array_equal(sa.node_positions(), sb.node_positions(), equal_nan=True)


# -- hostile and corrupted files ---------------------------------------------------------------------

def _valid() -> dict:
    m = models.cross_flexure_pivot(dim=2, elements_per_leaf=2, rotation=0.2)
    return files.to_dict(m)


def _edit(fn):
    def make():
        doc = _valid()
        fn(doc)
        return json.dumps(doc)
    return make


def _set(path, value):
    def fn(doc):
        *parents, last = path
        d = doc
        for k in parents:
            d = d[k]
        d[last] = value
    return _edit(fn)


def _text(replace_from, replace_to):
    return lambda: json.dumps(_valid()).replace(replace_from, replace_to, 1)


def _valid_points() -> dict:
    """A file with points inside a joint (format version 2): a load at P, a prescribed motion at M."""
    m = models.cantilever(elements=4)
    m.add_joint_point(next(iter(m.joints)), "P", 0.3)
    m.add_joint_point(next(iter(m.joints)), "M", 0.6)
    m.apply_force("P", (0.0, -1.0))
    m.prescribe("M", y=-1e-4)
    return files.to_dict(m)


def _points(path, value):
    """``_valid_points()`` with the value at ``path`` replaced (a missing parent: the key added)."""
    def make():
        doc = _valid_points()
        *parents, last = path
        d = doc
        for k in parents:
            d = d[k]
        d[last] = value
        return json.dumps(doc)
    return make


HOSTILE = {
    "not JSON": (lambda: "this is not a mechanism {", "not JSON"),
    "empty": (lambda: "", "not JSON"),
    "a list": (lambda: "[1, 2, 3]", "not a flexmb mechanism file"),
    "another format": (_set(["format"], "flexmb-database"), "not a flexmb mechanism file"),
    "newer version": (_set(["version"], 3), "format version 3, written by a newer flexmb; this flexmb reads "
                                            "versions up to 2"),
    "version as text": (_set(["version"], "1"), "version: '1' must be a whole number"),
    "missing key": (_edit(lambda d: d.pop("joints")), "missing key(s) 'joints'"),
    "unknown key": (_set(["linkz"], []), "unknown key(s) 'linkz'"),
    "dim 4": (_set(["dim"], 4), "dim: 4 must be 2 or 3"),
    "NaN": (_text('"position": [0.0, 0.0]', '"position": [NaN, 0.0]'), "NaN is not a number"),
    "Infinity": (_text('"thickness": 0.001', '"thickness": Infinity'), "Infinity is not a number"),
    "position wrong length": (_set(["links", 1, "position"], [0.0, 1.0, 2.0]), "links[1].position: must be a list of "
                                                                              "2 numbers, got shape (3,)"),
    "position as text": (_set(["links", 0, "position"], "origin"), "links[0].position: must be a list of 2 numbers"),
    "huge array": (_set(["links", 0, "position"], [0.0] * 1_000_000), "links[0].position: must be a list of 2"),
    "unknown joint": (_set(["joints", 0, "kind"], "os.system"), "joints[0].kind: no joint 'os.system' is registered"),
    "negative thickness": (_set(["joints", 0, "parameters", "thickness"], -1e-3),
                           "joints[0].parameters.thickness: cross_flexure: thickness=-0.001 must be > 0"),
    "length as text": (_set(["joints", 0, "parameters", "length"], "0.1"),
                       "joints[0].parameters.length: cross_flexure: length='0.1' is not a real number"),
    "unknown parameter": (_set(["joints", 0, "parameters", "colour"], "red"),
                          "joints[0].parameters.colour: joint 'cross_flexure': unknown parameter(s) ['colour']"),
    "huge integer": (_set(["joints", 0, "parameters", "elements_per_leaf"], 10**40),
                     "joints[0].parameters.elements_per_leaf: cross_flexure: elements_per_leaf="),
    "deep nesting": (lambda: "[" * 100_000 + "]" * 100_000, "not a mechanism file"),
    "duplicate key": (_text('"dim": 2', '"dim": 2, "dim": 3'), "the key 'dim' appears twice"),
    "not a rotation": (_set(["joints", 0, "rotation"], [[1.0, 0.5], [0.0, 1.0]]),
                       "joints[0].rotation: not a rotation matrix"),
    "missing link": (_set(["joints", 0, "b"], "nowhere"), "joints[0]: no link named 'nowhere'"),
    "unknown material": (_set(["joints", 0, "parameters", "material"], "kryptonite"),
                         "joints[0].parameters.material: 'kryptonite' is neither in the file's materials"),
    "material without E": (_edit(lambda d: d["materials"]["material_1"].pop("E")),
                           "materials.material_1: missing key(s) 'E'"),
    "prescribed on a fixed link": (_set(["prescribed", "A"], {"x": 0.1}), "prescribed.A: link 'A' is fixed"),
    "prescribed junk": (_set(["prescribed", "B", "rotation"], {"__class__": "os"}), "prescribed.B.rotation: an "
                                                                                    "object must be"),
    "code as a parameter": (_set(["joints", 0, "parameters", "angle"], "__import__('os').system('true')"),
                            "joints[0].parameters.angle: cross_flexure: angle="),
    "not UTF-8": (lambda: b"\xff\xfe\x00garbage", "not UTF-8"),
    # points inside joints (format version 2, issue 29)
    "joint points in a version-1 file": (_points(["version"], 1), "joint_points: points inside joints need format "
                                                                 "version 2 (the file says version 1)"),
    "joint point of no joint": (_points(["joint_points", 0, "joint"], "nowhere"),
                                "joint_points[0]: no joint named 'nowhere'"),
    "joint point at its end": (_points(["joint_points", 0, "fraction"], 1.0),
                               "joint_points[0]: joint point 'P': fraction=1.0 must be in (0, 1)"),
    "joint point fraction as text": (_points(["joint_points", 0, "fraction"], "half"),
                                     "joint_points[0]: joint point 'P': fraction='half'"),
    "joint point on no leaf": (_points(["joint_points", 1, "leaf"], 3),
                               "joint_points[1]: joint point 'M': leaf=3; joint 'leaf_spring' has leaves 0 ... 0"),
    "joint point named like a link": (_points(["joint_points", 0, "name"], "tip"),
                                      "joint_points[0]: a link or joint point named 'tip' exists already"),
    "joint point unknown key": (_points(["joint_points", 0, "side"], "A"), "joint_points[0]: unknown key(s) 'side'"),
    "joint point load at no point": (_points(["joint_point_loads", 0, "point"], "nowhere"),
                                     "joint_point_loads[0].point: no joint point named 'nowhere'"),
    "joint point load of 3 components": (_points(["joint_point_loads", 0, "force"], [0.0, 1.0, 2.0]),
                                         "joint_point_loads[0].force: must be a list of 2 numbers, got shape (3,)"),
    "joint point prescribed junk": (_points(["prescribed", "M", "w"], 1.0),
                                    "prescribed.M: joint point 'M': cannot prescribe 'w'"),
}


def _write(tmp_path, content) -> Path:
    path = tmp_path / "hostile.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def test_at_least_twenty_hostile_files():
    assert len(HOSTILE) >= 20


@pytest.mark.parametrize("name", list(HOSTILE))
def test_a_hostile_file_gives_one_clear_error_and_exit_2(name, tmp_path, capsys):
    make, message = HOSTILE[name]
    path = _write(tmp_path, make())
    with pytest.raises(MechanismFileError) as exc:
        flexmb.load(path)
    assert message in str(exc.value), str(exc.value)
    assert str(exc.value).startswith(str(path))
    try:
        code = cli.main(["solve", str(path)])
    except SystemExit as stop:  # argparse's own exit
        code = stop.code
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.startswith("flexmb: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert message in err


def test_a_file_too_large_is_refused_before_reading(tmp_path, monkeypatch):
    monkeypatch.setattr(files, "MAX_BYTES", 100)
    path = _write(tmp_path, json.dumps(_valid()))
    with pytest.raises(MechanismFileError, match="larger than a mechanism file can be"):
        flexmb.load(path)


def test_what_cannot_be_written_is_refused_naming_it(tmp_path):
    m = models.cantilever(elements=2)

    class Local(flexmb.LeafSpring):  # not the class registered as "leaf_spring"
        pass

    m.add_link("C", position=(0.2, 0.0))
    m.add_joint("tip", "C", Local(), name="local")
    with pytest.raises(MechanismFileError, match="joint 'local': its class .*Local is not the joint registered as "
                                                 "'leaf_spring'"):
        flexmb.save(m, tmp_path / "x.json")
    assert not (tmp_path / "x.json").exists()


def test_a_hand_written_file_with_the_defaults_left_out(tmp_path):
    text = """{"format": "flexmb-mechanism", "version": 1, "dim": 2,
               "links": [{"name": "ground", "position": [0, 0], "fixed": true},
                         {"name": "tip", "position": [0.1, 0]}],
               "joints": [{"kind": "leaf_spring", "a": "ground", "b": "tip", "rotation": 0.0,
                           "parameters": {"material": "spring_steel", "thickness": 0.0005}}],
               "loads": [{"link": "tip", "force": [0, -1]}]}"""
    m = flexmb.files.loads(text)
    ref = models.cantilever(elements=12, thickness=5e-4, material="spring_steel")
    ref.apply_force("tip", (0.0, -1.0))
    same_solution(flexmb.solve(ref), flexmb.solve(m))


def test_a_section_without_shear_deformation_round_trips(tmp_path):
    import attrs

    s = attrs.evolve(flexmb.rectangle(0.02, 1e-3, 200e9, 76.9e9), ky=np.inf, kz=np.inf)
    m = models.cantilever(elements=4, section=s)
    m.apply_force("tip", (0.0, -2.0))
    assert '{"float": "inf"}' in files.dumps(m)
    loaded = round_trip(m, tmp_path)
    assert loaded.joints["leaf"].section == s
    same_solution(flexmb.solve(m), flexmb.solve(loaded))
