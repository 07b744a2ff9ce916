"""feedtune.lazy.Deferred: what it answers without building, and that it builds once."""

import pytest

from feedtune.lazy import Deferred


class _Built:
    value = 42

    def twice(self, x):
        return 2 * x


def test_known_attributes_do_not_build_and_the_rest_builds_once():
    calls = []

    def build():
        calls.append(1)
        return _Built()

    deferred = Deferred(build, discrete=True)
    assert deferred.discrete is True and calls == []
    assert deferred.value == 42 and deferred.twice(3) == 6
    assert calls == [1]


def test_a_refusal_of_the_build_reaches_the_reader():
    def build():
        raise ValueError("/plant/model: refused")

    deferred = Deferred(build)
    with pytest.raises(ValueError, match="refused"):
        _ = deferred.a
    assert not hasattr(deferred, "__array__")  # dunder probes never build
