"""The ROS 2 reference page (``docs/reference/ros2.md``), made from the bridge's own tables (``ros2_bridge.topics``)
by ``python -m deploy.reference docs``, so the documentation lists exactly what the bridge serves."""

from __future__ import annotations

from ros2_bridge import rmw, ros_types
from ros2_bridge import topics as tp


def page() -> str:
    lines = ["# ROS 2 topics", "",
             "What `lunarsim ros2` (and `lunarsim export-rosbag`) serve, generated from the bridge's mapping. Every "
             "stamp is simulated time (`/clock`); `<id>` is a rover's id. Frames follow REP 103 and REP 105: "
             "`map` is the scenario's map frame, `rover_<id>/odom` the lander-centred frame a rover's odometry "
             "starts in, `rover_<id>/base_link` the rover (x ahead, y left, z up). How to use them: "
             "[ROS 2 guide](../guides/ros2.md).", "",
             "## From LunarSim to ROS 2", "", *_table("out"), "",
             "## From ROS 2 to LunarSim", "", *_table("in"), "",
             "Ground truth topics are published only with `--truth`.", "",
             "## Not bridged", "", "| LunarSim | why |", "|---|---|"]
    lines += [f"| {what} | {why} |" for what, why in tp.NOT_BRIDGED]
    lines += ["", "## On the wire", "",
              "Each topic's samples travel on rmw_zenoh's key `<domain>/<topic>/<type>/<hash>`, for example "
              f"`{_example()}`. The node `/lunarsim_bridge` and each of its publishers and subscriptions hold "
              f"liveliness tokens under `{rmw.ADMIN_SPACE}/<domain>/...` while the bridge runs; each sample carries "
              "rmw_zenoh's 33-byte attachment (sequence number from 1, source time, the publisher's GID). QoS: "
              "reliable, volatile, keep last 10.", "",
              "| ROS 2 type | RIHS01 type hash |", "|---|---|"]
    lines += [f"| `{name}` | `{ros_types.type_hash(name)}` |" for name in sorted({t.ros_type for t in tp.TOPICS})]
    return "\n".join(lines) + "\n"


def _table(direction: str) -> list[str]:
    rows = ["| topic | type | frame | LunarSim | what it holds |", "|---|---|---|---|---|"]
    for t in tp.TOPICS:
        if t.direction == direction:
            name = t.name.replace("{id}", "<id>")
            truth = " (ground truth, `--truth` only)" if t.truth else ""
            frame = f"`{t.frame}`" if t.frame != "-" else "-"
            rows.append(f"| `{name}` | `{t.ros_type}` | {frame} | `{t.source}` | {t.note}{truth} |")
    return rows


def _example() -> str:
    return rmw.topic_key(0, "/rover_1/scan", tp.SCAN.ros_type, ros_types.type_hash(tp.SCAN.ros_type))
