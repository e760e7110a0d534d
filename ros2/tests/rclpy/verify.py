"""Check what cliff-ros2 published against what the publisher sent.

The track rules are replayed here independently (per id: the newest stamps; a track
is forgotten once the newest input stamp is more than --timeout past its last
observation; predicted from the observations within --history-seconds of its newest,
when there are two or more; in the order the ids were first seen), the histories so
found are predicted in-process by cliff-ros2-reference (cliff-client's Request and
LocalPredictor, the code path of `cliff predict` and cliffd) and the node's points must
equal the reference's exactly (float32 for float32). A message whose stamp is more than
--timeout older than the newest resets every track (a tracker restarted). With
--transform, the sent positions are first mapped into the map frame as the node's static
transform does. Optional checks: every marker ever added was deleted by the end
(--all-deleted), the daemon's absence (--gone/--back), warnings in the node's log
(--log, --warn), that a learning cliffd took every row the node received once and every
track's end (--observed, its log, and --learned, its snapshot folder), and with
--expect-skipped that nothing was predicted at all. The PredictedObjects on cliff/objects
and the occupancy grids on cliff/occupancy are checked against the predictions of the
same cycle (check_objects, check_grid). Prints one
line per check and `N passed, N failed`; exits 1 on any failure.
"""
import argparse
import glob
import json
import math
import re
import struct
import subprocess
import sys
import uuid

import numpy as np

# the namespace of the People tracks' UUIDs (docs/planners.md)
PEOPLE_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "urn:cliff-ros2:people")


def f32(v):
    return struct.unpack("f", struct.pack("f", v))[0]


def secs(s):
    return float(s[0]) + float(s[1]) * 1e-9


class Results:
    def __init__(self, name):
        self.name, self.passed, self.failed = name, 0, 0

    def check(self, ok, what, detail=""):
        if ok:
            self.passed += 1
            print(f"ok   {self.name}: {what}")
        else:
            self.failed += 1
            print(f"FAIL {self.name}: {what}" + (f": {detail}" if detail else ""))


def replay(sent, timeout, history_seconds, transform=None):
    """Expected (ids, histories) after each published message, by stamp; and the rows
    the track rules keep (each person's stamps newer than its last) and the tracks they
    make (a person forgotten after the timeout and seen again is a new one)."""
    order, obs = [], {}
    newest = None
    out = {}
    rows = tracks = 0
    if transform:
        tx, ty, yaw = transform
        c, s = math.cos(yaw), math.sin(yaw)
    for m in sent:
        t = secs(m["stamp"])
        if newest is not None and t < newest - timeout:
            order, obs, newest = [], {}, None
        newest = t if newest is None or t > newest else newest
        for name, x, y in m["people"]:
            if transform:
                x, y = c * x - s * y + tx, s * x + c * y + ty
            if name not in obs:
                order.append(name)
                obs[name] = []
                tracks += 1
            if not obs[name] or t > secs(obs[name][-1][:2]):
                obs[name].append((m["stamp"][0], m["stamp"][1], x, y))
                rows += 1
        for name in list(order):
            if secs(obs[name][-1][:2]) < newest - timeout:
                order.remove(name)
                del obs[name]
        ids, hist = [], []
        for name in order:
            h = obs[name]
            last = secs(h[-1][:2])
            w = [o for o in h if secs(o[:2]) >= last - history_seconds - 1e-3] if history_seconds > 0 else list(h)
            if len(w) >= 2:
                ids.append(name)
                hist.append([list(o) for o in w])
        out[tuple(m["stamp"])] = (ids, hist)
    return out, rows, tracks


def check_log(r, path, specs):
    """specs: "TEXT:MIN:MAX", the number of node log lines holding TEXT."""
    lines = open(path, errors="replace").read().splitlines()
    for spec in specs:
        text, lo, hi = spec.rsplit(":", 2)
        n = sum(1 for line in lines if text in line)
        r.check(int(lo) <= n <= int(hi), f"node log: {n} lines with '{text}' (expected {lo}..{hi})")


def check_all_deleted(r, markers):
    last = {}
    for m in markers:
        for k in m:
            if k["action"] in (0, 2):
                last[(k["ns"], k["id"])] = k["action"]
    left = [key for key, action in last.items() if action != 2]
    r.check(last and not left,
            f"every sample marker added ({len(last)}) was deleted once its track went stale", f"left: {left[:5]}")


