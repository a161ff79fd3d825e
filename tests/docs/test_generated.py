"""The generated parts of the documentation are up to date: the reference pages (config keys, results.json
keys, command help) and the numbers of the paper's run in the README and docs/ (its results table and every
marked number), each regenerated in memory and compared with the committed text (`make docs` writes them)."""

import copy

import pytest

from .helpers import docs


def test_the_reference_pages_are_generated_from_the_cli_the_config_and_the_graph():
    for path, content in docs.reference_pages().items():
        assert path.exists(), f"{path.name} is missing: run `make docs`"
        assert path.read_text() == content, f"{path.relative_to(docs.ROOT)} is stale: run `make docs`"


def test_the_reference_pages_follow_a_renamed_flag_key_and_field(monkeypatch):
    """A flag, a config key and a stage field renamed in the code change the generated pages."""
    from pipeline.engine import config, graph

    before = docs.reference_pages()
    monkeypatch.setattr(config, "key_table", lambda: "| key |\n|---|\n| `zone.renamed` |")
    stage = graph.STAGES[0]
    monkeypatch.setattr(graph, "STAGES", (type(stage)(stage.name, stage.paper, stage.reads, stage.inputs,
                                                      {"renamed_field": "x"}),) + graph.STAGES[1:])
    from pipeline import cli
    original = cli.build_parser

    def renamed():
        parser = original()
        docs.subparsers(parser)["keys"].add_argument("--renamed-flag")
        return parser
    monkeypatch.setattr(cli, "build_parser", renamed)
    after = docs.reference_pages()
    assert "zone.renamed" in after[docs.REFERENCE / "config.md"] != before[docs.REFERENCE / "config.md"]
    assert "renamed_field" in after[docs.REFERENCE / "results.md"]
    assert "--renamed-flag" in after[docs.REFERENCE / "commands.md"]


@pytest.fixture(scope="module")
def paper_document(paper_run, paper_cache):
    """The paper's run as results.json holds it, from the session's cache (every stage is there)."""
    import pipeline
    from pipeline.engine import paths

    return pipeline.run(paths.PAPER_CONFIG, log=lambda s: None, cache_dir=paper_cache)


def test_the_readme_table_and_the_marked_numbers_are_the_paper_runs(paper_document):
    stale = []
    generated = docs.generated(paper_document)
    for page in docs.prose_pages():
        text = page.read_text()
        expected = generated[page]
        if expected != text:
            lines = [f"  {a!r}\n  -> {b!r}" for a, b in zip(text.splitlines(), expected.splitlines())
                     if a != b]
            stale.append(f"{page.name}:\n" + "\n".join(lines[:5]))
    assert not stale, ("numbers differ from the paper's run (run `make reproduce`, then `make docs`):\n"
                       + "\n".join(stale))


def test_a_moved_number_or_a_renamed_field_fails(paper_document):
    """Planted: a number of the run that moves changes the README's table and a marked number; a marked
    path that names no field is an error naming it."""
    moved = copy.deepcopy(paper_document)
    moved["stages"]["accuracy"]["d_f_Q2"] *= 1.01
    readme = docs.README.read_text()
    assert docs.fill_readme(readme, moved) != readme
    page = docs.DOCS / "choices.md"
    assert docs.fill_numbers(page.read_text(), moved) != page.read_text()
    marked = "1.2 %<!--r accuracy.d_f_Q2 %.1f-->"
    assert docs.fill_numbers(marked, moved) == "1.3 %<!--r accuracy.d_f_Q2 %.1f-->"
    with pytest.raises(docs.MissingField, match="d_f_Q9"):
        docs.fill_numbers("1.2 %<!--r accuracy.d_f_Q9 %.1f-->", paper_document, "page.md")
    with pytest.raises(docs.MissingField, match="no row with architecture=rdna9"):
        docs.fill_numbers("4<!--r decision.table[architecture=rdna9].winner_cycles d-->", paper_document)


