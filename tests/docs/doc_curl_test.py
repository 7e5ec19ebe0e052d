#!/usr/bin/env python3
"""Every curl command of the docs runs as written against `deltactl host serve --http` on a model
virtual board, in the order the docs give them. The commands are each ```sh block's lines that start
with `curl` (with their `\\` continuations) in README.md and docs/*.md; each runs in bash with the
real curl, unchanged but for the port: the docs' 127.0.0.1:8080 becomes the test server's. $TOKEN is
what the docs' own `TOKEN=...` line gives, run with HOME a scratch folder holding the server's token
at ~/.config/deltactl-token. curl's status code comes from a .curlrc (CURL_HOME) that adds
`write-out`, so the command line itself is untouched. Each answer must be the documented one: 2xx
with a body (a JSON POST reply with "ok" true), or the status a `# ... NNN ...` comment on the line
names (then with "ok" false); a piped command (`| head`) must print Server-Sent Events. Between
commands the test waits, as a person would, for what the previous one does (homed, the run
streaming, held, streaming again, the run's end, the drives off, no fault). A command the docs
document as refused must change nothing (state, homed, drives, run). Every POST of the API has a
curl example, and the e-stop's latch is shown: a run refused (409) after the e-stop, then the
clear, then a run that moves. Usage: doc_curl_test.py DELTACTL WEIGHTS SOURCE_DIR"""
import json
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "dashboard"))
from dashboard_bench import Bench, Failure, check  # noqa: E402

DOC_PORT = "8080"
POSTS = ("home", "run", "hold", "resume", "stop", "estop", "clear")


def doc_commands(source_dir):
    """[(file:line, command, documented status or None)] of every curl line, and the TOKEN lines."""
    files = [os.path.join(source_dir, "README.md")]
    docs = os.path.join(source_dir, "docs")
    files += [os.path.join(docs, f) for f in sorted(os.listdir(docs)) if f.endswith(".md")]
    commands, token_lines = [], []
    for path in files:
        inside, pending, first = False, None, 0
        for number, line in enumerate(open(path, encoding="utf-8").read().splitlines(), 1):
            if re.match(r"^\s*```", line):
                inside = line.strip() == "```sh"
                continue
            if not inside:
                continue
            if pending is not None:
                pending += " " + line.strip()
            elif re.match(r"^\s*curl\s", line):
                pending, first = line.strip(), number
            elif re.match(r"^\s*TOKEN=", line):
                token_lines.append(line.strip())
                continue
            else:
                continue
            if pending.endswith("\\"):
                pending = pending[:-1].rstrip()
                continue
            where = "%s:%d" % (os.path.relpath(path, source_dir), first)
            command, _, comment = pending.partition(" #")
            documented = re.search(r"\b([1-5]\d\d)\b", comment)
            commands.append((where, command.strip(), int(documented.group(1)) if documented else None))
            pending = None
    return commands, token_lines


def endpoint(command):
    match = re.search(r"/api/(\w+)", command)
    return match.group(1) if match else ""


def run_curl(command, environment, port):
    """(status, body text) of the command as written, the docs' port replaced by the server's."""
    written = command.replace("127.0.0.1:" + DOC_PORT, "127.0.0.1:%d" % port)
    result = subprocess.run(["bash", "-c", written], env=environment, capture_output=True, text=True, timeout=60)
    check(result.returncode == 0, "`%s` exits 0 (%d: %s)" % (written, result.returncode, result.stderr.strip()[:200]))
    if "|" in command:
        return None, result.stdout
    text, _, code = result.stdout.rstrip("\n").rpartition("\n")
    check(code.isdigit(), "`%s` gives a status (curl's write-out: %r)" % (written, result.stdout[-200:]))
    return int(code), text