def check_gone(r, sent, preds, gone, back):
    """The daemon stopped at `gone` and was started again at `back` (unix times)."""
    during = [p for p in preds if gone + 0.5 < p["wall"] < back]
    r.check(not during, f"no prediction while the daemon was away ({back - gone:.1f} s)",
            f"{len(during)} arrived")
    after_sent = [m for m in sent if m["wall"] > back + 2.0]
    after = [p for p in preds if p["wall"] > back + 2.0]
    r.check(after_sent and len(after) >= 0.9 * len(after_sent),
            f"predictions back by themselves after the restart ({len(after)} for {len(after_sent)} messages)")


def check_observed(r, rows, tracks, daemon_log, learned_dir):
    """cliffd's closing line: every row of the track rules (`rows`) once, every track's
    end (a duplicate of the track's newest row), rows learned, and a snapshot written."""
    text = open(daemon_log, errors="replace").read()
    m = re.search(r"cliffd learned: (\d+) rows taken, (\d+) duplicates, (\d+) rows learned, "
                  r"(\d+) versions, (\d+) refused, (\d+) snapshots", text)
    if not m:
        r.check(False, "cliffd's closing line on learning", text[-300:])
        return
    taken, dup, learned, _, _, snaps = (int(v) for v in m.groups())
    r.check(taken == rows, f"cliffd took every row the node received once ({taken} of {rows})")
    r.check(dup == tracks, f"every track's end reached cliffd ({dup} of {tracks} tracks)")
    files = sorted(glob.glob(f"{learned_dir}/*.cliff"))
    r.check(learned > 0 and snaps >= 1 and files,
            f"cliffd learned the tracks ({learned} rows) and wrote a snapshot ({len(files)} files)")


def expected_uuid(track_id):
    """A TrackedObjects track keeps its UUID (its id is the 32 hex digits); a People track
    gets the name-based UUID of its name."""
    if re.fullmatch("[0-9a-f]{32}", track_id):
        return track_id
    return uuid.uuid5(PEOPLE_NAMESPACE, track_id).hex


def yaw_close(a, b, tol=1e-6):
    d = (a - b + math.pi) % (2 * math.pi) - math.pi
    return abs(d) < tol


