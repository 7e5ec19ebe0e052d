#!/usr/bin/env python3
"""The dashboard's page in a real browser: Debian's chromium, headless, driven through the DevTools
protocol on a pipe (no extra package), against a model virtual board behind `host serve --http`.
The page loads and telemetry arrives; Run is pressed; two looks at the DOM show the plots moving
(the board time of the newest plotted sample, a data attribute of each plot, grows, and points are
drawn); then Hold (the page shows the feed held, Resume enabled) and Resume; the run completes and
its recording is listed. Screenshots (running, held, at the end; on a failure, as it failed) stay
in OUT_DIR as the test's artefacts.
Usage: dashboard_browser_test.py DELTACTL WEIGHTS OUT_DIR   (exit 77: no chromium, skipped)"""
import json
import os
import re
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dashboard_bench import Bench, Browser, Failure, check  # noqa: E402

PLOTS = ("plot-joints", "plot-error", "plot-currents", "plot-plate")
# Waits on the run are bounded by its progress, not by wall time: a loaded 2-core machine was seen
# running the model board at a tenth of real time. They fail when the run stands still for 60 s.
RUN_PROGRESS = "JSON.stringify(window.dashboard.status && window.dashboard.status.run &&" \
               " [window.dashboard.status.run.played, window.dashboard.status.run.feed])"
STALL_S = 60
START_S = 180  # chromium's start and the page's first events (seen: over 60 s on a machine at load 20)


def drawn_plots(dom):
    """{canvas id: (points drawn, board time of the newest sample in s)} from a dump of the DOM."""
    plots = {}
    for tag in re.findall(r"<canvas [^>]*>", dom):
        name = re.search(r'id="([^"]+)"', tag)
        points = re.search(r'data-points="(\d+)"', tag)
        newest = re.search(r'data-newest-s="([-0-9.]+)"', tag)
        if name and points and newest:
            plots[name.group(1)] = (int(points.group(1)), float(newest.group(1)))
    return plots


