"""Invariants of the batch's result file names (hypothesis): whatever the spec names,
every result gets its own safe file, the same one on every run."""

from __future__ import annotations

import re

from hypothesis import given, settings
from hypothesis import strategies as st

from hypothesis_text import utf8_text

from feedtune.batch.inputs import MAX_STEM, RESERVED_STEMS, Item, assign_stems, safe_stem

names = st.lists(st.one_of(utf8_text(min_size=0, max_size=150),
                           st.sampled_from(["summary", "Summary", "a", "A", "a-2", "..", "/", "ä"])),
                 min_size=1, max_size=30)


def _items(specs: list[str]) -> list[Item]:
    return [Item(i, f"in/{i}.json", f"in/{i}.json", None, b"{}", None, name)
            for i, name in enumerate(specs)]


@settings(max_examples=300, deadline=None)
@given(names)
def test_stems_are_unique_without_case_safe_and_never_reserved(specs):
    items = _items(specs)
    assign_stems(items)
    stems = [item.stem for item in items]
    assert len({s.lower() for s in stems}) == len(stems)
    for stem in stems:
        assert re.fullmatch(r"[A-Za-z0-9._-]+", stem)
        assert not stem.startswith(".")  # never hidden, never a temporary file's name
        assert stem.lower() not in RESERVED_STEMS
        assert len(stem) <= MAX_STEM + 8  # room for a collision suffix


@settings(max_examples=200, deadline=None)
@given(names)
def test_the_same_inputs_get_the_same_names(specs):
    first, second = _items(specs), _items(specs)
    assign_stems(first)
    assign_stems(second)
    assert [i.stem for i in first] == [i.stem for i in second]


@given(st.text(alphabet="abcXYZ019_-.", min_size=1, max_size=40).filter(
    lambda s: s.strip("._") == s and s and len(s) <= MAX_STEM))
def test_a_safe_name_is_kept_as_it_is(name):
    assert safe_stem(name) == name