def check_objects(r, preds, objects, expected, dt, paths, min_received):
    """Each predictions message with people has a PredictedObjects message of the same
    stamp and frame: per person, in order, its UUID, a pedestrian of probability 1, a
    cylinder, the initial pose at the last observation heading along the observed
    velocity (the last two observations) and that speed forward, and the best `paths`
    samples (by the predictions' scores, else the first) as paths: the origin then the
    sample's points, each pose heading to the next, the step dt, confidence the sample's
    share exp(s - best) / sum over its k samples (1/k unscored)."""
    by_stamp = {}
    for m in objects:
        by_stamp.setdefault(tuple(m["stamp"]), []).append(m)
    with_people = [p for p in preds if p["people"]]
    step = [int(dt), round((dt - int(dt)) * 1e9)]
    bad, compared, n_paths = [], 0, 0
    for p in with_people:
        key = tuple(p["stamp"])
        ms = by_stamp.get(key)
        if not ms:
            continue
        m = ms[0]
        compared += 1
        if m["frame"] != p["frame"] or len(m["objects"]) != len(p["people"]):
            bad.append((key, "frame or count"))
            continue
        hist = expected[key][1]
        for q, o, h in zip(p["people"], m["objects"], hist):
            who = (key, q["track_id"])
            if o["uuid"] != expected_uuid(q["track_id"]):
                bad.append((who, "uuid", o["uuid"]))
            if o["classification"] != [[7, 1.0]] or o["existence"] != 1.0 or o["shape"][0] != 1 \
                    or not 0.3 <= o["shape"][1] == o["shape"][2] <= 1.0 or not 1.0 <= o["shape"][3] <= 2.2:
                bad.append((who, "class, existence or shape", o["classification"], o["shape"]))
            (t0s, t0n, x0, y0), (t1s, t1n, x1, y1) = h[-2], h[-1]
            d = secs([t1s, t1n]) - secs([t0s, t0n])
            vx, vy = (x1 - x0) / d, (y1 - y0) / d
            speed = math.hypot(vx, vy)
            if abs(o["pose"][0] - x1) > 1e-9 or abs(o["pose"][1] - y1) > 1e-9 or abs(o["twist"][0] - speed) > 1e-6 * max(1.0, speed) \
                    or o["twist"][1] != 0.0 or (speed > 1e-6 and not yaw_close(o["pose"][2], math.atan2(vy, vx))):
                bad.append((who, "initial pose or twist", o["pose"], o["twist"], [x1, y1, speed]))
            k = len(q["lengths"])
            if q["scores"]:
                sc = q["scores"]
                best = max(v for v in sc if math.isfinite(v))
                w = [math.exp(v - best) if math.isfinite(v) else 0.0 for v in sc]
                conf = [v / sum(w) for v in w]
                order = sorted(range(k), key=lambda s: (-f32(conf[s]), s))
            else:
                conf = [1.0 / k] * k
                order = list(range(k))
            order = order[:paths]
            if len(o["paths"]) != len(order):
                bad.append((who, "paths", len(o["paths"])))
                continue
            starts = [sum(q["lengths"][:s]) for s in range(k)]
            total = 0.0
            for path, s in zip(o["paths"], order):
                n_paths += 1
                total += path["confidence"]
                want = [q["origin"]] + q["points"][starts[s]:starts[s] + q["lengths"][s]]
                got_xy = [[f32(x), f32(y)] for x, y, _ in path["poses"]]
                if got_xy != want or path["step"] != step or abs(path["confidence"] - conf[s]) > 1e-5:
                    bad.append((who, "path", s, path["confidence"], conf[s]))
                    continue
                poses = path["poses"]
                for i in range(len(poses) - 1):
                    dx, dy = poses[i + 1][0] - poses[i][0], poses[i + 1][1] - poses[i][1]
                    if math.hypot(dx, dy) > 1e-6 and not yaw_close(poses[i][2], math.atan2(dy, dx), 1e-5):
                        bad.append((who, "heading", s, i))
                        break
            if total > 1.0 + 1e-5:
                bad.append((who, "confidences sum", total))
    r.check(compared >= min_received * len(with_people) and compared > 0 and not bad,
            f"PredictedObjects: {compared} messages for {len(with_people)} predictions with people; UUIDs, "
            f"pedestrian class and shape, initial state, {n_paths} paths (the best {paths} by score, "
            "headings, step, confidences) as predicted", str(bad[:3]))


