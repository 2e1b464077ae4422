"""The README's Python examples run as written (in one namespace, in order, in a scratch folder);
its two Quickstart commands are the ones CI and the benchmarks use; it stays a newcomer's page
(at most 250 lines: the rest is the documentation site, docs/)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert len(blocks) >= 2  # a first mechanism; units, materials and a mechanism file
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "readme"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"README.md python block {i + 1}", "exec"), namespace)
    assert namespace["sol"].converged and (tmp_path / "stage.json").exists()


def test_readme_is_short_and_its_quickstart_is_two_commands():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    quickstart = re.search(r"## Quickstart\n.*?```bash\n(.*?)```", text, re.S).group(1).strip().splitlines()
    assert len(quickstart) == 2
    assert quickstart[0].startswith("python -m pip install ") and "&& flexmb demo" in quickstart[0]
    assert quickstart[1] == 'python -m pip install ".[test]" && python -m pytest'
    assert 'pip install --quiet ".[test]"' in (README.parent / ".ci" / "run").read_text()


def test_readme_links_resolve():
    """Every relative link of the README names a file of the checkout (and an anchor of a docs
    page one of its headings), so the README's map of the documentation does not rot."""
    text = README.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(((?!https?:)[^)]+)\)", text):
        path, _, anchor = target.partition("#")
        file = README.parent / (path or "README.md")
        assert file.exists(), target
        if anchor and file.suffix == ".md":
            slugs = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
                     for h in re.findall(r"^#+ (.*)$", file.read_text(encoding="utf-8"), re.M)}
            assert anchor in slugs, target


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
