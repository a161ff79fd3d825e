"""The figures, one registry: each entry is (file, caption, report section, drawing function in
`pipeline.publish.plots`, the stages and config keys it reads). The report embeds each figure
exactly once, in its section.

Figures are drawn into the figure cache (`<cache>/_figures/<key>/`), keyed on the drawing code,
the keys of the stages they read (which are keyed on those stages' values), the config values they
read and the expectations they may mark; a run's outputs copy them from there. `FigureDrawer`
hands each figure to a second process as soon as the stages it reads are done, so the figures are
drawn while later stages compute. This module imports neither matplotlib nor JAX.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import threading
from concurrent.futures import ProcessPoolExecutor, wait
from pathlib import Path

from ..engine.workers import may_start_processes, spawned_pool, submitted
from ..engine.cache import code_hash, digest, discard, sha256, temporary_folder
from ..engine.faults import check_interrupted
from ..engine.graph import RANGE

FIGURE_CACHE = "_figures"       # under the stage cache's root


@dataclasses.dataclass(frozen=True)
class Figure:
    """One figure: its file (or, for one per rendered exponent, a pattern with {n}), caption, the
    report section it belongs to, the name of its drawing function in `plots` (which returns the
    files it wrote), and the stages and config keys it reads: it is passed nothing else."""

    file: str
    caption: str
    section: str
    draw: str
    stages: tuple[str, ...]
    config: tuple[str, ...] = ()


FIGURES = (
    Figure("fig2_d_vs_Q.png", "Fig. 2: max relative error in the epicenter zone versus Q", "paper", "fig2",
           ("q_scan", "f2_errors"), ("derivation.metric",)),
    Figure("fig3_D_vs_Q.png", "Fig. 3: max absolute error versus Q", "paper", "fig3",
           ("q_scan", "f2_errors", "q_choice")),
    Figure("fig4_linear_coefficient.png", "Fig. 4: relative error of the linear coefficient", "paper", "fig4",
           ("linear_coefficient", "q_choice"),
           RANGE + ("derivation.fit", "paper_model.slope", "paper_model.intercept", "paper_model.line_max_rel_error")),
    Figure("fig5_lobes_n20.png", "Fig. 5: f_Q2, f_2 and f_b at n = 20", "paper", "fig5",
           ("accuracy", "linear_coefficient")),
    Figure("fig6_fQ2_errors.png", "Fig. 6: max d and max D of f_Q2 (and f_2) per n", "paper", "fig6",
           ("accuracy", "f2_errors"), RANGE),
    Figure("fig7_dataset.png", "Fig. 7: the ideal normalization dataset", "paper", "fig7",
           ("energy_dataset", "sample"), RANGE),
    Figure("fig9_front.png", "Fig. 9: complexity/error front of coef(n): the exhaustive symbolic regression, "
           "the pysindy sweep and the paper's five TuringBot rows", "paper", "fig9",
           ("symbolic_regression", "sparse_regression"), ("sample.y_decimals",)),
    Figure("fig10_coef_fit.png", "Fig. 10: dataset and coef(n)", "paper", "fig10",
           ("sparse_regression", "energy_dataset", "hemispherical", "sample"), RANGE),
    Figure("fig11_hemispherical.png", "Fig. 11: hemispherical reflectivity minus 1", "paper", "fig11",
           ("hemispherical",), RANGE),
    Figure("zone_sensitivity.png", "Epicenter figures versus the zone level", "zone", "zone_sensitivity",
           ("accuracy", "f2_errors", "zone")),
    Figure("exact_normalization.png", "Energy reflected at normal incidence with each coef(n)",
           "exact_normalization", "exact_normalization", ("exact_normalization", "hemispherical"), RANGE),
    Figure("directional_albedo.png", "Directional albedo at every incidence angle", "directional_albedo",
           "directional_albedo", ("directional_albedo",)),
    Figure("lobe_comparison.png", "Cheap lobes side by side: d and D per n", "lobe_comparison", "lobe_comparison",
           ("lobe_comparison",), RANGE),
    Figure("error_cost_front.png", "The decision's common case per architecture and n range: max d against cycles "
           "of every candidate, the budget and the winner, and the winner at each n", "decision", "error_cost_front",
           ("decision",)),
    Figure("lobe_front.png", "The lobe search: max d against compiled cycles per architecture and n range",
           "lobe_search", "lobe_front", ("lobe_search",)),
    Figure("mitsuba_zoom.png", "Mitsuba: the sphere of the largest n rendered zoomed, so that its statistics rest on "
           ">= 1500 highlight pixels", "mitsuba", "mitsuba_zoom", ("mitsuba_render",)),
    Figure("ndf_comparison.png", "The lobes as microfacet NDFs against Beckmann: d and D per n, and the "
           "distributions at n = 100", "ndf", "ndf_comparison", ("ndf", "linear_coefficient"), RANGE),
    Figure("microfacet_renders.png", "Mitsuba renders with each NDF (Cook-Torrance) and FLIP against Beckmann",
           "ndf", "microfacet_renders", ("microfacet_render",)),
    Figure("render_n{n}.png", "Renders at n = {n}: reference, f_2, f_Q2", "render", "renders", ("render",),
           ("render.*",)),
    Figure("render_shipped.png", "f_Q2 at equal peak and as shipped, with its own exact coef, beside cos^n",
           "render", "render_shipped", ("render",), ("render.resolution", "render.exponents")),
    Figure("render_crops_n{n}.png", "Highlight crops at n = {n}: linear luminance, one scale, and a profile",
           "render", "render_crops", ("render",), ("render.exponents",)),
    Figure("render_errors_n{n}.png", "Render errors at n = {n}: FLIP maps and absolute error", "render", "render_errors", ("render",),
           ("render.exponents",)),
    Figure("mitsuba_renders.png", "Mitsuba path-traced renders (n = 10, 100, 1000 left to right) and FLIP maps",
           "mitsuba", "mitsuba_renders", ("mitsuba_render",)),
    Figure("mitsuba_crops.png", "Mitsuba renders: each sphere's sun highlight, zoomed, with FLIP maps", "mitsuba",
           "mitsuba_crops", ("mitsuba_render",)),
)


# Keys every figure reads: the family's power names the fitted lobe (f_Q2, f_Q3, ...) in its text.
ALWAYS = ("lobe.power",)


class FigureConfig:
    """The config keys a figure declares, and the config's expectations (the paper's values it marks).
    Reading any other key is an error, so a figure's cache key covers everything it reads."""

    def __init__(self, config, keys):
        self.values = config.subset(tuple(keys) + ALWAYS)
        self.expectations = config.expectations

    def __getitem__(self, key):
        if key not in self.values:
            raise KeyError(f"a figure read config key '{key}', which it does not declare in FIGURES")
        return self.values[key]


