"""The figure cache: a figure is redrawn only when what it shows changes; a damaged entry is redrawn;
a figure reads only the config keys it declares."""

import pytest

import pipeline
from pipeline.engine import paths
from pipeline.run import run_derivation


@pytest.mark.slow
def test_a_figure_is_redrawn_only_when_what_it_shows_changes(paper_outputs):
    from pipeline.publish.figures import FIGURE_CACHE
    out, _, cache = paper_outputs
    folder = cache / FIGURE_CACHE
    before = {p.name for p in folder.iterdir() if not p.name.startswith(".")}
    config = pipeline.load_config(paths.PAPER_CONFIG, ("scan.curve_points=101",), name="curves")
    run_derivation(config, cache_dir=cache, outputs=out, log=lambda s: None)
    new = {p.name for p in folder.iterdir() if not p.name.startswith(".")} - before
    drawn = {(folder / key / "files.txt").read_text() for key in new}
    assert drawn == {"fig2_d_vs_Q.png", "fig3_D_vs_Q.png"}      # the two figures of the scan's curves
    # The copied figures are the paper run's files, byte for byte.
    for name in ("fig6_fQ2_errors.png", "render_n100.png"):
        assert (out / "curves" / name).read_bytes() == (out / "paper" / name).read_bytes()


@pytest.mark.slow
def test_a_damaged_figure_entry_is_redrawn(paper_outputs, paper_config):
    from pipeline.publish.figures import FIGURE_CACHE, FIGURES, figure_key
    out, base, cache = paper_outputs
    fig5 = next(f for f in FIGURES if f.file == "fig5_lobes_n20.png")
    entry = cache / FIGURE_CACHE / figure_key(fig5, paper_config, base.keys)
    (entry / "fig5_lobes_n20.png").unlink()
    (out / "paper" / ".stamp").unlink()          # force the outputs to be written again
    run_derivation(paper_config, cache_dir=cache, outputs=out, log=lambda s: None)
    assert (out / "paper" / "fig5_lobes_n20.png").stat().st_size > 10_000
    assert (entry / "fig5_lobes_n20.png").is_file()


def test_a_figure_reading_an_undeclared_config_key_is_an_error(paper_config):
    from pipeline.publish.figures import FigureConfig
    view = FigureConfig(paper_config, ("render.*",))
    assert view["render.resolution"] == 512
    with pytest.raises(KeyError, match="figure read config key 'derivation.Q', which it does not declare"):
        view["derivation.Q"]