def test_numbers_of_slow_commands_come_from_their_records(monkeypatch):
    """A number marked `measured[NAME]...` is the record's (`docs/measured/NAME.json`, written by
    `make bench` or `make measure`), with no run of the paper needed; benchmarks.md's table is the bench
    record's rows. Planted records move them; a record or field that does not exist is named."""
    planted = {"bench": {"rows": {"cold reproduce (empty cache)": dict(
        seconds=61.5, ratio=20.5, target=12.0, met=False, note="99 | compilations", floor=3.0, date="2026-01-01",
        commit="abc1234", cores=2)}, "throughput": {}},
        "derive_schlick": {"wall_seconds": 99.0, "verdict_rows": [
            dict(architecture="rdna3", anchor="Karis", verdict="beaten", ratio=0.83),
            dict(architecture="sm_89", anchor="Karis", verdict="missed", ratio=1.2)]}}
    monkeypatch.setattr(docs, "measured_records", lambda: planted)
    assert docs.fill_numbers("took 12<!--r measured[bench].rows[cold reproduce (empty cache)].seconds .1f--> s", None) \
        == "took 61.5<!--r measured[bench].rows[cold reproduce (empty cache)].seconds .1f--> s"
    text = "beaten on 1<!--r measured[derive_schlick].verdict_rows[verdict=beaten]# d--> of 9<!--r " \
           "measured[derive_schlick].verdict_rows# d-->"
    assert docs.fill_numbers(text, None) == text.replace("of 9", "of 2")
    # a number of the paper's run is left alone where there is no run
    assert docs.fill_numbers("1.2 %<!--r accuracy.d_f_Q2 %.1f-->", None) == "1.2 %<!--r accuracy.d_f_Q2 %.1f-->"
    with pytest.raises(docs.MissingField, match="derive_acos"):
        docs.fill_numbers("1<!--r measured[derive_acos].wall_seconds d-->", None, "page.md")
    table = docs.fill_bench(f"a\n{docs.BENCH_BEGIN}\nstale text\n{docs.BENCH_END}\nb")
    assert "| cold reproduce (empty cache) | 61.5 | 20.5 | 12x | no | 99 &#124; compilations | 3.00 |" in table
    assert "stale text" not in table


def test_every_record_a_page_names_exists_and_every_record_is_named():
    """docs/measured/ holds the records the pages read, and no record nobody reads."""
    import re

    named = {m for page in docs.prose_pages() for m in re.findall(r"measured\[(\w+)\]", page.read_text())}
    if any(docs.BENCH_BEGIN in page.read_text() for page in docs.prose_pages()):
        named.add("bench")
    assert named == set(docs.measured_records())


def test_make_bench_records_its_timed_rows(tmp_path, monkeypatch):
    """bench.py's record: each timed row under its label with its ratio to the floor and whether it met
    its target, and the row's own measured fields (a peak memory) beside them; a later run keeps the rows
    it did not measure and replaces those it did."""
    import importlib.util
    import json

    spec = importlib.util.spec_from_file_location("bench_script", docs.ROOT / "bench" / "bench.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    monkeypatch.setattr(bench, "RECORD", tmp_path / "measured" / "bench.json")
    monkeypatch.setattr(bench, "ROOT", tmp_path)
    bench.record([("cold reproduce (empty cache)", 30.0, 12.0, "n"), ("warm reproduce", 1.0, 1.2, "w")], 2.0,
                 [("CPU", [("f_Q2", 6.2e8, 6e8, 6.4e8)])])
    bench.record([("warm reproduce", 3.0, 1.2, "w"), ("regress a case", 40.0, None, "r", dict(peak_gb=0.61))], 2.0, [])
    rows = json.loads(bench.RECORD.read_text())["rows"]
    assert rows["regress a case"]["peak_gb"] == 0.61 and rows["regress a case"]["met"] is None
    del rows["regress a case"]
    assert set(rows) == {"cold reproduce (empty cache)", "warm reproduce"}
    assert rows["cold reproduce (empty cache)"]["ratio"] == 15.0 and rows["cold reproduce (empty cache)"]["met"] is False
    assert rows["warm reproduce"]["seconds"] == 3.0 and rows["warm reproduce"]["met"] is False
    assert json.loads(bench.RECORD.read_text())["throughput"]["CPU"]["f_Q2"] == 6.2e8
    # as printed: a ratio's verdict, none without a target (make test's kept row)
    assert bench.verdict(30.0, 2.0, 12.0, {}) == "<= 12x MISSED" and bench.verdict(1.0, 2.0, None, {}) == ""
    # a target in seconds (make test's): met by the seconds whatever the floor, and shown as seconds
    for seconds, floor, expected in ((359.0, 0.5, True), (361.0, 9.0, False)):
        bench.record([("make test, XLA cache empty", seconds, None, "t", dict(target_seconds=360.0))], floor, [])
        row = json.loads(bench.RECORD.read_text())["rows"]["make test, XLA cache empty"]
        assert row["met"] is expected and row["target_seconds"] == 360.0
        assert bench.verdict(seconds, floor, None, dict(target_seconds=360.0)) == (
            "<= 360 s ok" if expected else "<= 360 s MISSED")
        cell = "| 360 s | yes |" if expected else "| 360 s | no |"
        assert cell in docs.bench_table(json.loads(bench.RECORD.read_text()))