def main():
    deltactl, weights, out = sys.argv[1], sys.argv[2], sys.argv[3]
    chromium = shutil.which("chromium")
    if not chromium:
        print("skipped: no chromium (scripts/setup.sh installs it)")
        return 77
    os.makedirs(out, exist_ok=True)
    for old in os.listdir(out):
        if old.startswith("dashboard_") and old.endswith(".png"):
            os.remove(os.path.join(out, old))
    bench = Bench(deltactl, weights, "browser")
    browser = page = None
    try:
        code, body = bench.post("home")
        check(code == 200, "homed through the API")
        bench.wait_for(lambda s: s["state"] == "homed", 10, "homed")
        browser = Browser(chromium)
        page = browser.open("http://127.0.0.1:%d/?no-token-prompt" % bench.port)
        page.wait("window.dashboard && window.dashboard.events > 5", START_S, "telemetry events in the page")
        page.js("sessionStorage.setItem('deltactl-token', %s)" % json.dumps(bench.token))
        page.wait("document.getElementById('state').textContent === 'homed'", START_S, "the page to show homed")
        check(page.js("document.getElementById('hold').disabled && !document.getElementById('run-button').disabled"),
              "homed: Run enabled, Hold disabled")
        page.wait("[...document.getElementById('trajectory').options].some((o) => o.value === 'experiment1')", START_S,
                  "the trajectories listed")
        page.js("document.getElementById('trajectory').value = 'experiment1';"
                "document.getElementById('duration').value = '8';"
                "document.getElementById('run-button').click(); true")
        page.wait("document.getElementById('state').textContent === 'running'", STALL_S, "the page to show running",
                  RUN_PROGRESS)
        page.wait("window.dashboard.status.run && window.dashboard.status.run.played > 2000", STALL_S, "2 s played",
                  RUN_PROGRESS)

        # The plots move: the newest plotted sample's board time grows from one look at the DOM to the next.
        first = drawn_plots(page.dom())
        check(set(first) == set(PLOTS), "the DOM has the four plots with what they drew (%s)" % sorted(first))
        for name, (points, newest) in first.items():
            check(points >= 50, "%s: %d points drawn" % (name, points))
        newest = "Number(document.getElementById('plot-joints').dataset.newestS)"
        page.wait("%s >= %f" % (newest, first["plot-joints"][1] + 1.0), STALL_S, "1 s of board time more on the plots",
                  RUN_PROGRESS)
        later = drawn_plots(page.dom())  # the four plots are drawn in one frame
        for name in PLOTS:
            # The wait above compared with "%f" of first + 1.0 (rounded); 3.89 + 1.0 is 4.8900000000000006.
            check(later[name][1] >= first[name][1] + 1.0 - 1e-6,
                  "%s moved: newest sample at %.2f s of board time, then %.2f s" % (name, first[name][1], later[name][1]))
            check(later[name][0] >= first[name][0], "%s: %d points drawn, then %d (the window fills)"
                  % (name, first[name][0], later[name][0]))
        drawn = page.js("""(() => { const c = document.getElementById('plot-joints');
            const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
            for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 0) n++; return n / (c.width * c.height); })()""")
        check(drawn > 0.05, "the joint plot has %.0f %% of its pixels drawn" % (100 * drawn))
        age = page.js("document.getElementById('age').textContent")
        check(re.fullmatch(r"\d+ ms|\d+\.\d s", age) is not None, "the data age is shown (%s)" % age)
        page.screenshot(os.path.join(out, "dashboard_running.png"))

        check(not page.js("document.getElementById('hold').disabled"), "running: Hold enabled")
        page.js("document.getElementById('hold').click(); true")
        page.wait("window.dashboard.status.run && window.dashboard.status.run.feed === 'held'", STALL_S, "held",
                  RUN_PROGRESS)
        page.wait("document.getElementById('state').textContent === 'holding'", 10, "the page to show holding")
        check(page.js("!document.getElementById('resume').disabled && document.getElementById('hold').disabled"),
              "held: Resume enabled, Hold disabled")
        page.screenshot(os.path.join(out, "dashboard_held.png"))
        page.js("document.getElementById('resume').click(); true")
        page.wait("window.dashboard.status.run && window.dashboard.status.run.feed === 'streaming'", STALL_S,
                  "streaming again", RUN_PROGRESS)
        page.wait("window.dashboard.status.run === null && window.dashboard.status.last_run", STALL_S, "the run's end",
                  RUN_PROGRESS)
        outcome = page.js("window.dashboard.status.last_run.outcome")
        check(outcome == "completed", "the run completed (%s)" % outcome)
        page.wait("document.getElementById('run').textContent.startsWith('last run: completed')", 10,
                  "the page to say the last run completed")
        check(page.js("document.getElementById('estop').offsetHeight > 0"), "the e-stop is on the page")
        page.js("document.getElementById('refresh').click(); true")
        page.wait("document.getElementById('recording-list').rows.length >= 1", 20, "the recording listed")
        page.screenshot(os.path.join(out, "dashboard_done.png"))
        print("screenshots: " + ", ".join(os.path.join(out, n) for n in
                                           ("dashboard_running.png", "dashboard_held.png", "dashboard_done.png")))
    except Failure as failure:
        if page:
            try:
                page.screenshot(os.path.join(out, "dashboard_failed.png"))
            except (Failure, OSError):
                pass
        message = ""
        if page:
            try:
                message = page.js("document.getElementById('message').textContent")
            except (Failure, OSError):
                pass
        print("FAIL: %s\nthe page's message: %s\nlast run: %s\nserve's log:\n%s"
              % (failure, message, bench.status().get("last_run"), bench.serve_log()))
        return 1
    finally:
        if browser:
            browser.close()
        bench.close()
    bench.remove()
    return 0


if __name__ == "__main__":
    sys.exit(main())
