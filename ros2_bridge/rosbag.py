"""A recording as a rosbag2: the topics and types the ROS 2 bridge serves, made by the bridge's own translator.

Every LunarSim sample of the recording goes through ``Translator.outbound`` in the order it was recorded, and each
ROS message it makes is written at the sample's log time, CDR-encoded, into a rosbag2 folder (MCAP storage,
``metadata.yaml`` version 9) with ``rosbags``' writer, so ``ros2 bag info`` and ``ros2 bag play`` read it and
``/clock`` carries the mission's simulated time.
"""

from __future__ import annotations

import shutil
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from ros2_bridge import ros_types
from ros2_bridge.translator import Translator
from sessions.format import Sample

if TYPE_CHECKING:
    from schemas.params import RoverParams
    from sessions.recording import Recording

BAG_VERSION = 9


def export_recording(recording: Recording, params: RoverParams | None, truth: bool,
                     target: Path) -> tuple[Counter[str], int]:
    """``lunarsim export-rosbag``: the recording's samples as the bridge maps them, written by ``write_bag``; returns
    the messages written per topic and how many samples could not be converted. ``params`` lay out the scan's rays
    (None: the stock layout); ``truth`` adds ground truth."""
    import logging

    from bus.rejections import Rejections
    from ros2_bridge.mapping import RayLayout
    from schemas.keyspace import Keyspace

    layout = RayLayout.of(params.perception) if params is not None else RayLayout()
    rejected = Rejections(logging.getLogger("lunarsim.export"), "export-rosbag")
    translator = Translator(Keyspace(recording.world or "default"), layout,
                            params.perception.gyroscope_noise_std_deg if params else 0.0, truth, rejected)
    return write_bag(recording.samples(), translator, target), rejected.total


def write_bag(samples: Iterable[Sample], translator: Translator, target: Path) -> Counter[str]:
    """Write the bag into ``target`` (a folder that must not exist yet); returns messages written per topic.

    Written into a sibling ``.part`` folder first and renamed at the end, so a failure leaves no half bag."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    part = target.with_name(target.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    counts: Counter[str] = Counter()
    store = ros_types.typestore()
    try:
        with Writer(part, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP) as writer:
            connections = {}
            for sample in samples:
                for topic, ros_type, fields in translator.outbound(sample.key, sample.payload):
                    connection = connections.get(topic)
                    if connection is None:
                        connection = connections[topic] = writer.add_connection(topic, ros_type, typestore=store)
                    writer.write(connection, sample.log_time_ns, ros_types.encode(ros_type, fields))
                    counts[topic] += 1
        part.rename(target)
    except BaseException:
        shutil.rmtree(part, ignore_errors=True)
        raise
    return counts
