"""Every command the README and docs/ name exists as written: each `pipeline` command's subcommand and
flags are in the CLI's parsers, each `make` target is in the Makefile, each config key given to `--set`,
`SET=` or `pipeline explain` is a config key, and each `section.key` or `stage.field` in a code span is
a config key or a field of the stage graph. Each code block is run by a test or marked with why not."""

import re
import shlex

import pytest

from .helpers import docs

SPAN = re.compile(r"(?<!`)`([^`\n]+(?:\n[^`\n]+)?)`(?!`)")
PIPELINE = re.compile(r"(?:^|(?<=[\s/(]))pipeline ([a-z][a-z-]*)((?:[^;&|#\n`]|\n(?=\S))*)")
FILES = {"csv", "png", "json", "md", "glsl", "hlsl", "toml", "py", "txt", "brdf"}
MAKE = re.compile(r"(?:^|(?<=\s))make ([a-z][a-z-]*)")


def snippets(page):
    """(where, text) of every code block and every code span of a page, HTML comments left out."""
    text = re.sub(r"<!--.*?-->", "", page.read_text(), flags=re.DOTALL)
    blocks = list(re.finditer(r"^```(\w*)\n(.*?)^```", text, re.DOTALL | re.MULTILINE))
    out = [(f"{page.name}:{text[:m.start()].count(chr(10)) + 1}", m.group(2)) for m in blocks
           if m.group(1) not in ("text", "python")]
    prose = re.sub(r"^```.*?^```", "", text, flags=re.DOTALL | re.MULTILINE)
    out += [(f"{page.name} `{m.group(1)[:40]}`", m.group(1)) for m in SPAN.finditer(prose)]
    return out


def commands(text):
    """(subcommand, words) of each `pipeline SUB ...` in a snippet; a command ends at a line end, ;, &&,
    | or #."""
    for line in text.replace("\\\n", " ").splitlines():
        for m in PIPELINE.finditer(line):
            yield m.group(1), m.group(2).split()


def parser_flags():
    from pipeline.cli import build_parser

    subs = docs.subparsers(build_parser())
    return {name: {s for a in p._actions for s in a.option_strings} for name, p in subs.items()}


def config_keys():
    from pipeline.engine.config import SCHEMA

    return {k.name for k in SCHEMA}


def stage_fields():
    from pipeline.engine import graph

    return set(graph.output_paths())


def bad_names(pages):
    flags = parser_flags()
    keys, fields = config_keys(), stage_fields()
    sections = {k.split(".")[0] for k in keys} | {f.split(".")[0] for f in fields}
    targets = set(re.findall(r"^([a-z][a-z-]*):", (docs.ROOT / "Makefile").read_text(), re.MULTILINE))
    bad = []
    for page in pages:
        for where, text in snippets(page):
            for sub, words in commands(text):
                if sub not in flags:
                    bad.append(f"{where}: pipeline {sub}: no such command")
                    continue
                for word in words:
                    flag = word.split("=", 1)[0].rstrip(",.)]")
                    if flag.startswith("--") and flag not in flags[sub] and flag != "--help":
                        bad.append(f"{where}: pipeline {sub} {flag}: no such flag")
                if sub == "explain":
                    bad += [f"{where}: explain {w}: no config key" for w in words
                            if re.fullmatch(r"[a-z_]+\.\w+=\S*", w) and w.split("=")[0] not in keys]
            for m in MAKE.finditer(text):
                if m.group(1) not in targets:
                    bad.append(f"{where}: make {m.group(1)}: no such target")
            given = [k for group in re.findall(r'SET="([^"]*)"', text)
                     for k in re.findall(r"(\w+\.\w+)=", group)]
            for key in re.findall(r"--set[ =](\w+\.\w+)=", text) + given:
                if key not in keys:
                    bad.append(f"{where}: {key}: no config key")
            word = text.strip()
            head, _, tail = word.partition(".")
            if re.fullmatch(r"\w+\.[\w*]+", word) and head in sections and tail not in FILES:
                if word.endswith("*"):
                    if not any(n.startswith(word[:-1]) for n in keys | fields):
                        bad.append(f"{where}: {word}: matches no config key or field")
                elif word not in keys and word not in fields:
                    bad.append(f"{where}: {word}: no config key or stage field")
    return bad


def test_every_command_flag_key_and_field_the_pages_name_exists():
    assert bad_names(docs.all_pages()) == []


def test_a_renamed_flag_command_target_or_key_is_found(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("Run `pipeline regress data.csv --x x --y y --max-complexty 4` or\n\n```\n"
                    "pipeline refit --config c.toml --set derivation.QQ=0.5 --only accuracy\n"
                    "pipeline frobnicate\nmake reproduce && make tset\n```\n\n"
                    "See `accuracy.d_f_Q3`, `zone.levell` and `lobe_search.grammar_*`, "
                    "`lobe_search.nothing_*`.\n")
    assert bad_names([page]) == [
        "page.md:3: pipeline frobnicate: no such command",
        "page.md:3: make tset: no such target",
        "page.md:3: derivation.QQ: no config key",
        "page.md `pipeline regress data.csv --x x --y y --`: pipeline regress --max-complexty: no such flag",
        "page.md `accuracy.d_f_Q3`: accuracy.d_f_Q3: no config key or stage field",
        "page.md `zone.levell`: zone.levell: no config key or stage field",
        "page.md `lobe_search.nothing_*`: lobe_search.nothing_*: matches no config key or field",
    ]


def test_every_code_block_is_run_or_marked_with_its_reason():
    blocks = [b for page in docs.all_pages() for b in docs.code_blocks(page)]
    assert len(blocks) > 10
    for block in blocks:
        where = f"{block.page.name}:{block.line}"
        if block.mark.startswith("illustrative:"):
            reason = block.mark.split(":", 1)[1].strip()
            assert len(reason) > 5, f"{where}: an illustrative block needs its reason"
        elif block.mark.startswith("tested:"):
            path, _, name = block.mark.split(":", 1)[1].strip().partition("::")
            source = docs.ROOT / path
            assert source.exists() and f"def {name}(" in source.read_text(), f"{where}: no test {block.mark}"
        else:
            assert block.language in ("", "python", "text"), f"{where}: a {block.language} block cannot run"


@pytest.mark.parametrize("line", ["pipeline keys", ".venv/bin/pipeline regress f.csv --x x --y y --seed 1"])
def test_the_parser_of_commands_reads_what_a_shell_reads(line):
    sub, words = next(commands(line))
    assert [sub] + words == shlex.split(line.split("pipeline ", 1)[1])
