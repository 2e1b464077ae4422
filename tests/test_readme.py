"""The README's Python examples run as written (in one namespace, in order, in a scratch folder)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert len(blocks) >= 4  # composing, writing a joint, sweeps, studies, plots
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "readme"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"README.md python block {i + 1}", "exec"), namespace)
    assert (tmp_path / "pivot.csv").exists() and (tmp_path / "fourbar.png").stat().st_size > 10_000
    assert (tmp_path / "fourbar.vtu").exists() and (tmp_path / "pivot.pvd").exists()
    assert namespace["table"].n_rows == 9  # the 3 x 3 parameter study


def test_strategies_page_options_table_is_the_strategies_defaults():
    """The strategies page's 'method | options (default)' table (docs/strategies.md, moved there
    from the README) lists every option of every strategy with the
    default the code has (flexmb.solvers.options_doc reads the attrs fields): a changed default
    (rtol 1e-8 -> 1e-9 in issue 19) must change the table too."""
    from flexmb.solvers import STRATEGIES, options_doc

    text = (Path(__file__).resolve().parents[1] / "docs" / "strategies.md").read_text(encoding="utf-8")
    for name, cls in STRATEGIES.items():
        row = re.search(rf'^\| `"{re.escape(name)}"` \| (`\w+` \(.*?\)(?:, `\w+` \(.*?\))*) \|$', text, re.M)
        assert row, f"docs/strategies.md has no options row for {name!r}"
        expected = ", ".join(f"`{opt}` ({default!r})" for opt, default, _ in options_doc(cls))
        assert row.group(1) == expected
