"""Outside text stays text in every format the pipeline writes (`engine.escape`): rendered by the
format's own reader (Python-Markdown with tables, matplotlib's mathtext test, Python's parser, an
HTML parser), each hostile string comes back as it was, as text."""

import ast
import json
from html.parser import HTMLParser

import pytest

from pipeline.engine import escape

HOSTILE = ["</script><script>alert(1)</script>", "Karis 2013 | $5.55$ `tick`", "a *b* _c_ [d](e) ![f](g) \\| \\",
           "```", "x <!-- y", "&amp; &lt; &#124;", "$$ x $$", "'\"\"\" quotes"]


class Cells(HTMLParser):
    """The text of each table cell and whether any element other than the table's and <code> came."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.cells, self.others, self.inside = [], [], False

    def handle_starttag(self, tag, attrs):
        if tag in ("td", "th"):
            self.cells.append("")
            self.inside = True
        elif tag not in ("table", "thead", "tbody", "tr", "code", "p"):
            self.others.append(tag)

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.inside = False

    def handle_data(self, data):
        if self.inside:
            self.cells[-1] += data


@pytest.mark.parametrize("text", HOSTILE)
def test_markdown_cells_show_the_text_as_it_is(text):
    import markdown

    rendered = markdown.markdown(f"| a | b | c |\n|---|---|---|\n| {escape.markdown(text)} | {escape.code(text)} | "
                                 f"{escape.code('x**2')} |\n", extensions=["tables"])
    cells = Cells()
    cells.feed(rendered)
    assert cells.others == [] and cells.cells == ["a", "b", "c", text, text, "x**2"]
    prose = markdown.markdown(f"Target: {escape.markdown(text)} and {escape.code(text)}.")
    cells = Cells()
    cells.feed(prose.replace("<p>", "<td>").replace("</p>", "</td>"))
    assert cells.others == [] and cells.cells == [f"Target: {text} and {text}."]


@pytest.mark.parametrize("text", HOSTILE + ["a\nb\rc\u2028d"])
def test_labels_comments_strings_and_html_keep_the_text(text):
    import matplotlib.text

    label = escape.mathtext(text)
    assert matplotlib.text.Text(text=label)._preprocess_math(label)[1] is False
    line = escape.one_line(text)
    assert "\n" not in escape.comment(text) and not escape.comment(text).endswith("\\")
    assert ast.literal_eval(escape.python_string(text)) == text
    html = escape.html(text)
    assert "<" not in html and ">" not in html and '"' not in html
    script = escape.script_json({"name": text})
    assert "</" not in script and "<!--" not in script and json.loads(script) == {"name": text}
    assert line.replace(" ", "") == "".join(text.split())


@pytest.mark.parametrize("text, name", [("</script><script>alert(1)</script>_poly", "script_script_alert_1_script_poly"),
                                        ("2x", "f_2x"), ("gl_Position", "f_gl_Position"), ("main", "f_main"),
                                        ("a__b", "a_b"), ("\u00e9t\u00e9", "t"), ("", "f"), ("lambda", "f_lambda")])
def test_function_names_are_identifiers_of_every_language(text, name):
    assert escape.identifier(text) == name and name.isascii() and name.isidentifier()


@pytest.mark.parametrize("text, folder", [("../../etc", "_.._etc"), (".hidden", "hidden"), ("a b/c", "a_b_c"),
                                          ("</script>", "__script_"), ("", "target")])
def test_a_folder_name_never_leaves_its_parent(text, folder):
    assert escape.folder_name(text) == folder and "/" not in folder and not folder.startswith(".")