def figure_key(figure: Figure, config, stage_keys) -> str:
    """A figure's cache key: its drawing code, the keys of the stages it reads, the config values it
    reads, and the expectations it may mark."""
    return digest("figure", figure.file, code_hash("pipeline.publish.plots"),
                  {s: stage_keys[s] for s in figure.stages}, config.subset(tuple(figure.config) + ALWAYS),
                  [dataclasses.asdict(e) for e in config.expectations])


def draw_into_cache(figure: Figure, folder: Path, key: str, config: FigureConfig, results) -> list[str]:
    """Draws one figure into `folder/key/` (a temporary folder published by one rename); returns
    its file names."""
    from . import plots     # matplotlib, only where figures are drawn

    folder.mkdir(parents=True, exist_ok=True)
    tmp = temporary_folder(folder, key)
    try:
        plots.POWER = config["lobe.power"]
        files = getattr(plots, figure.draw)(tmp, config, results)
        files = [files] if isinstance(files, str) else list(files)
        # Each file with its SHA-256: every later read verifies it.
        (tmp / "files.txt").write_text("\n".join(f"{name} {sha256(tmp / name)}" for name in files))
        try:
            os.rename(tmp, folder / key)
        except OSError:
            pass        # published by another run meanwhile: the same inputs, the same figure
        return files
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


# One figure at a time is drawn in this process (the threads of a Dask worker may run several points).
IN_PROCESS = threading.Lock()


