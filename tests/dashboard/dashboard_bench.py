"""What the dashboard's tests and benchmark share: a model virtual board, `host serve --http` on it, HTTP calls,
a Server-Sent Events reader and headless chromium (Python's standard library only)."""
import base64
import http.client
import json
import os
import re
import select
import shutil
import subprocess
import tempfile
import threading
import time


class Failure(Exception):
    pass


def check(condition, what):
    print(("ok:   " if condition else "FAIL: ") + what, flush=True)
    if not condition:
        raise Failure(what)


class Bench:
    """A model-fidelity virtual board (kept to real time) and `host serve --http 127.0.0.1:0` on it."""

    def __init__(self, deltactl, weights, name, extra_serve=(), http="127.0.0.1:0"):
        self.deltactl = deltactl
        self.weights = weights
        self.dir = tempfile.mkdtemp(prefix="dash_" + name + "_")
        self.link = self.dir + "/tty"
        self.truth = self.dir + "/truth.csv"
        self.records = self.dir + "/runs"
        self.token_file = self.dir + "/http-token"
        self.board = subprocess.Popen(
            [deltactl, "virtual-board", "--link", self.link, "--weights", weights, "--truth", self.truth,
             "--fidelity", "model"], stdout=subprocess.PIPE, stderr=open(self.dir + "/board.err", "w"), text=True)
        ready = self.board.stdout.readline()
        if self.link not in ready:
            raise Failure("virtual board not ready: " + ready)
        self.serve_err = open(self.dir + "/serve.err", "w+")
        self.serve = subprocess.Popen(
            [deltactl, "host", "serve", "--port", self.link, "--weights", weights, "--socket", self.dir + "/ctl.sock",
             "--record-folder", self.records, "--link-timeout-ms", "1000", "--http", http,
             "--http-token-file", self.token_file, *extra_serve],
            stdout=subprocess.DEVNULL, stderr=self.serve_err, text=True)
        self.port = None
        deadline = time.time() + 60
        while self.port is None:
            if time.time() > deadline or self.serve.poll() is not None:
                raise Failure("serve did not start: " + self.serve_log())
            match = re.search(r"dashboard on http://[^ /]+:(\d+)/", self.serve_log())
            if match:
                self.port = int(match.group(1))
            time.sleep(0.05)
        self.token = open(self.token_file).read().strip()
        deadline = time.time() + 60
        while self.status().get("connection") != "connected":
            if time.time() > deadline:
                raise Failure("serve never connected: " + self.serve_log())
            time.sleep(0.1)

    def serve_log(self):
        self.serve_err.flush()
        with open(self.dir + "/serve.err") as f:
            return f.read()

    def request(self, method, path, body=None, token=True, headers=None):
        """(status, parsed JSON or bytes)."""
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        h = {"Host": "127.0.0.1:%d" % self.port}
        if token:
            h["Authorization"] = "Bearer " + (self.token if token is True else token)
        if body is not None:
            h["Content-Type"] = "application/json"
        h.update(headers or {})
        connection.request(method, path, body=None if body is None else json.dumps(body), headers=h)
        response = connection.getresponse()
        data = response.read()
        connection.close()
        kind = response.getheader("Content-Type", "")
        return response.status, json.loads(data) if kind.startswith("application/json") else data

    def status(self):
        try:
            code, body = self.request("GET", "/api/status", token=False)
            return body if code == 200 else {}
        except OSError:
            return {}

    def post(self, name, body=None, **kwargs):
        return self.request("POST", "/api/" + name, body=body, **kwargs)

    def curl_post(self, name, token=True):
        """(status, parsed JSON) of `curl -s -X POST [-H "Authorization: Bearer TOKEN"] URL`, as the docs
        write it: Debian 12's curl sends no Content-Length on a POST without a body."""
        command = ["curl", "-s", "-X", "POST", "-o", "-", "-w", "\n%{http_code}", "--max-time", "20"]
        if token:
            command += ["-H", "Authorization: Bearer " + self.token]
        command.append("http://127.0.0.1:%d/api/%s" % (self.port, name))
        output = subprocess.run(command, capture_output=True, text=True, timeout=30).stdout
        text, _, code = output.rpartition("\n")
        try:
            body = json.loads(text) if text else {}
        except ValueError:
            body = {"unparsed": text}
        return int(code or 0), body

    def wait_for(self, done, timeout_s, what):
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            status = self.status()
            if status and done(status):
                return status
            time.sleep(0.05)
        raise Failure("timed out waiting for " + what + "; status: " + json.dumps(self.status())[:600])

    def truth_rows(self):
        with open(self.truth) as f:
            lines = [line for line in f.read().splitlines() if line and not line.startswith("#")]
        names = lines[0].split(",")
        rows = []
        for line in lines[1:]:
            fields = line.split(",")
            if len(fields) == len(names):
                rows.append(dict(zip(names, map(float, fields))))
        return rows

    def check_drives_off_after(self, asked, bound_ms, what):
        """The truth: drives on at board time `asked` (the newest telemetry before the e-stop), off
        within bound_ms of board time after it. The delay in ms."""
        time.sleep(1.5)  # the truth is flushed every second
        rows = self.truth_rows()
        on = [r for r in rows if r["t_s"] <= asked]
        check(on and on[-1]["drives_enabled"] == 1, "truth: drives on at board time %.3f s before %s" % (asked, what))
        off = [r["t_s"] for r in rows if r["t_s"] > asked and r["drives_enabled"] == 0]
        check(off, "truth: drives off after " + what)
        delay_ms = (off[0] - asked) * 1e3
        check(delay_ms <= bound_ms, "truth: drives off %.1f ms of board time after the newest telemetry before %s "
              "(<= %g)" % (delay_ms, what, bound_ms))
        return delay_ms

    def close(self):
        for process in (self.serve, self.board):
            if process.poll() is None:
                process.terminate()
                try:
                    process.wait(20)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()

    def remove(self):
        shutil.rmtree(self.dir, ignore_errors=True)


