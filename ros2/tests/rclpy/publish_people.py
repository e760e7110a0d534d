"""Publish THÖR1 round 2 as people_msgs/People at 2.5 Hz (a stock rclpy node).

The recording's rows (time, person, x, y, ...) are put into 0.4 s frames: frame f
holds each person's last row with round(time / 0.4) == f, stamped f * 0.4 s (the
recording's clock, as sim time would be). Every message published is written to
--out as JSON: [{"stamp": [sec, nanosec], "frame": frame_id, "people": [[name, x, y], ...]}].
"""
import argparse
import json
import math
import os
import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy

from people_msgs.msg import People, Person


def frames_of(path, step):
    frames = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            t, pid, x, y = line.split(",")[:4]
            fr = round(float(t) / step)
            frames.setdefault(fr, {})[str(int(float(pid)))] = (float(x), float(y))
    return frames


def stamp_of(t):
    sec = math.floor(t)
    ns = round((t - sec) * 1e9)
    if ns >= 1_000_000_000:
        sec, ns = sec + 1, ns - 1_000_000_000
    return int(sec), int(ns)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tracks", required=True)
    ap.add_argument("--frames", type=int, default=100, help="how many 0.4 s frames from the start")
    ap.add_argument("--first", type=int, default=0, help="first frame")
    ap.add_argument("--rate", type=float, default=2.5)
    ap.add_argument("--topic", default="/people")
    ap.add_argument("--frame-id", default="map")
    ap.add_argument("--best-effort", action="store_true")
    ap.add_argument("--wait-for", default="", help="a file the checker creates when it listens")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()

    rclpy.init()
    node = Node("thor_people")
    qos = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.BEST_EFFORT if a.best_effort else ReliabilityPolicy.RELIABLE)
    pub = node.create_publisher(People, a.topic, qos)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
        if pub.get_subscription_count() >= 1 and (not a.wait_for or os.path.exists(a.wait_for)):
            break
    else:
        print("publish_people: nobody subscribed to", a.topic, file=sys.stderr)
    time.sleep(1.0)  # let the matching settle on both sides

    frames = frames_of(a.tracks, 0.4)
    sent = []
    period = 1.0 / a.rate
    nxt = time.monotonic()
    for fr in range(a.first, a.first + a.frames):
        people = frames.get(fr, {})
        msg = People()
        sec, ns = stamp_of(fr * 0.4)
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, ns
        msg.header.frame_id = a.frame_id
        for name, (x, y) in sorted(people.items()):
            p = Person()
            p.name = name
            p.position.x, p.position.y = x, y
            p.reliability = 1.0
            msg.people.append(p)
        pub.publish(msg)
        sent.append({"stamp": [sec, ns], "frame": a.frame_id,
                     "people": [[n, x, y] for n, (x, y) in sorted(people.items())]})
        nxt += period
        time.sleep(max(0.0, nxt - time.monotonic()))
    time.sleep(0.5)
    with open(a.out + ".tmp", "w") as f:
        json.dump(sent, f)
    os.replace(a.out + ".tmp", a.out)
    print(f"publish_people: {len(sent)} messages on {a.topic}", file=sys.stderr)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
