"""Receive cliff-ros2's predictions, markers, PredictedObjects, occupancy grids and latched map markers (a stock rclpy node)
and write them to --out as JSON once --done appears (plus a settling second) or after
--timeout seconds. Each predictions message is kept with the unix time it arrived."""
import argparse
import json
import math
import os
import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy

from autoware_perception_msgs.msg import PredictedObjects
from nav_msgs.msg import OccupancyGrid
from cliff_msgs.msg import Predictions
from visualization_msgs.msg import MarkerArray


def stamp(t):
    return [t.sec, t.nanosec]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ns", default="")
    ap.add_argument("--ready", required=True)
    ap.add_argument("--done", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--timeout", type=float, default=120)
    ap.add_argument("--linger", type=float, default=1.5, help="seconds to keep listening after --done")
    a = ap.parse_args()

    rclpy.init()
    node = Node("cliff_listener")
    got = {"predictions": [], "markers": [], "map_markers": [], "objects": [], "grids": []}

    def on_pred(m):
        got["predictions"].append({
            "wall": time.time(), "stamp": stamp(m.header.stamp), "frame": m.header.frame_id, "dt": m.dt,
            "horizon": m.horizon, "k": m.k, "method": m.method, "map": m.map, "seed": m.seed,
            "people": [{
                "track_id": p.track_id, "stamp": stamp(p.stamp), "history": p.history,
                "origin": [p.origin.x, p.origin.y], "lengths": list(p.lengths),
                "points": [[q.x, q.y] for q in p.points], "scores": list(p.scores),
            } for p in m.people],
        })

    def markers(m):
        return [{"ns": k.ns, "id": k.id, "type": k.type, "action": k.action,
                 "frame": k.header.frame_id, "points": [[q.x, q.y] for q in k.points],
                 "a": k.color.a} for k in m.markers]

    def yaw(q):
        return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))

    def on_objects(m):
        got["objects"].append({
            "stamp": stamp(m.header.stamp), "frame": m.header.frame_id,
            "objects": [{
                "uuid": bytes(o.object_id.uuid).hex(), "existence": o.existence_probability,
                "classification": [[c.label, c.probability] for c in o.classification],
                "pose": [o.kinematics.initial_pose_with_covariance.pose.position.x,
                         o.kinematics.initial_pose_with_covariance.pose.position.y,
                         yaw(o.kinematics.initial_pose_with_covariance.pose.orientation)],
                "twist": [o.kinematics.initial_twist_with_covariance.twist.linear.x,
                          o.kinematics.initial_twist_with_covariance.twist.linear.y],
                "paths": [{
                    "confidence": q.confidence, "step": [q.time_step.sec, q.time_step.nanosec],
                    "poses": [[p.position.x, p.position.y, yaw(p.orientation)] for p in q.path],
                } for q in o.kinematics.predicted_paths],
                "shape": [o.shape.type, o.shape.dimensions.x, o.shape.dimensions.y, o.shape.dimensions.z],
            } for o in m.objects],
        })

    def on_grid(m):
        i = m.info
        got["grids"].append({
            "stamp": stamp(m.header.stamp), "frame": m.header.frame_id, "resolution": i.resolution,
            "width": i.width, "height": i.height, "origin": [i.origin.position.x, i.origin.position.y],
            "data": list(m.data),
        })

    def on_markers(m):
        got["markers"].append(markers(m))

    def on_map(m):
        got["map_markers"].append(markers(m))

    rel = QoSProfile(depth=50, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE)
    latched = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    ns = a.ns.rstrip("/")
    subs = [
        node.create_subscription(Predictions, f"{ns}/cliff/predictions", on_pred, rel),
        node.create_subscription(MarkerArray, f"{ns}/cliff/markers", on_markers, rel),
        node.create_subscription(MarkerArray, f"{ns}/cliff/map_markers", on_map, latched),
        node.create_subscription(PredictedObjects, f"{ns}/cliff/objects", on_objects, rel),
        node.create_subscription(OccupancyGrid, f"{ns}/cliff/occupancy", on_grid, rel),
    ]
    start = time.monotonic()
    ready = False
    done_at = None
    while time.monotonic() - start < a.timeout:
        rclpy.spin_once(node, timeout_sec=0.05)
        if not ready and all(s.get_publisher_count() >= 1 for s in subs[:2] + subs[3:]):
            open(a.ready, "w").close()
            ready = True
        if done_at is None and os.path.exists(a.done):
            done_at = time.monotonic()
        if done_at is not None and time.monotonic() - done_at > a.linger:
            break
    with open(a.out, "w") as f:
        json.dump(got, f)
    print(f"listen: {len(got['predictions'])} predictions, {len(got['markers'])} marker arrays, "
          f"{len(got['map_markers'])} map marker arrays, {len(got['objects'])} objects, "
          f"{len(got['grids'])} grids", file=sys.stderr)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
