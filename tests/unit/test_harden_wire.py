"""Wire corners: an attachment that is not a tag is a bad tag, and tagged and untagged messages still decode."""

from __future__ import annotations

import pytest

from pegbt.transport.sequencing import BadTag, Tag


@pytest.mark.parametrize(
    "attachment",
    [b"me|\xc2\xb2|x|y", b"me|" + b"9" * 5000 + b"|x|y", b"me|-1|x|y", b"me||x|y", b"m" * 600 + b"|1|x|y"],
)
def test_an_attachment_that_is_not_a_tag_is_a_bad_tag(attachment):
    with pytest.raises(BadTag):
        Tag.decode(attachment)


def test_tags_and_untagged_messages_still_decode():
    assert Tag.decode(b"me|12|c|done") == Tag("me", 12, "c", "done")
    assert Tag.decode(None) is None and Tag.decode(b"\x01\x02 rmw_zenoh's own attachment") is None
