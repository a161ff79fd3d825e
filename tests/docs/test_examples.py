"""Every code block of the README and docs/ that is not marked illustrative (or run by a named test) runs
as written, in page order, in a scratch folder with its own outputs and a copy of the session's stage
cache (so that a refit of the paper's settings computes only what it changes): shell blocks with bash,
Python blocks in this process."""

import contextlib
import io
import os
import subprocess

import pytest

from tests.helpers import cli_env, copy_cache

from .helpers import docs


@pytest.fixture
def workspace(paper_run, paper_cache, tmp_path):
    copy_cache(paper_cache, tmp_path / "cache")
    for name in ("configs", "tests", ".venv"):
        (tmp_path / name).symlink_to(docs.ROOT / name)
    (tmp_path / "outputs").mkdir()
    return tmp_path


def run_block(block, workspace, monkeypatch) -> str:
    """Runs one block; returns "" or what went wrong, with its output."""
    where = f"{block.page.name}:{block.line}"
    if block.language == "python":
        from pipeline.engine import paths

        monkeypatch.setattr(paths, "CACHE", workspace / "cache")
        monkeypatch.setattr(paths, "OUTPUTS", workspace / "outputs")
        monkeypatch.chdir(workspace)
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out):
                exec(compile(block.code, where, "exec"), {})
        except Exception as e:
            return f"{where}: {type(e).__name__}: {e}\n{out.getvalue()[-2000:]}"
        return ""
    env = cli_env(workspace, PATH=f"{docs.ROOT / '.venv' / 'bin'}{os.pathsep}{os.environ['PATH']}")
    env["PIPELINE_OUTPUTS_DIR"] = str(workspace / "outputs")
    done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block.code], cwd=workspace, env=env,
                          capture_output=True, text=True, timeout=600)
    return "" if done.returncode == 0 else \
        f"{where}: exit {done.returncode}\n{(done.stdout + done.stderr)[-2000:]}"


def runnable(pages):
    return [b for page in pages for b in docs.code_blocks(page) if not b.mark and b.language != "text"]


def test_every_runnable_example_of_the_pages_runs(workspace, monkeypatch):
    blocks = runnable(docs.prose_pages())
    assert {b.language for b in blocks} == {"", "python"} and len(blocks) >= 8
    failed = [f for f in (run_block(b, workspace, monkeypatch) for b in blocks) if f]
    assert failed == [], "\n\n".join(failed)


def test_a_failing_example_fails(tmp_path, monkeypatch):
    """A flag the CLI does not have, a failing command inside a block and a Python error are reported."""
    page = tmp_path / "page.md"
    page.write_text("```\npipeline keys --nope\n```\n\n```\nfalse\npipeline keys\n```\n\n"
                    "```python\nimport pipeline\npipeline.load_config('configs/nothing.toml')\n```\n\n"
                    "<!-- illustrative: planted -->\n```\nfalse\n```\n")
    for name in ("configs", "tests", ".venv"):
        (tmp_path / name).symlink_to(docs.ROOT / name)
    blocks = runnable([page])
    assert len(blocks) == 3
    results = [run_block(b, tmp_path, monkeypatch) for b in blocks]
    assert results[0].startswith("page.md:1: exit 2") and "--nope" in results[0]
    assert results[1].startswith("page.md:5: exit 1")
    assert results[2].startswith("page.md:10:") and "nothing.toml" in results[2]
