"""Wire corners: a malformed attachment is refused and counted, and every refusal reaches `PSMn/error`
even under a burst."""

from __future__ import annotations

import json
import threading
import time

import pytest

from pegbt.sim.process import SimProcess
from pegbt.transport import ArmClient, codec, connect
from pegbt.transport.sequencing import Outlet


def _wait(predicate, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while not predicate() and time.monotonic() < deadline:
        time.sleep(0.05)
    return predicate()


@pytest.mark.slow
def test_bad_attachments_and_a_burst_of_refusals_all_reach_the_error_topic(tmp_path):
    log = tmp_path / "sim.jsonl"
    with (
        SimProcess(["--physics", "ideal", "--no-world", "--log", str(log)]) as sim,
        connect([sim.endpoint]) as link,
    ):
        psm1 = ArmClient(link, "PSM1")
        psm1.wait_until_ready(30.0)
        errors: list[str] = []
        lock = threading.Lock()

        def on_error(sample) -> None:
            with lock:
                errors.append(codec.decode_string(sample.payload.to_bytes()))

        subscriber = link.session.declare_subscriber(psm1.keys.error, on_error)
        time.sleep(0.5)  # the endpoint sees the subscriber before it has anything to say
        payload = codec.encode_joint_state(
            0.0, psm1.setpoint_js.position + [0, 0, 1.0, 0, 0, 0]
        )  # q3 out of range
        for attachment in (b"me|\xc2\xb2|x|y", b"me|" + b"9" * 5000 + b"|x|y"):
            link.session.put(psm1.keys.servo_jp, payload, attachment=attachment)
        assert _wait(lambda: len(errors) >= 2, 20.0), errors
        assert all("bad attachment" in text for text in errors[:2])

        burst = 20_000
        outlet = Outlet(link.session, psm1.keys.servo_jp, link.source)
        for _ in range(burst):
            outlet.put(payload)
        assert _wait(lambda: len(errors) >= 2 + burst, 120.0), (
            f"{len(errors) - 2} of {burst} refusals arrived"
        )
        subscriber.undeclare()
        outlet.close()
    refused = [json.loads(line) for line in log.read_text().splitlines() if '"refused"' in line]
    assert len(refused) == 2 + burst and len(errors) == 2 + burst
