"""The pages docs/files.md, docs/units.md and docs/state-space.md: their Python blocks run, their JSON
example is a mechanism file, and their tables are the code's (units, materials)."""

import re
from pathlib import Path

import numpy as np
import pytest

import flexmb
from flexmb import materials, units

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAGES = ("files.md", "units.md", "state-space.md")


def blocks(page: str, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", (DOCS / page).read_text(), flags=re.S)


@pytest.mark.parametrize("page", PAGES)
def test_python_blocks_run(page, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # files.md writes fourbar.json
    found = blocks(page, "python")
    assert found, page
    for code in found:
        exec(compile(code, f"{page} python block", "exec"), {})


def test_the_files_page_example_is_a_mechanism_file():
    (doc,) = blocks("files.md", "json")
    m = flexmb.files.loads(doc)
    assert m.units.name == "mm-N-MPa" and m.joints["left"].material == flexmb.material("spring_steel", "mm-N-MPa")
    sol = flexmb.solve(m)
    assert sol.converged and np.isclose(sol.pose("block")[0][0], 2.0)


def test_the_units_tables_are_the_codes():
    text = (DOCS / "units.md").read_text()
    for u in units.SYSTEMS.values():
        row = re.search(rf"^\| `{re.escape(u.name)}` \|(.*)$", text, flags=re.M).group(1)
        cells = [c.strip() for c in row.strip(" |").split("|")]
        qs = ("length", "force", "time", "mass", "stress", "density", "moment", "inertia", "frequency", "stiffness",
              "rotational stiffness", "compliance")
        assert cells == [u.label(q) for q in qs], u.name
    for name in materials.CATALOGUE:
        m = flexmb.material(name)
        row = re.search(rf"^\| `{name}` \|(.*)$", text, flags=re.M).group(1)
        E, G, nu, rho, ys = (float(c) for c in row.strip(" |").split("|")[:5])
        assert (E, rho, ys) == (m.E / 1e9, m.density, m.yield_stress / 1e6), name
        assert G == pytest.approx(m.G / 1e9, rel=1e-3) and nu == pytest.approx(m.nu, abs=1e-3), name


def test_the_state_space_page_shows_its_figure():
    assert "![Bode plot" in (DOCS / "state-space.md").read_text()
    assert (DOCS / "state_space_bode.png").stat().st_size > 10_000