def settle(bench, name, refused, before):
    """Waits for what the command does before the next one, as a person would; a refused command
    changed nothing (state, homed, drives, run as before it)."""
    if refused:
        time.sleep(0.5)
        status = bench.status()
        def seen(s):
            return {"state": s["state"], "homed": s["homed"], "drives_enabled": s["drives_enabled"],
                    "a run": s["run"] is not None}
        check(seen(status) == seen(before),
              "after the refused %s nothing changed (%s; before: %s)" % (name, seen(status), seen(before)))
    elif name == "home":
        bench.wait_for(lambda s: s["homed"] and s["state"] == "homed", 60, "homed")
    elif name == "run":
        bench.wait_for(lambda s: s["run"] and s["run"]["feed"] == "streaming" and s["run"]["played"] > 500, 30,
                       "the run streaming")
    elif name == "hold":
        bench.wait_for(lambda s: s["run"] and s["run"]["feed"] == "held" and s["state"] == "holding", 10, "held")
    elif name == "resume":
        bench.wait_for(lambda s: s["run"] and s["run"]["feed"] == "streaming", 10, "streaming again")
    elif name == "stop":
        bench.wait_for(lambda s: s["run"] is None and not s["drives_enabled"], 20, "the run's end, drives off")
    elif name == "estop":
        bench.wait_for(lambda s: s["run"] is None and not s["drives_enabled"] and (s.get("estop") or {}).get("latched"),
                       10, "drives off and the e-stop latched")
    elif name == "clear":
        bench.wait_for(lambda s: s["fault"] is None and not (s.get("estop") or {}).get("latched"), 10,
                       "no fault and no e-stop latched after the clear")


def run_checks(bench, commands, token_lines):
    shown = {endpoint(c) for _, c, _ in commands}
    for name in POSTS:
        check(name in shown, "the docs show POST /api/%s with curl" % name)
    check(token_lines, "the docs say how to set $TOKEN")
    order = [(endpoint(c), documented) for _, c, documented in commands]
    estop = next((i for i, (name, _) in enumerate(order) if name == "estop"), None)
    clear = next((i for i, (name, _) in enumerate(order) if name == "clear" and estop is not None and i > estop), None)
    check(estop is not None and clear is not None and
          any(name == "run" and documented == 409 for name, documented in order[estop + 1:clear]),
          "the docs show a run refused (409) between the e-stop and its clear (the latch)")
    check(any(name == "run" and documented is None for name, documented in order[(clear or 0) + 1:]),
          "the docs show a run after the clear")
    scratch = bench.dir + "/home"
    os.makedirs(scratch + "/.config")
    with open(scratch + "/.config/deltactl-token", "w") as f:
        f.write(bench.token + "\n")
    with open(scratch + "/.curlrc", "w") as f:
        f.write('write-out = "\\n%{http_code}\\n"\n')
    environment = dict(os.environ, HOME=scratch, CURL_HOME=scratch)
    for line in token_lines:
        token = subprocess.run(["bash", "-c", line + '; printf %s "$TOKEN"'], env=environment, capture_output=True,
                               text=True, timeout=10).stdout
        check(token == bench.token, "`%s` gives the server's token" % line)
    environment["TOKEN"] = bench.token
    for where, command, documented in commands:
        name = endpoint(command)
        before = bench.status()
        code, body = run_curl(command, environment, bench.port)
        if code is None:
            events = [l for l in body.splitlines() if l.startswith("data:") or l.startswith("event:")]
            check(events and body.startswith("event: history"),
                  "%s: `%s` prints Server-Sent Events, the history first (%d lines)" % (where, command, len(events)))
            continue
        expected = "%d" % documented if documented else "2xx"
        check((code == documented) if documented else 200 <= code < 300,
              "%s: `%s` answers %d (%s documented)" % (where, command, code, expected))
        check(body.strip() != "", "%s: the answer has a body (%d bytes)" % (where, len(body)))
        try:
            reply = json.loads(body)
        except ValueError:
            raise Failure("%s: the answer is not JSON: %r" % (where, body[:200]))
        if "-X POST" in command:
            check(reply.get("ok") is (documented is None),
                  "%s: the reply says ok %s (%s)" % (where, documented is None, json.dumps(reply)[:300]))
        else:
            check("state" in reply, "%s: the status has a state (%s)" % (where, reply.get("state")))
        settle(bench, name, documented is not None and documented >= 400, before)
    print("doc curl: %d commands ran as written" % len(commands))


def main():
    if len(sys.argv) != 4:
        print("usage: doc_curl_test.py DELTACTL WEIGHTS SOURCE_DIR", file=sys.stderr)
        return 2
    deltactl, weights, source_dir = sys.argv[1:]
    commands, token_lines = doc_commands(source_dir)
    bench = Bench(deltactl, weights, "doc_curl")
    try:
        run_checks(bench, commands, token_lines)
    except Failure as failure:
        print("FAIL: %s\nserve's log:\n%s" % (failure, bench.serve_log()[-4000:]))
        return 1
    finally:
        bench.close()
    bench.remove()
    return 0


if __name__ == "__main__":
    sys.exit(main())
