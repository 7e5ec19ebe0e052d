#!/usr/bin/env python3
"""The dashboard's page in a real browser: Debian's chromium, headless, driven through the DevTools
protocol on a pipe (no extra package), against a model virtual board behind `host serve --http`.
The page loads, telemetry arrives and the plots are redrawn, Run is pressed, then Hold (the page
shows the feed held, Resume enabled) and Resume; the run completes. Screenshots (running, and at
the end) stay in OUT_DIR as the test's artefacts.
Usage: dashboard_browser_test.py DELTACTL WEIGHTS OUT_DIR   (exit 77: no chromium, skipped)"""
import base64
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dashboard_bench import Bench, Failure, check  # noqa: E402


class Browser:
    """chromium --headless --remote-debugging-pipe: commands on fd 3, answers and events on fd 4."""

    def __init__(self, executable):
        self.profile = tempfile.mkdtemp(prefix="dash_chromium_")
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()

        def fds():  # copies first: a pipe's end may already be fd 3 or 4 (and close-on-exec)
            commands, answers = os.dup(to_browser_r), os.dup(from_browser_w)
            os.dup2(commands, 3)
            os.dup2(answers, 4)

        flags = ["--headless", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                 "--user-data-dir=" + self.profile, "--remote-debugging-pipe", "--window-size=1280,1500"]
        if os.geteuid() == 0:
            flags.append("--no-sandbox")  # chromium refuses to run as root with its sandbox
        # The pipe's ends are close-on-exec; their copies on 3 and 4 are not (dup2), and close_fds
        # would close them again.
        # At the lowest priority: the virtual board (kept to real time) must not starve behind it.
        self.process = subprocess.Popen(["nice", "-n", "19", executable, *flags, "about:blank"], preexec_fn=fds,
                                        close_fds=False,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.buffer = b""
        self.next_id = 0
        self.session = None

    def send(self, method, params=None, session=True):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            message["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in self.buffer:
                chunk = os.read(self.from_browser, 1 << 16)
                if not chunk:
                    raise Failure("chromium closed its pipe")
                self.buffer += chunk
            raw, self.buffer = self.buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise Failure("%s: %s" % (method, reply["error"]))
                return reply.get("result", {})

    def open(self, url):
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        self.send("Page.enable")
        self.send("Runtime.enable")
        self.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": 1500, "deviceScaleFactor": 1,
                                                         "mobile": False})
        self.send("Page.navigate", {"url": url})

    def js(self, expression):
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True})
        if "exceptionDetails" in result:
            raise Failure("page script: %s: %s" % (expression, result["exceptionDetails"]))
        return result["result"].get("value")

    def wait(self, expression, timeout_s, what):
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            try:
                if self.js(expression):
                    return
            except Failure:
                pass
            time.sleep(0.1)
        raise Failure("timed out in the browser waiting for " + what + " (" + expression + ")")

    def screenshot(self, path):
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self):
        try:
            self.send("Browser.close", session=False)
        except Exception:
            pass
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        shutil.rmtree(self.profile, ignore_errors=True)


def main():
    deltactl, weights, out = sys.argv[1], sys.argv[2], sys.argv[3]
    chromium = shutil.which("chromium")
    if not chromium:
        print("skipped: no chromium (scripts/setup.sh installs it)")
        return 77
    os.makedirs(out, exist_ok=True)
    bench = Bench(deltactl, weights, "browser")
    browser = None
    try:
        code, body = bench.post("home")
        check(code == 200, "homed through the API")
        browser = Browser(chromium)
        browser.open("http://127.0.0.1:%d/?no-token-prompt" % bench.port)
        browser.wait("window.dashboard && window.dashboard.events > 5", 30, "telemetry events in the page")
        browser.js("sessionStorage.setItem('deltactl-token', %s)" % json.dumps(bench.token))
        browser.wait("document.getElementById('state').textContent === 'homed'", 10, "the page to show homed")
        check(browser.js("document.getElementById('hold').disabled && !document.getElementById('run-button').disabled"),
              "homed: Run enabled, Hold disabled")
        browser.js("document.getElementById('trajectory').value = 'experiment1';"
                   "document.getElementById('duration').value = '12';"
                   "document.getElementById('run-button').click(); true")
        browser.wait("document.getElementById('state').textContent === 'running'", 20, "the page to show running")
        browser.wait("window.dashboard.status.run && window.dashboard.status.run.played > 2500", 20, "2.5 s played")
        before = browser.js("[window.dashboard.draws, window.dashboard.samples.length,"
                            " window.dashboard.samples[window.dashboard.samples.length - 1][0]]")
        time.sleep(1.0)
        after = browser.js("[window.dashboard.draws, window.dashboard.samples.length,"
                           " window.dashboard.samples[window.dashboard.samples.length - 1][0]]")
        check(after[0] - before[0] >= 3, "the plots were redrawn %d times in a second (at most 25; headless chromium "
              "paints less often on a busy machine)" % (after[0] - before[0]))
        check(after[2] - before[2] >= 0.5, "the newest sample moved %.2f s of board time on" % (after[2] - before[2]))
        drawn = browser.js("""(() => { const c = document.getElementById('plot-joints');
            const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
            for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 0) n++; return n / (c.width * c.height); })()""")
        check(drawn > 0.05, "the joint plot has %.0f %% of its pixels drawn" % (100 * drawn))
        age = browser.js("document.getElementById('age').textContent")
        check(age.endswith(" ms"), "the data age shows milliseconds (%s)" % age)
        browser.screenshot(os.path.join(out, "dashboard_running.png"))

        check(not browser.js("document.getElementById('hold').disabled"), "running: Hold enabled")
        browser.js("document.getElementById('hold').click(); true")
        browser.wait("window.dashboard.status.run && window.dashboard.status.run.feed === 'held'", 15, "held")
        browser.wait("document.getElementById('state').textContent === 'holding'", 5, "the page to show holding")
        check(browser.js("!document.getElementById('resume').disabled && document.getElementById('hold').disabled"),
              "held: Resume enabled, Hold disabled")
        browser.screenshot(os.path.join(out, "dashboard_held.png"))
        browser.js("document.getElementById('resume').click(); true")
        browser.wait("window.dashboard.status.run && window.dashboard.status.run.feed === 'streaming'", 15,
                     "streaming again")
        browser.wait("window.dashboard.status.run === null && window.dashboard.status.last_run", 40, "the run's end")
        outcome = browser.js("window.dashboard.status.last_run.outcome")
        check(outcome == "completed", "the run completed (%s)" % outcome)
        check(browser.js("document.getElementById('run').textContent").startswith("last run: completed"),
              "the page says the last run completed")
        check(browser.js("document.getElementById('estop').offsetHeight > 0"), "the e-stop is on the page")
        browser.js("document.getElementById('refresh').click(); true")
        browser.wait("document.getElementById('recording-list').rows.length >= 1", 10, "the recording listed")
        browser.screenshot(os.path.join(out, "dashboard_done.png"))
        print("screenshots: " + ", ".join(os.path.join(out, n) for n in
                                           ("dashboard_running.png", "dashboard_held.png", "dashboard_done.png")))
    except Failure as failure:
        if browser:
            try:
                browser.screenshot(os.path.join(out, "dashboard_failed.png"))
            except Failure:
                pass
        print("FAIL: %s\nlast run: %s\nserve's log:\n%s" % (failure, bench.status().get("last_run"), bench.serve_log()))
        return 1
    finally:
        if browser:
            browser.close()
        bench.close()
    bench.remove()
    return 0


if __name__ == "__main__":
    sys.exit(main())
