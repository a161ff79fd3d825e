"""What a run writes: every figure the figure registry names is written, readable and embedded in the
report once; every number the report states with decimals is a value of results.json. The figure
cache: a figure is redrawn only when what it shows changes; a damaged entry is redrawn; a figure reads
only the config keys it declares."""

import json
import math
import re
import shutil

import numpy as np
import pytest
from PIL import Image

import pipeline
from pipeline.engine import paths
from pipeline.isa.architectures import VENDORS
from pipeline.publish.figures import FIGURES
from pipeline.runner import run_derivation

# A decimal number as the report prints it: 0.448142, 1.2567 %, 6.3e-05, -0.0532 (integers are counts,
# exponents n, figure and section numbers, and are not checked here).
NUMBER = re.compile(r"(?<![\w.^/])([-+]?\d+\.\d+(?:e[-+]?\d+)?)( %)?(?![\w.])")


def figure_files(config):
    for f in FIGURES:
        if "{n}" in f.file:
            yield from (f.file.format(n=f"{n:g}") for n in config["render.exponents"])
        else:
            yield f.file


def test_every_figure_is_written_readable_and_embedded_once(paper_outputs, paper_config):
    out = paper_outputs[0] / "paper"
    report = (out / "report.md").read_text()
    names = list(figure_files(paper_config))
    per_n = sum("{n}" in f.file for f in FIGURES)
    assert per_n == 3 and len(names) == len(FIGURES) + per_n * (len(paper_config["render.exponents"]) - 1)
    for name in names:
        with Image.open(out / name) as image:
            image.verify()
        with Image.open(out / name) as image:
            assert image.size[0] >= 400 and image.size[1] >= 200, name
            pixels = np.asarray(image.convert("L"))
        assert pixels.std() > 1.0, name             # not a blank image
        assert report.count(f"]({name})") == 1, name
    assert sorted(p.name for p in out.glob("*.png")) == sorted(names)


def leaves(value):
    """Every number in a results.json value, recursively; and every number written in its strings
    (formulas, canonical forms, the config's reasons), which the report quotes."""
    if isinstance(value, bool) or value is None:
        return
    if isinstance(value, str):
        for match in NUMBER.finditer(value):
            yield float(match.group(1)) / (100.0 if match.group(2) else 1.0)
    elif isinstance(value, int | float):
        yield float(value)
    elif isinstance(value, dict):
        for v in value.values():
            yield from leaves(v)
    elif isinstance(value, list):
        for v in value:
            yield from leaves(v)


def shown(text: str, value: float, percent: bool) -> bool:
    """Whether `value` (a fraction if percent) printed at the precision of `text` reads `text`."""
    v = 100.0 * value if percent else value
    target = float(text)
    if "e" in text:
        mantissa = text.split("e")[0]
        digits = len(mantissa.replace("-", "").replace("+", "").replace(".", "").lstrip("0")) or 1
        return math.isclose(float(f"{v:.{digits - 1}e}"), target, rel_tol=1e-9)
    decimals = len(text.split(".")[1])
    return any(math.isclose(round(x, decimals), target, abs_tol=0.6 * 10.0 ** -decimals)
               for x in (v, abs(v) if target >= 0 else -abs(v)))


def report_prose(path) -> str:
    """The report without what it quotes: code blocks (generated jax code, indented) and figure
    links are left out, and on every other line each `quoted span` (code, sympy forms, shader
    bodies, field names), so that the numbers around a quote are still checked."""
    lines = [line for line in path.read_text().splitlines() if not line.startswith(("    ", "def ", "return ", "!["))]
    return "\n".join(re.sub(r"`[^`]*`", "`…`", line) for line in lines)


def test_every_decimal_number_in_the_report_is_a_value_of_results_json(paper_outputs):
    out = paper_outputs[0] / "paper"
    doc = json.loads((out / "results.json").read_text())
    values = np.array(sorted(set(leaves(doc))))
    text = report_prose(out / "report.md")
    missing = []
    for match in NUMBER.finditer(text):
        number, percent = match.group(1), bool(match.group(2))
        target = float(number) / (100.0 if percent else 1.0)
        near = values[np.abs(values - target) <= max(abs(target) * 0.05, 1e-12)]
        near = np.concatenate([near, -near])
        if not any(shown(number, v, percent) for v in near):
            missing.append(match.group(0))
    assert missing == []