def check_grid(r, preds, grids, dt, grid_to, min_received, origin=(-10.0, -10.0), size=(20.0, 20.0),
               resolution=0.25):
    """Each predictions message has an occupancy grid of the same stamp and frame, of the
    set origin, size and resolution, with the cell under each person's last observed
    position occupied (the window starts there: >= 50 of 100), and every cell farther
    than 4 m from all of the window's predicted positions (origins and samples' points
    up to grid_to) free (0)."""
    by_stamp = {tuple(g["stamp"]): g for g in grids}
    width, height = round(size[0] / resolution), round(size[1] / resolution)
    bad, compared, occupied, free = [], 0, 0, 0
    steps = int(round(grid_to / dt))
    for p in preds:
        g = by_stamp.get(tuple(p["stamp"]))
        if g is None:
            continue
        compared += 1
        if (g["frame"], g["width"], g["height"]) != (p["frame"], width, height) \
                or abs(g["resolution"] - resolution) > 1e-6 or g["origin"] != list(origin) \
                or len(g["data"]) != width * height or not all(0 <= v <= 100 for v in g["data"]):
            bad.append((p["stamp"], "layout", g["width"], g["height"], g["resolution"], g["origin"]))
            continue

        def cell(x, y):
            c, r_ = int((x - origin[0]) // resolution), int((y - origin[1]) // resolution)
            return r_ * width + c if 0 <= c < width and 0 <= r_ < height else None

        near = np.zeros((height, width), dtype=bool)
        reach = int(4.0 / resolution) + 1
        for q in p["people"]:
            pts = [q["origin"]]
            start = 0
            for n in q["lengths"]:
                pts += q["points"][start:start + min(n, steps)]
                start += n
            i = cell(*q["origin"])
            if i is not None:
                if g["data"][i] < 50:
                    bad.append((p["stamp"], q["track_id"], "free under the person", g["data"][i]))
                occupied += 1
            for x, y in pts:
                c0, r0 = int((x - origin[0]) // resolution), int((y - origin[1]) // resolution)
                near[max(0, r0 - reach):max(0, r0 + reach + 1), max(0, c0 - reach):max(0, c0 + reach + 1)] = True
        data = np.array(g["data"]).reshape(height, width)
        hot = int(((data != 0) & ~near).sum())
        free += int((~near).sum())
        if hot:
            bad.append((p["stamp"], "occupied far from every prediction", hot))
    r.check(compared >= min_received * len(preds) and compared > 0 and occupied > 0 and not bad,
            f"occupancy grids: {compared} for {len(preds)} predictions; layout as set, the cells under "
            f"{occupied} people occupied, {free} cells far from every prediction free", str(bad[:3]))


def expect_skipped(r, got):
    with_people = [p for p in got["predictions"] if p["people"]]
    adds = [m for m in got["markers"] if any(k["action"] == 0 for k in m)]
    r.check(not with_people and not adds,
            f"nothing predicted from the skipped input ({len(got['predictions'])} predictions messages, "
            f"{len(with_people)} with people, {len(adds)} marker arrays with samples)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--name", default="rclpy")
    ap.add_argument("--sent", required=True)
    ap.add_argument("--received", required=True)
    ap.add_argument("--reference", required=True, help="the cliff-ros2-reference binary")
    ap.add_argument("--map", required=True)
    ap.add_argument("--map-components", type=int, default=-1)
    ap.add_argument("--map-label", default=None, help="the map as the messages must name it")
    ap.add_argument("--k", type=int, default=20)
    ap.add_argument("--method", default="cliff")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--horizon", type=float, default=12.0)
    ap.add_argument("--dt", type=float, default=0.4)
    ap.add_argument("--timeout", type=float, default=2.0)
    ap.add_argument("--history-seconds", type=float, default=3.2)
    ap.add_argument("--min-received", type=float, default=0.95)
    ap.add_argument("--transform", default="", help="x y yaw of the static transform into the map frame")
    ap.add_argument("--all-deleted", action="store_true")
    ap.add_argument("--gone", default="", help="file holding the unix time the daemon was stopped")
    ap.add_argument("--back", default="", help="file holding the unix time it was started again")
    ap.add_argument("--log", default="", help="the node's log")
    ap.add_argument("--warn", action="append", default=[], help="TEXT:MIN:MAX lines of --log")
    ap.add_argument("--expect-skipped", action="store_true")
    ap.add_argument("--observed", default="", help="the log of a learning cliffd the node sent observations")
    ap.add_argument("--learned", default="", help="that cliffd's --learn-dir")
    ap.add_argument("--scores", action="store_true", help="the node scores its samples")
    ap.add_argument("--object-paths", type=int, default=3)
    a = ap.parse_args()
    r = Results(a.name)

    sent = json.load(open(a.sent))
    got = json.load(open(a.received))
    preds = got["predictions"]
    if a.log:
        check_log(r, a.log, a.warn)
    if a.expect_skipped:
        expect_skipped(r, got)
        print(f"{r.name}: {r.passed} passed, {r.failed} failed")
        return r
    if a.gone:
        check_gone(r, sent, preds, float(open(a.gone).read()), float(open(a.back).read()))
    if a.all_deleted:
        check_all_deleted(r, got["markers"])
    r.check(len(sent) > 0 and len(preds) >= a.min_received * len(sent),
            f"{len(preds)} predictions for {len(sent)} people messages",
            f"expected at least {a.min_received:.0%}")

    transform = [float(v) for v in a.transform.split()] if a.transform else None
    expected, rows, tracks = replay(sent, a.timeout, a.history_seconds, transform)
    if a.observed:
        check_observed(r, rows, tracks, a.observed, a.learned)
    bad_meta, bad_rules, cycles = [], [], []
    for p in preds:
        key = tuple(p["stamp"])
        label = a.map if a.map_label is None else a.map_label
        if (p["frame"], p["method"], p["k"], p["seed"], p["dt"], p["horizon"], p["map"]) != ("map", a.method, a.k, a.seed, a.dt, a.horizon, label):
            bad_meta.append(key)
        if key not in expected:
            bad_rules.append((key, "stamp not published"))
            continue
        ids, hist = expected[key]
        mine = [q["track_id"] for q in p["people"]]
        lens = [q["history"] for q in p["people"]]
        if mine != ids or lens != [len(h) for h in hist]:
            bad_rules.append((key, f"node {list(zip(mine, lens))} expected {list(zip(ids, [len(h) for h in hist]))}"))
            continue
        if ids:
            cycles.append((p, {"stamp": list(key), "agents": hist}))
    r.check(not bad_meta, "frame, method, map, k, seed, dt and horizon as set", str(bad_meta[:3]))
    r.check(not bad_rules, f"the people predicted and their histories follow the track rules ({len(preds)} messages)",
            str(bad_rules[:2]))
    people = sum(len(p["people"]) for p, _ in cycles)
    r.check(people > 0, f"{people} person predictions in {len(cycles)} messages to compare")

    ref_in = {"map": a.map, "method": a.method, "k": a.k, "horizon": a.horizon, "dt": a.dt,
              "seed": a.seed, "scores": a.scores, "cycles": [c for _, c in cycles]}
    res = subprocess.run([a.reference], input=json.dumps(ref_in), capture_output=True, text=True)
    if res.returncode != 0:
        r.check(False, "reference ran", res.stderr.strip())
    else:
        ref = json.loads(res.stdout)["cycles"]
        mism = []
        for (p, c), rc in zip(cycles, ref):
            for q, rq in zip(p["people"], rc["people"]):
                pts = [[f32(x), f32(y)] for x, y in rq["points"]]
                if q["lengths"] != rq["lengths"] or q["points"] != pts:
                    mism.append((p["stamp"], q["track_id"]))
                last = c["agents"][p["people"].index(q)][-1]
                if q["origin"] != [f32(last[2]), f32(last[3])] or q["stamp"] != [last[0], last[1]]:
                    mism.append((p["stamp"], q["track_id"], "origin"))
        r.check(not mism and len(ref) == len(cycles),
                f"positions equal the in-process reference for the same histories and seed ({people} people)",
                f"{len(mism)} differ, first {mism[:3]}")

    check_objects(r, preds, got.get("objects", []), expected, a.dt, a.object_paths, a.min_received)
    check_grid(r, preds, got.get("grids", []), a.dt, 1.6, a.min_received)

    # markers: the arrays with line strips, in order, match the predictions with people
    adds = [m for m in got["markers"] if any(k["action"] == 0 for k in m)]
    with_people = [p for p in preds if p["people"]]
    bad = []
    for p, m in zip(with_people, adds):
        strips = [k for k in m if k["action"] == 0]
        if len(strips) != len(p["people"]) * a.k:
            bad.append((p["stamp"], "count"))
            continue
        i = 0
        for q in p["people"]:
            start = 0
            for s, n in enumerate(q["lengths"]):
                k = strips[i]
                i += 1
                want = [q["origin"]] + q["points"][start:start + n]
                if n == 0:
                    want = [q["origin"], q["origin"]]
                start += n
                if k["type"] != 4 or k["frame"] != "map" or k["points"] != want:
                    bad.append((p["stamp"], q["track_id"], s))
    r.check(len(adds) >= a.min_received * len(with_people) and not bad,
            f"{len(adds)} marker arrays of line strips equal the predicted samples", str(bad[:3]))
    dels = sum(1 for m in got["markers"] for k in m if k["action"] == 2)
    r.check(dels > 0 and dels % a.k == 0, f"markers of ended tracks deleted ({dels // a.k} tracks)")

    mm = got["map_markers"]
    ok = len(mm) >= 1 and all(k["type"] == 0 for k in mm[0][1:]) and mm[0][0]["action"] == 3
    if a.map_components >= 0 and mm:
        ok = ok and len(mm[0]) == a.map_components + 1
    r.check(ok, f"the map as latched arrows ({len(mm[0]) - 1 if mm else 0} arrows)")

    print(f"{r.name}: {r.passed} passed, {r.failed} failed")
    return r


if __name__ == "__main__":
    res = main()
    sys.exit(1 if res.failed else 0)
