"""The documentation site (mkdocs.yml, docs/): every page is in the navigation and every
navigation entry is a page; every name `import flexmb` exports is in the API reference's index,
linked to an object that an API page renders. (CI builds the site with ``mkdocs build --strict``,
which also fails on a page missing from the navigation; this test says so without mkdocs.)"""

import re
from pathlib import Path

import pytest

import flexmb

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _nav_pages(entries) -> list[str]:
    pages = []
    for entry in entries:
        if isinstance(entry, str):
            pages.append(entry)
        elif isinstance(entry, dict):
            for value in entry.values():
                pages += _nav_pages(value) if isinstance(value, list) else [value]
    return pages


def _config() -> dict:
    yaml = pytest.importorskip("yaml")
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))


def test_every_page_is_in_the_navigation():
    nav = _nav_pages(_config()["nav"])
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md"))
    assert sorted(set(pages) - set(nav)) == [], "pages missing from mkdocs.yml's nav"
    assert sorted(set(nav) - set(pages)) == [], "nav entries without a page"
    assert len(nav) == len(set(nav)), "a page twice in the nav"


def test_the_site_builds_strictly():
    config = _config()
    assert config["strict"] is True and config["docs_dir"] == "docs"
    assert all(config["validation"][k] == "warn" for k in ("omitted_files", "unrecognized_links", "anchors"))
    build = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if "mkdocs build" in line]
    assert len(build) == 1 and "--strict" in build[0]
    assert "--quiet" not in build[0] and " -q" not in build[0]  # quiet hides the warnings strict counts: exit 0


def _rendered() -> dict[str, list[str] | None]:
    """Module -> the members its ``:::`` directive lists (None: all of the module's public names)."""
    rendered = {}
    for page in (DOCS / "api").glob("*.md"):
        text = page.read_text(encoding="utf-8")
        for module, options in re.findall(r"^::: ([\w.]+)\n((?:    .*\n)*)", text, flags=re.M):
            listed = re.search(r"members: \[(.*?)\]", options)
            members = [m.strip() for m in listed.group(1).split(",")] if listed else None
            rendered[module] = [] if "members: false" in options else members
    return rendered


def test_every_public_name_is_in_the_api_reference():
    index = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    rendered = _rendered()
    for name in flexmb.__all__:
        row = re.search(rf"^\| \[`flexmb\.{name}`\]\[([\w.]+)\] \|", index, flags=re.M)
        assert row, f"flexmb.{name} is not in docs/api/index.md"
        target = row.group(1)
        if target in rendered:  # a module
            continue
        module, member = target.rsplit(".", 1)
        assert module in rendered, f"flexmb.{name}: no API page renders {module}"
        assert rendered[module] is None or member in rendered[module], f"flexmb.{name}: {module} lists no {member}"