@pytest.mark.slow
def test_a_figure_is_redrawn_only_when_what_it_shows_changes(paper_outputs):
    from pipeline.publish.figures import FIGURE_CACHE
    out, _, cache = paper_outputs
    folder = cache / FIGURE_CACHE
    before = {p.name for p in folder.iterdir() if not p.name.startswith(".")}
    config = pipeline.load_config(paths.PAPER_CONFIG, ("scan.curve_points=101",), name="curves")
    run_derivation(config, cache_dir=cache, outputs=out, log=lambda s: None)
    new = {p.name for p in folder.iterdir() if not p.name.startswith(".")} - before
    drawn = {(folder / key / "files.txt").read_text().split()[0] for key in new}
    assert drawn == {"fig2_d_vs_Q.png", "fig3_D_vs_Q.png"}      # the two figures of the scan's curves
    # The copied figures are the paper run's files, byte for byte.
    for name in ("fig6_fQ2_errors.png", "render_n100.png"):
        assert (out / "curves" / name).read_bytes() == (out / "paper" / name).read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["delete", "flip_bytes", "truncate"])
def test_a_damaged_figure_entry_is_reported_by_name_and_redrawn(paper_outputs, paper_config, damage):
    from pipeline.publish.figures import FIGURE_CACHE, FIGURES, figure_key
    out, base, cache = paper_outputs
    fig5 = next(f for f in FIGURES if f.file == "fig5_lobes_n20.png")
    entry = cache / FIGURE_CACHE / figure_key(fig5, paper_config, base.keys)
    png = entry / "fig5_lobes_n20.png"
    good = png.read_bytes()
    if damage == "delete":
        png.unlink()
    elif damage == "flip_bytes":
        png.write_bytes(good[:5000] + bytes(b ^ 0xFF for b in good[5000:5016]) + good[5016:])
    else:
        png.write_bytes(good[: len(good) // 2])
    (out / "paper" / ".stamp").unlink()          # force the outputs to be written again
    log = []
    run_derivation(paper_config, cache_dir=cache, outputs=out, log=log.append)
    said = [line for line in log if "fig5_lobes_n20.png" in line]
    reason = "is missing" if damage == "delete" else "does not match its checksum"
    assert said and f"is damaged (fig5_lobes_n20.png {reason}); redrawing" in said[0]
    # Redrawn: the same bytes as before the damage, in the cache and in the outputs.
    assert png.read_bytes() == good and (out / "paper" / "fig5_lobes_n20.png").read_bytes() == good


@pytest.mark.slow
def test_a_daemonic_process_draws_the_figures_itself_with_the_same_bytes(paper_outputs, paper_config, monkeypatch):
    """Where no child process may start (a Dask worker under its nanny), the figures are drawn in the
    run's own process: the same files as the figure process writes, byte for byte."""
    from pipeline.publish import figures
    out, base, cache = paper_outputs
    fig5 = next(f for f in figures.FIGURES if f.file == "fig5_lobes_n20.png")
    entry = cache / figures.FIGURE_CACHE / figures.figure_key(fig5, paper_config, base.keys)
    good = (entry / "fig5_lobes_n20.png").read_bytes()
    shutil.rmtree(entry)
    (out / "paper" / ".stamp").unlink()          # force the outputs to be written again
    monkeypatch.setattr(figures, "may_start_processes", lambda: False)
    monkeypatch.setattr(figures, "ProcessPoolExecutor", None)       # starting one would fail
    run_derivation(paper_config, cache_dir=cache, outputs=out, log=lambda s: None)
    assert (entry / "fig5_lobes_n20.png").read_bytes() == good
    assert (out / "paper" / "fig5_lobes_n20.png").read_bytes() == good


def test_a_figure_reading_an_undeclared_config_key_is_an_error(paper_config):
    from pipeline.publish.figures import FigureConfig
    view = FigureConfig(paper_config, ("render.*",))
    assert view["render.resolution"] == 512
    with pytest.raises(KeyError, match="figure read config key 'derivation.Q', which it does not declare"):
        view["derivation.Q"]


def test_the_summary_is_one_screen_at_the_top_of_the_report(paper_outputs):
    """summary.md: the rule, the answer per architecture and range, where it differs, and the facts that
    change it, counted; the same text opens report.md (its numbers are checked against results.json with
    the report's, above; its sentences change with the numbers in tests/stages/test_decision.py)."""
    out = paper_outputs[0] / "paper"
    summary = (out / "summary.md").read_text()
    report = (out / "report.md").read_text()
    assert report.split("\n", 2)[2].startswith(summary)
    # one screen: the title, the question, the answer's table (a row per vendor's group), the six cases where
    # it differs (the last: as rendered) and the facts
    assert len(summary.splitlines()) <= 31
    doc = json.loads((out / "results.json").read_text())["stages"]["decision"]
    assert doc["rule"] in summary
    if doc["available"]:
        # Each architecture decided is in exactly one row of the answer (a vendor's that agree share one).
        from pipeline.publish.summary import groups
        table = doc["table"]
        architectures = list(dict.fromkeys(r["architecture"] for r in table))
        grouped = groups(table, architectures, list(dict.fromkeys(tuple(r["n_range"]) for r in table)))
        assert sorted(a for g in grouped for a in g) == sorted(architectures)
        rows = [line for line in summary.splitlines() if line.startswith(tuple(f"| {v} " for v in VENDORS.values()))]
        assert len(rows) == len(grouped) < len(architectures)
        for fact in doc["facts"]:
            assert fact["count"] == 0 or f"{fact['count']} of {fact['of']}" in summary
    for word in ("ship", "verdict"):
        assert word not in summary.lower()


def test_every_text_of_a_figure_names_the_run_s_power(monkeypatch):
    """At lobe.power = 4 every text a reader sees (titles, axis labels, legend, annotations, the
    figure's own title, a colorbar's label) names f_Q4 instead of f_Q2, except names kept by
    `report_beyond.keep`; the tick labels, written by the axes' formatters when drawn, stay numbers."""
    import matplotlib.pyplot as plt
    from pipeline.publish import plots
    from pipeline.publish.report_beyond import keep
    monkeypatch.setattr(plots, "POWER", 4)
    fig, (ax, bx) = plt.subplots(1, 2)
    ax.plot([0, 1], [0, 1], label="f_Q2 (this run)")
    ax.plot([0, 1], [1, 0], label=keep("f_Q2") + " at m = 2")
    ax.legend()
    ax.set(title="max d of f_Q2", xlabel="n of f_Q2", ylabel="f_Q2 / cos^n")
    ax.annotate("f_Q2 here", (0.5, 0.5))
    image = bx.imshow(np.eye(3))
    fig.colorbar(image, ax=bx).set_label("error of f_Q2")
    fig.suptitle("f_Q2 against cos^n; accuracy.d_f_Q2 as a field path")
    plots._names_at_power(fig)
    fig.canvas.draw()
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text")) if t.get_text()]
    plt.close(fig)
    assert {"f_Q4 (this run)", "f_Q2 at m = 2", "max d of f_Q4", "n of f_Q4", "f_Q4 / cos^n", "f_Q4 here",
            "error of f_Q4", "f_Q4 against cos^n; accuracy.d_f_Q2 as a field path"} <= set(texts)
    assert not [t for t in texts if "f_Q2" in t and "m = 2" not in t and "d_f_Q2" not in t]
    assert any(re.fullmatch(r"[\d.−-]+", t) for t in texts)        # tick labels, drawn


@pytest.mark.parametrize("tight", [True, False])
def test_a_figure_is_drawn_once_to_be_saved(tmp_path, tight):
    """`plots._save` draws a figure once, into its file: after tight_layout (which measures the texts
    without drawing) it leaves no layout engine for savefig to draw the figure once more for. The
    file is the one a plain savefig of the same figure writes."""
    import matplotlib.pyplot as plt
    from pipeline.publish import plots

    def figure():
        fig, ax = plt.subplots(figsize=(4, 3))
        ax.plot([1, 10, 100], [0.3, 0.02, 0.01], "o-")
        ax.set(xscale="log", yscale="log", title="a figure", xlabel="n", ylabel="d")
        return fig

    fig = figure()
    draws = []
    fig.canvas.mpl_connect("draw_event", draws.append)
    plots._save(fig, tmp_path, "saved.png", tight=tight)
    assert len(draws) == 1
    plain = figure()
    if tight:
        plain.tight_layout()
    plain.savefig(tmp_path / "plain.png", dpi=110, pil_kwargs=plots.FAST_PNG)
    plt.close(plain)
    assert (tmp_path / "saved.png").read_bytes() == (tmp_path / "plain.png").read_bytes()


def test_the_paper_s_report_html_opens_offline_in_a_browser(paper_outputs):
    """outputs/paper/report.html from file:// in headless Chromium, the network blocked: under 12 MB,
    nothing asked for outside the file, no console error; the checks table holds results.json's
    checks and its filter shows each verdict's; a decision cell opens that architecture's and range's
    lobe front, whose points are the lobe search's candidates and placed lobes there, and the decision's
    candidates there; the albedo is drawn."""
    import json

    from tests.helpers import open_page

    out = paper_outputs[0] / "paper"
    page_path = out / "report.html"
    assert page_path.stat().st_size < 12e6
    doc = json.loads((out / "results.json").read_text())
    with open_page(page_path) as opened:
        page = opened.page
        assert page.locator("#checks-table tbody tr").count() == len(doc["checks"])
        differs = sum(c["verdict"] == "differs (documented)" for c in doc["checks"])
        if differs:
            page.evaluate("pageState.filterChecks('differs (documented)')")
            assert page.locator("#checks-table tbody tr").count() == differs
        cells = page.locator("#decision-table a.cell")
        if doc["stages"]["decision"]["available"] and cells.count():
            cell = cells.nth(cells.count() - 1)
            arch, n_range = cell.get_attribute("data-arch"), cell.get_attribute("data-range")
            cell.click()
            page.wait_for_function(f"document.getElementById('front-plot').dataset.range === {json.dumps(n_range)}"
                                   f" && document.getElementById('front-plot').dataset.arch === {json.dumps(arch)}")
            search = doc["stages"]["lobe_search"]
            lo, hi = (float(v) for v in n_range.removeprefix("n in [").removesuffix("]").split(", "))
            inside = [c for c in search["candidates"] + search["placements"]
                      if c["architecture"] == arch and c["n_range"] == [lo, hi]]
            assert int(page.locator("#front-plot").get_attribute("data-points")) == len(inside)
            # the decision's candidates there: every lobe candidate with a cost on that GPU and d > 0
            candidates = [m for m in doc["stages"]["decision"]["candidates"] if m["use"] == "lobe"
                          and m["n_range"] == [lo, hi] and arch in m["cycles"] and m["d"] > 0]
            page.wait_for_function(f"document.getElementById('cost-plot').dataset.points === '{len(candidates)}'")
        assert page.locator("#albedo-plot svg").count() == 1
        # a lobe front member live on a lit sphere: its values at the pixels' t are the Python twin's
        # (float32 arithmetic against float64: 1e-5 relative to the peak, 1)
        live_rows = page.locator("#front-table tbody tr[data-key^='cosfit_']")
        if live_rows.count():
            import importlib.util

            import numpy as np

            live_rows.first.click()
            page.wait_for_function("window.pageState.live !== null && window.pageState.live.name === window.pageState.lobe")
            live = page.evaluate("pageState.live")
            spec = importlib.util.spec_from_file_location("lobe_search_twin", out / "shader" / "lobe_search_twin.py")
            twin = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(twin)
            values = np.asarray(live["values"], dtype=np.float64).reshape(-1, 4)
            inside = values[values[:, 2] >= 0][::37]
            assert inside.shape[0] > 100
            expected = [getattr(twin, live["name"])(float(t), float(np.float32(live["n"]))) for t in inside[:, 2]]
            np.testing.assert_allclose(inside[:, 0], expected, rtol=0, atol=1e-5)
            assert page.locator("#lobe-code").text_content().startswith(f"float {live['name']}(float t, float n)")
            # its family's per-n optimum over the range's n of the search's grid, the line's max d above it
            page.wait_for_selector("#per-n-plot[data-points]")
            grid = np.asarray(paper_outputs[1].results["lobe_search"]["n_grid"], dtype=np.float64)
            lo, hi = (float(v) for v in page.evaluate("pageState.range").removeprefix("n in [").removesuffix("]").split(", "))
            assert int(page.locator("#per-n-plot").get_attribute("data-points")) == np.sum((grid >= lo) & (grid <= hi))
        assert page.locator("img.figure").count() >= 10
        assert opened.problems == [] and page.evaluate("pageState.errors") == []
        assert all(u.startswith("file://") for u in opened.requests)
