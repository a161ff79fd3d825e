"""The page writer: its data stays data (no text of a run can end its script element), and the page
names nothing outside itself."""

import json
import re

from pipeline.approximate.publishing.derive_page import gles_function
from pipeline.engine import web_page


def test_the_json_island_cannot_end_its_element_and_reads_back_the_same():
    data = {"name": "</script><script>alert(1)</script>", "x": "a & b <!-- c -->", "e": float("inf"), "n": [1.5, None]}
    text = web_page.json_island(data)
    assert "<" not in text and ">" not in text and "&" not in text
    assert json.loads(text) == data | {"e": "inf"}


def test_the_page_asks_for_nothing_outside_the_file():
    """No src or href to anywhere, a policy that forbids every connection, the title as text."""
    page = web_page.page("a <b> & c", {"kind": "none"})
    assert "<title>a &lt;b&gt; &amp; c</title>" in page
    assert re.findall(r"""(?:src|href)\s*=\s*["'](?:https?:)?//""", page) == []
    assert "default-src 'none'" in page and "connect-src" not in page
    assert page.count("<script") == 3 and page.count("</script>") == 3


def test_a_float16_function_becomes_gles_mediump():
    glsl = "// f\nfloat16_t f(float16_t x)\n{\n    return float16_t(0.5)*x + float16_t(1.0);\n}"
    assert gles_function(glsl) == "// f\nmediump float f(mediump float x)\n{\n    return float(0.5)*x + float(1.0);\n}"
    assert gles_function("float g(float x)\n{\n    return x;\n}") == "float g(float x)\n{\n    return x;\n}"
