#!/usr/bin/env python3
"""Benchmark (not a test): does the dashboard disturb the real-time loop? Two 60 s runs of
experiment1 through `host serve --http` against the model virtual board: one with no dashboard
client, one with 10 telemetry clients (Server-Sent Events, one of them reading slowly); from each
run's summary the underruns while streaming and the streaming loop's wake latency (p50, p99, max),
and the events the clients received.
Usage: scripts/dashboard_benchmark.py [--deltactl build/bin/deltactl] [--weights W.json] [--seconds 60]"""
import argparse
import os
import re
import sys
import threading
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "tests", "dashboard"))
from dashboard_bench import Bench, EventReader  # noqa: E402


def one_run(bench, seconds, clients):
    readers = [EventReader(bench.port, slow_s=0.5 if k == 0 else 0.0) for k in range(clients)]
    for reader in readers:
        reader.start()
    time.sleep(1.0)
    code, body = bench.post("run", {"trajectory": "experiment1", "duration": seconds})
    if code != 200:
        sys.exit("run refused: %s" % body)
    time.sleep(2.0)
    status = bench.wait_for(lambda s: s["run"] is None and s.get("last_run"), 4 * seconds + 120, "the run's end")
    for reader in readers:
        reader.stopped = True
    summary = status["last_run"].get("summary", "")
    underruns = re.search(r"underruns while streaming (\d+)", summary)
    latency = re.search(r"wake latency p50 (\d+) us, p99 (\d+) us, p99.9 (\d+) us, max (\d+) us; overruns (\d+)",
                        summary)
    events = [len(r.data_events()) for r in readers]
    return {
        "clients": clients, "outcome": status["last_run"].get("outcome"),
        "underruns": int(underruns.group(1)) if underruns else None,
        "p50_us": int(latency.group(1)), "p99_us": int(latency.group(2)), "p999_us": int(latency.group(3)),
        "max_us": int(latency.group(4)), "overruns": int(latency.group(5)),
        "events_per_client": "%d..%d" % (min(events), max(events)) if events else "-",
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--deltactl", default=os.path.join(root, "build", "bin", "deltactl"))
    parser.add_argument("--weights", default=os.path.join(root, "weights", "paper_like.json"))
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--clients", type=int, default=10)
    options = parser.parse_args()
    bench = Bench(options.deltactl, options.weights, "benchmark")
    try:
        bench.post("home")
        results = []
        for clients in (0, options.clients):
            print("run of %.0f s with %d dashboard clients ..." % (options.seconds, clients), flush=True)
            results.append(one_run(bench, options.seconds, clients))
    finally:
        bench.close()
    print("\n| dashboard clients | outcome | underruns | wake p50 [us] | p99 [us] | p99.9 [us] | max [us] | overruns "
          "| events per client |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print("| %(clients)d | %(outcome)s | %(underruns)s | %(p50_us)d | %(p99_us)d | %(p999_us)d | %(max_us)d | "
              "%(overruns)d | %(events_per_client)s |" % r)
    base, loaded = results[0]["p99_us"], results[1]["p99_us"]
    print("\np99 with %d clients: %+.0f %% against none" % (options.clients, 100.0 * (loaded - base) / max(base, 1)))
    bench.remove()


if __name__ == "__main__":
    main()
