"""Strings for the hypothesis tests: ``utf8_text(...)`` draws what ``st.text(...)`` draws.

``st.text()``'s default alphabet is ``st.characters(codec="utf-8")``: every character
UTF-8 encodes, which is every code point but the surrogates (U+D800–U+DFFF, RFC 3629).
hypothesis finds that set by encoding each of the 1 114 112 code points and keeps it in
``.hypothesis/`` (≈ 1.4 s of CPU in each test process that draws a string before the
file is there: every xdist worker of a fresh clone's run). :data:`UTF8` names the same
set by its category, ``Cs`` excluded, from the Unicode table hypothesis ships: the same
intervals, so the same strings from the same seed (benchmarks/README.md, "Branch
h-tref6").
"""

from hypothesis import strategies as st

#: every character UTF-8 can encode: the code points but the surrogates (category Cs)
UTF8 = st.characters(exclude_categories=("Cs",))


def utf8_text(**sizes) -> st.SearchStrategy[str]:
    """``st.text(**sizes)`` (``min_size``, ``max_size``) over :data:`UTF8`."""
    return st.text(UTF8, **sizes)
