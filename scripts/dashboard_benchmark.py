#!/usr/bin/env python3
"""Benchmark (not a test): does the dashboard disturb the real-time loop? Runs of experiment1 through
`host serve --http` against the model virtual board, one after the other on the same server: with no
dashboard client, with N telemetry clients (Server-Sent Events read in Python, one of them slowly:
the server's side alone), and with N headless chromium browsers on the dashboard (a page each,
drawing the live plots: the server and the browsers' rendering). From each run's summary: the
underruns while streaming and the streaming loop's wake latency (p50, p99, p99.9, max); beside them
the CPU time `host serve` and chromium used, and the events the clients received.
Usage: scripts/dashboard_benchmark.py [--deltactl build/bin/deltactl] [--weights W.json] [--seconds 60]
                                      [--clients 10] [--kinds none,sse,chromium]"""
import argparse
import os
import re
import shutil
import sys
import time

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, "tests", "dashboard"))
from dashboard_bench import Bench, Browser, EventReader  # noqa: E402

TICKS_PER_S = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pids):
    """User and system CPU time of these processes and their threads (children that ended not counted)."""
    total = 0
    for pid in pids:
        try:
            with open("/proc/%d/stat" % pid) as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += int(fields[11]) + int(fields[12])
        except (OSError, IndexError, ValueError):
            pass
    return total / TICKS_PER_S


def process_tree(pid):
    """pid and all its descendants now."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open("/proc/%s/stat" % entry) as f:
                    parent = int(f.read().rsplit(")", 1)[1].split()[1])
                children.setdefault(parent, []).append(int(entry))
            except (OSError, IndexError, ValueError):
                pass
    tree, todo = [], [pid]
    while todo:
        p = todo.pop()
        tree.append(p)
        todo.extend(children.get(p, []))
    return tree


def one_run(bench, seconds, kind, clients, chromium):
    readers, tabs, browsers = [], [], []
    if kind == "sse":
        readers = [EventReader(bench.port, slow_s=0.5 if k == 0 else 0.0) for k in range(clients)]
        for reader in readers:
            reader.start()
    elif kind == "chromium":
        # Separate browsers, one page each: a browser keeps at most 6 HTTP/1.1 connections to a host,
        # and every page's telemetry stream holds one, so one browser's 7th page would never load.
        browsers = [Browser(chromium) for _ in range(clients)]
        tabs = [browser.open("http://127.0.0.1:%d/?no-token-prompt" % bench.port) for browser in browsers]
        for tab in tabs:
            tab.wait("window.dashboard && window.dashboard.events > 0", 120, "telemetry in every tab")
    time.sleep(2.0)
    browser_pids = [pid for browser in browsers for pid in process_tree(browser.process.pid)]
    serve_cpu, browser_cpu = cpu_seconds([bench.serve.pid]), cpu_seconds(browser_pids)
    load = os.getloadavg()[0]
    code, body = bench.post("run", {"trajectory": "experiment1", "duration": seconds})
    if code != 200:
        sys.exit("run refused: %s" % body)
    time.sleep(2.0)
    status = bench.wait_for(lambda s: s["run"] is None and s.get("last_run"), 10 * seconds + 120, "the run's end")
    serve_cpu = cpu_seconds([bench.serve.pid]) - serve_cpu
    browser_cpu = cpu_seconds(browser_pids) - browser_cpu
    load = max(load, os.getloadavg()[0])
    if readers:
        events = [len(r.data_events()) for r in readers]
        received = "%d..%d events" % (min(events), max(events))
    elif tabs:
        counts = [tab.js("[window.dashboard.events, window.dashboard.draws]") for tab in tabs]
        received = "%d..%d events, %d..%d redraws" % (min(c[0] for c in counts), max(c[0] for c in counts),
                                                      min(c[1] for c in counts), max(c[1] for c in counts))
    else:
        received = "-"
    for reader in readers:
        reader.stopped = True
    for browser in browsers:
        browser.close()
    summary = status["last_run"].get("summary", "")
    underruns = re.search(r"underruns while streaming (\d+)", summary)
    latency = re.search(r"wake latency p50 (\d+) us, p99 (\d+) us, p99.9 (\d+) us, max (\d+) us; overruns (\d+)",
                        summary)
    if not latency:
        sys.exit("no wake latency in the run's summary: %s (%s)" % (summary, status["last_run"]))
    return {
        "what": {"none": "no client", "sse": "%d telemetry clients" % clients,
                 "chromium": "%d chromium browsers" % clients}[kind],
        "outcome": status["last_run"].get("outcome"),
        "underruns": int(underruns.group(1)) if underruns else -1,
        "p50_us": int(latency.group(1)), "p99_us": int(latency.group(2)), "p999_us": int(latency.group(3)),
        "max_us": int(latency.group(4)), "overruns": int(latency.group(5)),
        "serve_cpu": serve_cpu, "browser_cpu": browser_cpu, "load": load, "received": received,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--deltactl", default=os.path.join(root, "build", "bin", "deltactl"))
    parser.add_argument("--weights", default=os.path.join(root, "weights", "paper_like.json"))
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--clients", type=int, default=10)
    parser.add_argument("--kinds", default="none,sse,chromium", help="which runs, in order")
    options = parser.parse_args()
    kinds = options.kinds.split(",")
    chromium = shutil.which("chromium")
    if "chromium" in kinds and not chromium:
        sys.exit("no chromium (scripts/setup.sh installs it); --kinds none,sse runs without it")
    bench = Bench(options.deltactl, options.weights, "benchmark")
    results = []
    try:
        bench.post("home")
        bench.wait_for(lambda s: s["state"] == "homed", 10, "homed")
        for kind in kinds:
            print("run of %.0f s with %s ..." % (options.seconds, kind), flush=True)
            results.append(one_run(bench, options.seconds, kind, options.clients, chromium))
            print("  %(outcome)s, underruns %(underruns)d, wake p99 %(p99_us)d us" % results[-1], flush=True)
    finally:
        bench.close()
    print("\n%d cores, %.0f s runs of experiment1 (model virtual board)\n" % (os.cpu_count(), options.seconds))
    print("| dashboard | outcome | underruns | wake p50 [us] | p99 [us] | p99.9 [us] | max [us] | overruns "
          "| host serve CPU [s] | chromium CPU [s] | load (1 min) | received per client |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print("| %(what)s | %(outcome)s | %(underruns)d | %(p50_us)d | %(p99_us)d | %(p999_us)d | %(max_us)d | "
              "%(overruns)d | %(serve_cpu).1f | %(browser_cpu).1f | %(load).1f | %(received)s |" % r)
    base = results[0]
    print()
    for r in results[1:]:
        change = 100.0 * (r["p99_us"] - base["p99_us"]) / max(base["p99_us"], 1)
        verdict = "met" if r["underruns"] == 0 and change <= 10.0 else "NOT met"
        print("%s: underruns %d, wake p99 %+.0f %% against %s: %s (no underrun, p99 within 10 %%)"
              % (r["what"], r["underruns"], change, base["what"], verdict))
    bench.remove()


if __name__ == "__main__":
    main()
