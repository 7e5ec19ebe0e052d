"""What the dashboard's tests and benchmark share: a model virtual board, `host serve --http` on it, HTTP calls
and a Server-Sent Events reader (Python's standard library only)."""
import http.client
import json
import os
import re
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

    def __init__(self, deltactl, weights, name, extra_serve=()):
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
             "--record-folder", self.records, "--link-timeout-ms", "1000", "--http", "127.0.0.1:0",
             "--http-token-file", self.token_file, *extra_serve],
            stdout=subprocess.DEVNULL, stderr=self.serve_err, text=True)
        self.port = None
        deadline = time.time() + 60
        while self.port is None:
            if time.time() > deadline or self.serve.poll() is not None:
                raise Failure("serve did not start: " + self.serve_log())
            match = re.search(r"dashboard on http://127\.0\.0\.1:(\d+)/", self.serve_log())
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
