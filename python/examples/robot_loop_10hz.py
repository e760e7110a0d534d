#!/usr/bin/env python3
"""A robot's 10 Hz loop against cliffd: track three people, predict them every cycle.

Start the daemon first (it serves the built-in demo hall as `demo`):

    cargo run --release -p cliff-service --bin cliffd
    python python/examples/robot_loop_10hz.py --seconds 5

or reach it over zenoh, from this host or another one (the daemon and this package
both built with the cargo feature zenoh):

    cargo run --release -p cliff-service --features zenoh --bin cliffd -- --zenoh tcp/0.0.0.0:7447
    python python/examples/robot_loop_10hz.py --zenoh tcp/192.0.2.10:7447

Each cycle appends the people's new positions to their histories (the last 8 rows
are sent), asks the daemon for 20 samples 12 s ahead, and prints where the first
sample of each person is 4 s from now. A cycle without a daemon, or whose answer comes
too late, is skipped, and the loop carries on: the same client works again once the
daemon is back.
"""

import argparse
import math
import time

import numpy as np

import cliff_lhmp


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--service", default="cliff/predict")
    ap.add_argument("--prefix", default=None, help="cliffd's --prefix, if any")
    ap.add_argument("--map", default="demo")
    ap.add_argument("--zenoh", metavar="ENDPOINT", default=None,
                    help="reach cliffd over zenoh at ENDPOINT (e.g. tcp/192.0.2.10:7447) "
                         "instead of shared memory")
    ap.add_argument("--zenoh-config", metavar="FILE", default=None,
                    help="zenoh configuration file (TLS certificates, ...)")
    ap.add_argument("--deadline", type=float, default=0.05, help="seconds per request")
    a = ap.parse_args()
    if (a.zenoh or a.zenoh_config) and not cliff_lhmp.HAS_ZENOH:
        ap.error("this cliff_lhmp was built without zenoh: "
                 "pip install ./python -C maturin.build-args=\"--features zenoh\"")

    def connect() -> cliff_lhmp.Client:
        if a.zenoh or a.zenoh_config:
            return cliff_lhmp.Client.connect_zenoh(a.zenoh, a.service, config=a.zenoh_config,
                                                   deadline=a.deadline)
        return cliff_lhmp.Client(a.service, prefix=a.prefix, deadline=a.deadline)

    client = None
    # three people walking through the demo hall (x from -14 to 14 m, y from -9 to 9 m)
    starts = [(-12.0, -1.0, 0.0), (10.0, 1.0, math.pi), (0.5, -8.0, math.pi / 2)]
    speed, period = 1.2, 0.1
    history = [[] for _ in starts]
    t0 = time.monotonic()
    cycles = ok = 0
    latencies = []
    while (now := time.monotonic() - t0) < a.seconds:
        for h, (x, y, heading) in zip(history, starts):
            h.append((now, x + speed * now * math.cos(heading), y + speed * now * math.sin(heading),
                      speed, heading))
            del h[:-8]
        cycles += 1
        try:
            if client is None:
                client = connect()
            t = time.perf_counter()
            p = client.predict(a.map, [np.array(h) for h in history], k=20, dt=0.4, horizon=12.0)
            latencies.append(time.perf_counter() - t)
            ok += 1
            if cycles % 10 == 1:
                at4 = [p.positions[i, 0, 9] for i in range(len(history))]
                print(f"t {now:5.1f} s: in 4 s " + ", ".join(
                    f"person {i} at ({xy[0]:6.2f}, {xy[1]:6.2f})" if not np.isnan(xy[0])
                    else f"person {i} off the map" for i, xy in enumerate(at4)))
        except (cliff_lhmp.NoDaemon, cliff_lhmp.DaemonGone, cliff_lhmp.DeadlinePassed) as e:
            print(f"t {now:5.1f} s: no prediction this cycle: {e}")
        next_cycle = t0 + cycles * period
        time.sleep(max(0.0, next_cycle - time.monotonic()))
    if latencies:
        lat = np.array(latencies) * 1e6
        print(f"{ok} of {cycles} cycles predicted; round trip p50 {np.median(lat):.0f} us, "
              f"max {lat.max():.0f} us")
    else:
        print(f"0 of {cycles} cycles predicted (is cliffd running"
              f"{' with --zenoh' if a.zenoh else ''}?)")


if __name__ == "__main__":
    main()
