"""The guide pages' Python examples run as written: each page's ``python`` blocks in one namespace,
in order, in a scratch folder (the README's examples moved here with their text; docs/files.md,
units.md and state-space.md run in tests/test_io_docs.py, the tutorials in tests/test_examples.py)."""

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: page -> marks (slow: a process pool, or more than ~3 s)
PAGES = {"mechanisms.md": (), "sweeps.md": (pytest.mark.slow,), "plots.md": (), "properties.md": (), "accuracy.md": (),
         "paths.md": (), "design-loops.md": ()}


def run_page(page: str) -> dict:
    blocks = re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(encoding="utf-8"), re.S)
    assert blocks, f"{page} has no python block"
    namespace = {"__name__": page}
    for i, code in enumerate(blocks):
        exec(compile(code, f"docs/{page} python block {i + 1}", "exec"), namespace)
    return namespace


@pytest.mark.parametrize("page", [pytest.param(p, marks=m) for p, m in PAGES.items()])
def test_page_python_blocks_run(page, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    monkeypatch.chdir(tmp_path)
    namespace = run_page(page)
    if page == "sweeps.md":
        assert (tmp_path / "pivot.csv").exists() and namespace["table"].n_rows == 9  # the 3 x 3 parameter study
    if page == "plots.md":
        assert (tmp_path / "fourbar.png").stat().st_size > 10_000
        assert (tmp_path / "fourbar.vtu").exists() and (tmp_path / "pivot.pvd").exists()


def test_every_page_with_python_blocks_is_run():
    """A guide page whose examples no test runs is a page that can rot: each is here, in
    test_io_docs, or schematic (docs/design.md's signatures; plugins.md: tests/test_plugin_notch.py
    checks its code is the tested package's)."""
    elsewhere = {"files.md", "units.md", "state-space.md", "design.md", "plugins.md"}
    with_blocks = {p.name for p in DOCS.glob("*.md") if "```python" in p.read_text(encoding="utf-8")}
    assert with_blocks - elsewhere == set(PAGES)
