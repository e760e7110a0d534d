"""Publish THÖR1 round 2 at 2.5 Hz (a stock rclpy node) as people_msgs/People or, with
--type objects, as autoware_perception_msgs/TrackedObjects.

The recording's rows (time, person, x, y, ...) are put into 0.4 s frames: frame f
holds each person's last row with round(time / 0.4) == f, stamped --stamp-base + f * 0.4 s
(the recording's clock, as sim time would be); from message --restart-at on, the base is
--restart-base (a tracker restarted: its stamps jump). As TrackedObjects, each person is
an object with a uuid made from its id and the most probable label 7 (pedestrian), and
each message also holds two objects that are not pedestrians (a car, a bicycle that is
only possibly a pedestrian) at the first person's position. Every message published is
written to --out as JSON: [{"stamp": [sec, nanosec], "frame": frame_id, "wall": unix time,
"people": [[track id, x, y], ...]}] (the pedestrians only; the track id as the node must
read it: the name, or the uuid in hex).
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


def uuid_of(name, salt):
    """16 bytes from a numeric person id: a fixed prefix, the salt and the id."""
    return bytes([0xC1, 0x1F, salt]) + int(name).to_bytes(13, "big")


def objects_message(people, stamp, frame_id):
    from autoware_perception_msgs.msg import ObjectClassification, TrackedObject, TrackedObjects

    def obj(uuid, x, y, classes):
        o = TrackedObject()
        o.object_id.uuid = list(uuid)
        o.existence_probability = 0.9
        for label, prob in classes:
            c = ObjectClassification()
            c.label, c.probability = label, prob
            o.classification.append(c)
        o.kinematics.pose_with_covariance.pose.position.x = x
        o.kinematics.pose_with_covariance.pose.position.y = y
        o.kinematics.pose_with_covariance.covariance[0] = 0.05
        o.kinematics.pose_with_covariance.covariance[7] = 0.05
        o.shape.type = 1
        o.shape.dimensions.x = o.shape.dimensions.y = 0.6
        o.shape.dimensions.z = 1.7
        return o

    msg = TrackedObjects()
    msg.header.stamp.sec, msg.header.stamp.nanosec = stamp
    msg.header.frame_id = frame_id
    for name, (x, y) in people:
        msg.objects.append(obj(uuid_of(name, 0), x, y, [(1, 0.1), (7, 0.8), (6, 0.1)]))
    if people:
        x, y = people[0][1]
        msg.objects.append(obj(uuid_of(people[0][0], 1), x + 3.0, y, [(1, 0.9), (7, 0.1)]))
        msg.objects.append(obj(uuid_of(people[0][0], 2), x, y + 3.0, [(6, 0.6), (7, 0.4)]))
    return msg


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
    ap.add_argument("--type", choices=["people", "objects"], default="people")
    ap.add_argument("--topic", default=None, help="default /people or /tracked_objects")
    ap.add_argument("--stamp-base", type=float, default=0.0)
    ap.add_argument("--restart-at", type=int, default=-1, help="from this message on, stamps from --restart-base")
    ap.add_argument("--restart-base", type=float, default=0.0)
    ap.add_argument("--started", default="", help="a file created when the first message goes out")
    ap.add_argument("--frame-id", default="map")
    ap.add_argument("--best-effort", action="store_true")
    ap.add_argument("--wait-for", default="", help="a file the checker creates when it listens")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()

    if a.topic is None:
        a.topic = "/people" if a.type == "people" else "/tracked_objects"
    rclpy.init()
    node = Node("thor_people")
    qos = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.BEST_EFFORT if a.best_effort else ReliabilityPolicy.RELIABLE)
    if a.type == "people":
        pub = node.create_publisher(People, a.topic, qos)
    else:
        from autoware_perception_msgs.msg import TrackedObjects
        pub = node.create_publisher(TrackedObjects, a.topic, qos)
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
    for i, fr in enumerate(range(a.first, a.first + a.frames)):
        people = sorted(frames.get(fr, {}).items())
        base = a.restart_base if 0 <= a.restart_at <= i else a.stamp_base
        sec, ns = stamp_of(base + fr * 0.4)
        if a.type == "people":
            msg = People()
            msg.header.stamp.sec, msg.header.stamp.nanosec = sec, ns
            msg.header.frame_id = a.frame_id
            for name, (x, y) in people:
                p = Person()
                p.name = name
                p.position.x, p.position.y = x, y
                p.reliability = 1.0
                msg.people.append(p)
            ids = [n for n, _ in people]
        else:
            msg = objects_message(people, (sec, ns), a.frame_id)
            ids = [uuid_of(n, 0).hex() for n, _ in people]
        if i == 0 and a.started:
            open(a.started, "w").close()
        wall = time.time()
        pub.publish(msg)
        sent.append({"stamp": [sec, ns], "frame": a.frame_id, "wall": wall,
                     "people": [[t, x, y] for t, (_, (x, y)) in zip(ids, people)]})
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
