"""Every hypothesis string of the suite is drawn over tests/hypothesis_text.py's UTF8: a
``st.text()`` without an alphabet makes hypothesis build its UTF-8 table by encoding every
code point (≈ 1.4 s of CPU in each test process of a fresh clone), one such call in any
file is enough for a worker to pay it."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def _default_alphabet_texts(source: str) -> list[int]:
    """Lines of ``st.text(...)`` / ``strategies.text(...)`` calls without an alphabet."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and node.func.attr == "text" and isinstance(node.func.value, ast.Name)
                and node.func.value.id in {"st", "strategies"}
                and not node.args and all(k.arg != "alphabet" for k in node.keywords)):
            lines.append(node.lineno)
    return lines


def test_no_test_draws_text_over_the_default_alphabet():
    found = {}
    for path in sorted(TESTS.rglob("*.py")):
        source = path.read_text()
        if "hypothesis" in source and (lines := _default_alphabet_texts(source)):
            found[str(path.relative_to(TESTS))] = lines
    assert not found, f"st.text() without an alphabet (use hypothesis_text.utf8_text): {found}"


def test_the_check_finds_a_default_alphabet():
    assert _default_alphabet_texts("st.text(max_size=3)\nst.text('ab')\n"
                                   "st.text(alphabet=x)\nutf8_text()\n") == [1]