class EventReader(threading.Thread):
    """GET /api/telemetry in a thread: every event as (wall time, event name, parsed data)."""

    def __init__(self, port, token=None, slow_s=0.0):
        super().__init__(daemon=True)
        self.port, self.token, self.slow_s = port, token, slow_s
        self.events = []
        self.stopped = False
        self.error = None
        self.http_status = None

    def run(self):
        try:
            connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10)
            headers = {"Host": "127.0.0.1:%d" % self.port}
            if self.token:
                headers["Authorization"] = "Bearer " + self.token
            connection.request("GET", "/api/telemetry", headers=headers)
            response = connection.getresponse()
            self.http_status = response.status
            if response.status != 200:
                return
            name, data = "message", ""
            while not self.stopped:
                line = response.readline()
                if not line:
                    break
                line = line.decode().rstrip("\n")
                if line.startswith("event:"):
                    name = line[6:].strip()
                elif line.startswith("data:"):
                    data += line[5:].strip()
                elif line == "":
                    if data:
                        self.events.append((time.time(), name, json.loads(data)))
                        if self.slow_s:
                            time.sleep(self.slow_s)
                    name, data = "message", ""
            connection.close()
        except Exception as error:  # reported by the test
            self.error = error

    def data_events(self):
        return [e for e in self.events if e[1] == "message"]


class Browser:
    """Debian's chromium, headless, driven through the DevTools protocol on a pipe (no extra package):
    `--remote-debugging-pipe` reads commands on fd 3 and writes answers and events on fd 4. It runs at
    normal priority, as a person's browser does: the virtual board and the host's streaming loop are
    SCHED_FIFO and come first all the same (an idle browser at the lowest priority, behind a busy
    machine's compilers, answered nothing for minutes)."""

    def __init__(self, executable, width=1280, height=1500, answer_timeout_s=180):
        self.answer_timeout_s = answer_timeout_s
        self.width, self.height = width, height
        self.profile = tempfile.mkdtemp(prefix="dash_chromium_")
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()

        def fds():  # copies first: a pipe's end may already be fd 3 or 4 (and close-on-exec)
            commands, answers = os.dup(to_browser_r), os.dup(from_browser_w)
            os.dup2(commands, 3)
            os.dup2(answers, 4)

        flags = ["--headless", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage", "--mute-audio",
                 "--disable-extensions", "--user-data-dir=" + self.profile, "--remote-debugging-pipe",
                 "--window-size=%d,%d" % (width, height)]
        if os.geteuid() == 0:
            flags.append("--no-sandbox")  # chromium refuses to run as root with its sandbox
        # The copies on 3 and 4 are not close-on-exec (dup2); close_fds would close them again.
        self.process = subprocess.Popen([executable, *flags, "about:blank"], preexec_fn=fds,
                                        close_fds=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.buffer = b""
        self.next_id = 0

    def send(self, method, params=None, session=None):
        """The answer to one command (events arriving meanwhile are passed over)."""
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.time() + self.answer_timeout_s
        while True:
            while b"\0" not in self.buffer:
                if not select.select([self.from_browser], [], [], max(0.0, deadline - time.time()))[0]:
                    raise Failure("chromium did not answer %s within %d s" % (method, self.answer_timeout_s))
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
        """A new tab showing `url`."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        tab = Tab(self, self.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"])
        tab.send("Page.enable")
        tab.send("Runtime.enable")
        tab.send("Emulation.setDeviceMetricsOverride", {"width": self.width, "height": self.height,
                                                         "deviceScaleFactor": 1, "mobile": False})
        tab.send("Page.navigate", {"url": url})
        return tab

    def close(self):
        try:
            self.send("Browser.close")
        except (Failure, OSError):
            pass
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for fd in (self.to_browser, self.from_browser):
            os.close(fd)
        shutil.rmtree(self.profile, ignore_errors=True)


class Tab:
    """One page in a Browser."""

    def __init__(self, browser, session):
        self.browser, self.session = browser, session

    def send(self, method, params=None):
        return self.browser.send(method, params, self.session)

    def js(self, expression):
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True})
        if "exceptionDetails" in result:
            raise Failure("page script: %s: %s" % (expression, result["exceptionDetails"]))
        return result["result"].get("value")

    def wait(self, expression, timeout_s, what, progress=None, limit_s=600):
        """Until `expression` is true in the page: within timeout_s, or, with `progress` (an
        expression such as the board's time), within timeout_s of its last change (a loaded machine
        slows the model board down; a stopped one is still caught) and limit_s in all."""
        start = time.time()
        deadline, last = start + timeout_s, None
        while time.time() < min(deadline, start + limit_s):
            try:
                if self.js(expression):
                    return
                if progress:
                    now = self.js(progress)
                    if now != last:
                        deadline, last = time.time() + timeout_s, now
            except Failure:
                pass
            time.sleep(0.1)
        raise Failure("timed out in the browser waiting for %s (%s)%s" % (
            what, expression, "; %s stayed at %s for %d s" % (progress, last, timeout_s) if progress else ""))

    def dom(self):
        """The document as it is now (the DOM, not the page's source)."""
        root = self.send("DOM.getDocument", {"depth": -1})["root"]
        return self.send("DOM.getOuterHTML", {"nodeId": root["nodeId"]})["outerHTML"]

    def screenshot(self, path):
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))
