"""The fuzz campaign's fast subset: about 50 inputs per reader, drawn by hypothesis, each a random or
mutated valid input; none may raise anything but a `PegbtError`, hang, or accept an absurd value.
`pegbt bench fuzz` runs 1000 per reader."""

from __future__ import annotations

import random
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pegbt.bench.fuzz import READERS
from pegbt.errors import PegbtError
from pegbt.transport.sequencing import BadTag, Tag
from pegbt.yamlfile import parse_yaml

FAST = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.parametrize("reader", sorted(READERS))
def test_mutated_valid_inputs_never_crash_hang_or_pass_absurd_values(reader):
    @FAST
    @given(st.integers(min_value=0, max_value=2**32 - 1))
    def one_input(seed: int) -> None:
        with tempfile.TemporaryDirectory() as folder:
            tally = READERS[reader](1, random.Random(seed), Path(folder))
        assert (tally.tracebacks, tally.hangs, tally.absurd_accepted, tally.written_from_non_arm) == (
            0,
            0,
            0,
            0,
        ), tally.examples

    one_input()


@FAST
@given(st.binary(max_size=2000))
def test_any_bytes_are_yaml_or_a_located_error(data):
    try:
        parse_yaml(data, "fuzz.yaml")
    except PegbtError as error:
        assert error.file == "fuzz.yaml"


@FAST
@given(
    st.binary(max_size=300)
    | st.builds(lambda a, b: b"s|" + a + b"|c|" + b, st.binary(max_size=40), st.binary(max_size=8))
)
def test_any_attachment_is_a_tag_untagged_or_a_bad_tag(data):
    try:
        tag = Tag.decode(data)
    except BadTag:
        return
    assert tag is None or 0 <= tag.seq < 10**19
