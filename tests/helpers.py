"""Helpers shared by the tests."""

import contextlib
import os

import pytest


def cli_env(tmp_path, **extra):
    """Environment for running the CLI in a subprocess with its own cache and outputs; compiled XLA
    programs are shared by the session's subprocesses (the stage cache is what the tests test)."""
    from pipeline.engine import paths

    xla = paths.XLA_CACHE or str(tmp_path.parent / "xla")      # the session's (conftest), where it is set
    return dict(os.environ, PIPELINE_CACHE_DIR=str(tmp_path / "cache"), PIPELINE_OUTPUTS_DIR=str(tmp_path / "out"),
                PIPELINE_XLA_CACHE_DIR=xla, **extra)



@contextlib.contextmanager
def busy_cores(count: int = 2):
    """`count` other processes spinning on the CPU while the block runs (both cores of this machine
    busy with another process), stopped after it, or earlier by the function the block is given."""
    import subprocess
    import sys

    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]

    def stop():
        for p in spinners:
            p.kill()
            p.wait()

    try:
        yield stop
    finally:
        stop()


PLANTED_SLOW_RATES = {kind: dict(screen_s=1e-2, refit_s=1e-2, polish_s=1e-2, compile_s=500.0, operon_s=1.0)
                      for kind in ("arithmetic/squares", "arithmetic/max", "functions/squares", "functions/max")}


def copy_cache(source, target):
    """A copy of the session's shared cache, which the other worker may be writing meanwhile: its
    hidden entries (a writer's temporary folder, the `.in-use` lock file) are left out, since they
    can vanish while the copy runs; published entries are never changed in place."""
    import shutil

    shutil.copytree(source, target, ignore=shutil.ignore_patterns(".*"))


def require_fast_variant(variant: str, why: str) -> None:
    """Skips a test that needs Mitsuba's vectorized variant where it cannot run here (no LLVM, only
    Debian 12's LLVM 15, which aborts renders, or PIPELINE_MITSUBA_VARIANT forcing another), with
    `why`; fails where an LLVM >= 16 was found and still the fallback was taken: the tool was found
    but not used."""
    from pipeline.engine import toolchains
    from pipeline.mitsuba import bsdf

    if variant == bsdf.FAST_VARIANT:
        return
    found = toolchains.locate("llvm")
    if found.found and int(found.version or 0) >= 16 and not os.environ.get(toolchains.VARIANT_VARIABLE):
        pytest.fail(f"LLVM {found.version} ({found.path}) was found, yet Mitsuba runs {variant}")
    pytest.skip(why)


def spirv_tools_missing() -> str | None:
    """Why spirv-opt (the per-operation emulation's front end) cannot run here, or None."""
    from pipeline.optics import spirv

    try:
        spirv.tool("spirv-opt")
    except spirv.ToolMissing as e:
        return str(e)
    return None


CHROMIUM_ARGS = ["--no-sandbox", "--disable-background-networking", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader"]


def chromium_path() -> str | None:
    """Debian's Chromium (`make test` installs it best effort), or None."""
    import shutil

    return shutil.which("chromium") or shutil.which("chromium-browser")


class OpenedPage:
    """A page opened from file:// in headless Chromium with the network blocked: `page` (Playwright's),
    `requests` (every URL the page asked for), `problems` (console errors and uncaught exceptions)."""

    def __init__(self, page):
        self.page, self.requests, self.problems = page, [], []


def open_page(path, ready: str = "body[data-ready='1']"):
    """A context manager: `path` opened in a fresh headless Chromium profile (Playwright driving
    the system's browser; SwiftShader's WebGL2), every request but file:// aborted, waiting for the
    selector `ready`. Skips the test, naming what is missing, where Playwright or Chromium is absent."""
    import contextlib

    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed: the page was not opened in a browser")
    executable = chromium_path()
    if executable is None:
        pytest.skip("Chromium is not installed (apt-get install chromium): the page was not opened in a browser")

    @contextlib.contextmanager
    def opened():
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
            try:
                page = browser.new_page(viewport={"width": 1300, "height": 1000})
                out = OpenedPage(page)
                page.on("console", lambda m: out.problems.append(m.text) if m.type == "error" else None)
                page.on("pageerror", lambda e: out.problems.append(str(e)))

                def route(r):
                    out.requests.append(r.request.url)
                    if r.request.url.startswith("file://"):
                        r.continue_()
                    else:
                        r.abort()

                page.route("**/*", route)
                page.goto(f"file://{path}")
                page.wait_for_selector(ready, state="attached", timeout=30000)
                yield out
            finally:
                browser.close()

    return opened()
