"""The HTML site builds with MkDocs in strict mode: with the figures of a run, and without any (a fresh
clone, before `make reproduce`); a broken link or a page left out of the navigation fails the build."""

import re
import shutil

import pytest

from .helpers import docs

mkdocs = pytest.importorskip("mkdocs", reason="MkDocs is not installed (make test installs it)")
from mkdocs.exceptions import Abort  # noqa: E402 - after the skip where MkDocs is missing

PNG = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010806000000"
                    "1f15c4890000000d49444154789c6360000002000154a24f5d0000000049454e44ae426082")


def figures():
    names = set()
    for page in docs.prose_pages():
        names |= {m.group("name") for m in docs.FIGURE.finditer(page.read_text())}
    return names


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    from pipeline.engine import paths

    monkeypatch.setattr(paths, "OUTPUTS", tmp_path / "outputs")
    return tmp_path / "outputs"


def test_the_site_builds_strictly_with_a_runs_figures(outputs, tmp_path):
    names = figures()
    assert "fig2_d_vs_Q.png" in names and len(names) > 15
    (outputs / "paper").mkdir(parents=True)
    for name in names:
        (outputs / "paper" / name).write_bytes(PNG)
    docs.build(tmp_path / "site")
    html = (tmp_path / "site" / "derivation" / "index.html").read_text()
    assert re.search(r'<img alt="Fig. 2[^"]*" src="\.\./figures/fig2_d_vs_Q\.png"', html)
    assert all((tmp_path / "site" / "figures" / name).read_bytes() == PNG for name in names)
    home = (tmp_path / "site" / "index.html").read_text()
    assert docs.BEGIN in home and 'href="derivation/"' in home          # the README, its links to the pages


def test_the_site_builds_strictly_on_a_fresh_clone_without_figures(outputs, tmp_path):
    docs.build(tmp_path / "site")
    html = (tmp_path / "site" / "derivation" / "index.html").read_text()
    assert "<img" not in html and "drawn by <code>make reproduce</code>" in html
    assert not (tmp_path / "site" / "figures").exists()


@pytest.mark.parametrize("plant", ["[a page](missing.md)", "[a heading](choices.md#no-such-heading)",
                                   "orphan"])
def test_a_broken_link_or_a_page_outside_the_navigation_fails_the_build(outputs, tmp_path, plant):
    pages = tmp_path / "docs"
    shutil.copytree(docs.DOCS, pages, ignore=shutil.ignore_patterns("_build"))
    if plant == "orphan":
        (pages / "orphan.md").write_text("# A page no one links\n")
    else:
        (pages / "choices.md").write_text((pages / "choices.md").read_text() + f"\n{plant}\n")
    with pytest.raises(Abort):
        docs.build(tmp_path / "site", docs_dir=pages)