class FigureDrawer:
    """Draws the run's figures into the figure cache while the stages compute.

    `update(results, stage_keys)` (after each stage) hands every figure whose stages are all done to
    a second process (started with "spawn" on first need: it imports matplotlib, never JAX), unless
    the cache holds it already; `collect(out)` waits for them and copies every figure into `out`.
    A daemonic process (a Dask worker under its nanny) may not start one: there `collect` draws
    the figures in this process, one at a time (matplotlib's pyplot is not thread-safe), into the
    same cache entries.
    """

    def __init__(self, config, cache_root: Path, log=print):
        self.config = config
        self.log = log
        code_hash("pipeline.publish.plots")     # parsed now, before any stage thread runs (see run_stages)
        self.folder = Path(cache_root) / FIGURE_CACHE
        self.keys: dict[str, str] = {}
        self.pending = {}
        self.pool: ProcessPoolExecutor | None = None

    def _stored(self, key: str, file: str) -> list[str] | None:
        """The files of a complete, verified cache entry, or None: a damaged one (a file missing or
        not matching its checksum) is reported and removed, to be redrawn."""
        folder = self.folder / key
        if not folder.is_dir():
            return None
        try:
            listed = [line.split() for line in (folder / "files.txt").read_text().splitlines()]
            damage = None if listed and all(len(entry) == 2 for entry in listed) else "files.txt is malformed"
            for name, checksum in listed if damage is None else ():
                if not (folder / name).is_file():
                    damage = f"{name} is missing"
                elif sha256(folder / name) != checksum:
                    damage = f"{name} does not match its checksum"
                if damage:
                    break
        except (OSError, UnicodeDecodeError) as e:
            damage = f"{type(e).__name__}: {e}"
        if damage is None:
            return [name for name, _ in listed]
        self.log(f"figure {file}: cache entry {key[:12]} is damaged ({damage}); redrawing")
        discard(folder)
        return None

    def update(self, results, stage_keys) -> None:
        for f in FIGURES:
            if f.file in self.keys or not all(s in results for s in f.stages):
                continue
            key = self.keys[f.file] = figure_key(f, self.config, stage_keys)
            if self._stored(key, f.file) is not None or not may_start_processes():
                continue
            if self.pool is None:
                self.pool = spawned_pool(1)
            self.pending[f.file] = submitted(self.pool, draw_into_cache, f, self.folder, key,
                                             FigureConfig(self.config, f.config),
                                             {stage: results[stage] for stage in f.stages})

    def collect(self, out: Path, results, stage_keys) -> dict[str, list[tuple[str, str]]]:
        """Copies every figure into `out` (drawing what is missing); returns, per report section,
        the (file, caption) of each."""
        self.update(results, stage_keys)
        for future in self.pending.values():
            while not future.done():
                wait([future], timeout=0.5)
                check_interrupted()
            future.result()         # a drawing error surfaces here
        sections: dict[str, list[tuple[str, str]]] = {}
        for f in FIGURES:
            if f.file not in self.keys:
                continue            # a targeted run did not compute what it shows: not drawn
            stored = self.folder / self.keys[f.file]
            files = self._stored(self.keys[f.file], f.file)
            if files is None:       # not drawn by a second process, or removed meanwhile: draw it here
                with IN_PROCESS:
                    from . import plots  # noqa: F401
                    files = draw_into_cache(f, self.folder, self.keys[f.file], FigureConfig(self.config, f.config),
                                            {stage: results[stage] for stage in f.stages})
            os.utime(stored)            # last use, for `pipeline cache --prune`
            for name in files:
                shutil.copyfile(stored / name, out / name)
                n = name.split("_n")[-1][:-4] if "{n}" in f.file else ""
                sections.setdefault(f.section, []).append((name, f.caption.format(n=n)))
        return sections

    def close(self, now: bool = False) -> None:
        """Ends the worker: after its last figure, or (`now`, on an error or an interrupt) at once."""
        if self.pool is None:
            return
        if now:
            for process in list(getattr(self.pool, "_processes", {}).values()):
                process.kill()
        self.pool.shutdown(wait=not now, cancel_futures=True)
        self.pool = None
