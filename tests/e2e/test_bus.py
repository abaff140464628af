"""The Bus keeps one publisher's samples in order across keys, over a real router, and its callbacks keep their
Zenoh thread's Python state; a rover agent receives on Zenoh's application thread."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from procs import module, stop, wait_for, wait_for_output

from bus.bus import PER_KEY_LIMIT, Bus, zenoh_callback
from bus.zenoh_config import build_config, open_session

pytestmark = pytest.mark.e2e


def test_samples_of_different_keys_arrive_in_publication_order(router):
    endpoint = router
    conf = build_config(connect=[endpoint])
    # lossless, as a lockstep world's bus, which relies on this order: a real-time bus drops under congestion
    with (Bus(open_session(conf, endpoint), lossless=True) as sender,
          Bus(open_session(conf, endpoint), per_key_limit=3000) as receiver):
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


def test_a_flooded_key_is_cut_at_its_bound_and_counted_while_other_keys_get_through(router):
    endpoint = router
    conf = build_config(connect=[endpoint])
    # The sender waits out congestion (lossless): a dropping sender may lose part of the flood on a loaded
    # machine before it reaches the receiver, whose inbox bound is what this test counts.
    with Bus(open_session(conf, endpoint), lossless=True) as sender, Bus(open_session(conf, endpoint)) as receiver:
        flood, other = "lunar/flood/rover/2/move_action", "lunar/flood/rover/1/status"
        receiver.subscribe(flood)
        receiver.subscribe(other)
        wait_for(lambda: sender.put(other, b"ready") or receiver.drain(), 10, "the subscriptions")
        for _ in range(5000):
            sender.put(flood, b"x")
        sender.put(other, b"after")
        wait_for(lambda: receiver.inbox.dropped["move_action"] + receiver.inbox.qsize() >= 5000
                 and receiver.inbox.qsize() > PER_KEY_LIMIT, 30, "the flood at the receiver")
        # The sample put after the flood may still be on its way when the flood's last one is counted; draining
        # now frees no room for a flood that has all arrived.
        items: list = []
        wait_for(lambda: items.extend(receiver.drain()) or any(item.payload == b"after" for item in items), 10,
                 "the sample put after the flood")
    assert sum(item.key == flood for item in items) == PER_KEY_LIMIT
    assert receiver.inbox.dropped["move_action"] == 5000 - PER_KEY_LIMIT


def test_zenoh_threads_keep_their_python_thread_state_between_samples(router):
    """Without it each sample costs a thread state made and dropped (an mmap and an munmap): thread-local data
    would start afresh in every callback."""
    endpoint = router
    conf = build_config(connect=[endpoint])
    local, counts = threading.local(), []

    def count(sample) -> None:
        local.n = getattr(local, "n", 0) + 1
        counts.append((threading.get_ident(), local.n))

    with Bus(open_session(conf, endpoint)) as sender, open_session(conf, endpoint) as receiver:
        subscriber = receiver.declare_subscriber("lunar/threads/**", zenoh_callback(count))
        wait_for(lambda: sender.put("lunar/threads/ready", b"") or counts, 10, "the subscription")
        for _ in range(200):
            sender.put("lunar/threads/data", b"x")
        wait_for(lambda: len(counts) >= 200, 30, "200 samples")
        subscriber.undeclare()
    per_thread: dict[int, list[int]] = {}
    for thread, n in counts:
        per_thread.setdefault(thread, []).append(n)
    assert all(ns == list(range(1, len(ns) + 1)) for ns in per_thread.values()), per_thread
    assert len(counts) > len(per_thread)  # some thread took more than one sample


def test_the_world_puts_on_its_rovers_keys_without_declaring_a_publisher(router):
    """A declared publisher brings the subscriptions matching it into the world's session, and Zenoh matches every
    sample the world receives against them all: at a thousand rovers, 0.2 of a core of the world's."""
    from world_service.commands.world import world_bus

    endpoint = router
    conf = build_config(connect=[endpoint])
    with (world_bus(open_session(conf, endpoint), lockstep=False, fault_loss=0.0, seed=0) as world,
          Bus(open_session(conf, endpoint)) as agent):
        keys = [f"lunar/undeclared/rover/{rover}/gyroscope" for rover in (1, 2, 3)]
        for key in keys:
            agent.subscribe(key)
        got: set[str] = set()

        def heard() -> bool:
            for key in keys:
                world.put(key, b"pitch")
            got.update(r.key for r in agent.drain())
            return got == set(keys)

        wait_for(heard, 10, "the world's samples at the agent")
        assert world._publishers == {}, "the world declared publishers"


def _threads(pid: int) -> list[str]:
    """The names of the process's threads; one that ends while they are read is left out."""
    names = []
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            names.append(Path(f"/proc/{pid}/task/{task}/comm").read_text().strip())
        except FileNotFoundError:
            continue
    return sorted(names)


@pytest.mark.parametrize(("rovers", "runtime", "receiving"), [
    (["--id", "1"], None, []),
    (["--id", "1"], "(rx: (worker_threads: 1))", ["rx-0"]),
    (["--ids", "1-3"], None, ["rx-0", "rx-1"]),
], ids=["one agent", "the user's ZENOH_RUNTIME", "three agents"])
def test_one_rovers_agent_receives_on_zenohs_application_thread(router, rovers, runtime, receiving):
    """One rover's agent has Zenoh run its receiving on the application runtime's thread (``receive_on_one_thread``):
    no thread of Zenoh's receiving runtime exists. A ``ZENOH_RUNTIME`` of the user's wins, and a process of several
    agents keeps Zenoh's two receiving threads. Zenoh reads the variable once per process, so each case is an agent
    process of its own."""
    env = {k: v for k, v in os.environ.items() if k != "ZENOH_RUNTIME"}
    if runtime is not None:
        env["ZENOH_RUNTIME"] = runtime
    rover = module("rover_agent", *rovers, "--world", "lunar-runtime", "--connect", router, "--no-state", env=env)
    try:
        wait_for_output(rover, "waiting for the world's clock", 30)  # its session, subscriptions and token are up

        def link_up() -> list[str] | None:  # the link's tasks start their runtimes' threads as they first run
            threads = _threads(rover.pid)
            return threads if "tx-0" in threads and set(receiving) <= set(threads) else None

        threads = wait_for(link_up, 30, "the threads of the rover's link to the router")
    finally:
        stop(rover)
    assert [name for name in threads if name.startswith("rx-")] == receiving, threads
    assert "app-0" in threads, threads
