"""The Bus keeps one publisher's samples in order across keys, over a real router."""

from __future__ import annotations

import pytest
from procs import wait_for

from deploy.bus import Bus
from deploy.zenoh_config import build_config, open_session

pytestmark = pytest.mark.e2e


def test_samples_of_different_keys_arrive_in_publication_order(router):
    endpoint = router
    conf = build_config(connect=[endpoint])
    with Bus(open_session(conf, endpoint)) as sender, Bus(open_session(conf, endpoint)) as receiver:
        keys = [f"lunar/order/rover/1/{topic}" for topic in ("navigation_status", "gyroscope", "perception")]
        for key in keys:
            receiver.subscribe(key)
        receiver.subscribe("lunar/order/ready")
        wait_for(lambda: sender.put("lunar/order/ready", b"") or receiver.drain(), 10, "the subscriptions")
        count = 3000
        for i in range(count):
            sender.put(keys[i % 3], i.to_bytes(4, "big"))
        got: list[int] = []
        wait_for(lambda: got.extend(int.from_bytes(r.payload, "big") for r in receiver.drain()
                                    if r.key in keys) or len(got) >= count, 30, f"{count} samples")
    assert got == list(range(count))
