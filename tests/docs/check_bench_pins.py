#!/usr/bin/env python3
"""The wiring tables of docs/bench.md agree with rtl/board/icebreaker.pcf. A wiring table is a Markdown
table whose header has the columns `PMOD pin`, `iCEBreaker name`, `FPGA pin`, `port (icebreaker.pcf)`
and `FPGA pull-up`; each row with a port (in backticks; `-` for GND and 3V3) must name a port the pcf
places (`set_io [-nowarn] [-pullup yes|no] [-pullup_resistor R] PORT PIN`) on that FPGA pin, with
`yes` in the pull-up column exactly when the pcf says `-pullup yes`; every port of the pcf must have
a row; no FPGA pin and no iCEBreaker PMOD name (P1A1..P1A10, P1B1..P1B10, P2_1..P2_10) may have two
rows, and a PMOD name's number must be its row's PMOD pin. Usage: check_bench_pins.py BENCH_MD PCF
prints each disagreement as FILE:LINE: reason and exits 1 when there is one.
check_bench_pins.py --mutations BENCH_MD writes the pcf the tables describe, checks that it passes,
then changes it one way at a time (each port moved to another pin, each pull-up flipped, each port
removed, a port added) and checks that every change is caught: the check can fail."""
import re
import sys

COLUMNS = ("PMOD pin", "iCEBreaker name", "FPGA pin", "port (icebreaker.pcf)", "FPGA pull-up")
PMOD_NAME = re.compile(r"^(?:P1[AB]|P2_)(\d+)$")


def parse_pcf(text, name="icebreaker.pcf"):
    """{port: (pin, pulled up, line)} of every set_io line; raises ValueError naming a bad line."""
    ports = {}
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split("#", 1)[0].split()
        if not words or words[0] != "set_io":
            continue
        pullup, rest, i = False, [], 1
        while i < len(words):
            if words[i] == "-nowarn":
                i += 1
            elif words[i] in ("-pullup", "-pullup_resistor") and i + 1 < len(words):
                if words[i] == "-pullup":
                    pullup = words[i + 1] == "yes"
                i += 2
            else:
                rest.append(words[i])
                i += 1
        if len(rest) != 2 or not rest[1].isdigit():
            raise ValueError("%s:%d: a set_io line that is not 'set_io [options] PORT PIN'" % (name, number))
        ports[rest[0]] = (int(rest[1]), pullup, number)
    return ports


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


def parse_tables(text):
    """[(line, PMOD pin, name, FPGA pin or None, port or None, pull-up)] of every wiring table row."""
    rows, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        header = cells(lines[i]) if lines[i].lstrip().startswith("|") else []
        if all(c in header for c in COLUMNS) and i + 1 < len(lines) and set(lines[i + 1]) <= set("|-: "):
            at = {c: header.index(c) for c in COLUMNS}
            i += 2
            while i < len(lines) and lines[i].lstrip().startswith("|"):
                row = cells(lines[i])
                get = lambda c: row[at[c]] if at[c] < len(row) else ""
                port = re.fullmatch(r"`([^`]+)`", get("port (icebreaker.pcf)"))
                pin = get("FPGA pin")
                rows.append((i + 1, get("PMOD pin"), get("iCEBreaker name"), int(pin) if pin.isdigit() else None,
                             port.group(1) if port else None, get("FPGA pull-up")))
                i += 1
        else:
            i += 1
    return rows


def check(doc_text, pcf_text, doc="docs/bench.md"):
    """The disagreements between the wiring tables and the pcf, each 'FILE:LINE: reason'."""
    try:
        pcf = parse_pcf(pcf_text)
    except ValueError as error:
        return [str(error)]
    rows = parse_tables(doc_text)
    problems = [] if rows else ["%s: no wiring table (a table with the columns %s)" % (doc, ", ".join(COLUMNS))]
    seen_ports, seen_pins, seen_names = {}, {}, {}
    for line, pmod_pin, name, pin, port, pullup in rows:
        where = "%s:%d: " % (doc, line)
        named = PMOD_NAME.match(name)
        if named:
            if named.group(1) != pmod_pin:
                problems.append(where + "%s is PMOD pin %s, not %s" % (name, named.group(1), pmod_pin))
            if name in seen_names:
                problems.append(where + "%s has a row already (line %d)" % (name, seen_names[name]))
            seen_names[name] = line
        if port is None:
            if pin is not None:
                problems.append(where + "FPGA pin %d without a port" % pin)
            continue
        if pin is None:
            problems.append(where + "`%s` without an FPGA pin" % port)
            continue
        if port in seen_ports:
            problems.append(where + "`%s` has a row already (line %d)" % (port, seen_ports[port]))
        if pin in seen_pins:
            problems.append(where + "FPGA pin %d has a row already (line %d)" % (pin, seen_pins[pin]))
        seen_ports[port], seen_pins[pin] = line, line
        if port not in pcf:
            problems.append(where + "`%s` is not in icebreaker.pcf" % port)
            continue
        pcf_pin, pcf_pullup, pcf_line = pcf[port]
        if pcf_pin != pin:
            problems.append(where + "`%s` on FPGA pin %d, but icebreaker.pcf:%d puts it on %d" % (port, pin, pcf_line, pcf_pin))
        if pullup not in ("yes", "no"):
            problems.append(where + "`%s`: FPGA pull-up '%s' is neither yes nor no" % (port, pullup))
        elif (pullup == "yes") != pcf_pullup:
            problems.append(where + "`%s`: FPGA pull-up %s, but icebreaker.pcf:%d has %s" %
                            (port, pullup, pcf_line, "-pullup yes" if pcf_pullup else "no pull-up"))
    for port, (pin, _, pcf_line) in sorted(pcf.items(), key=lambda item: item[1][2]):
        if port not in seen_ports:
            problems.append("%s: icebreaker.pcf:%d places `%s` on pin %d, which no wiring table shows" % (doc, pcf_line, port, pin))
    return problems


def described_pcf(doc_text):
    """The pcf the wiring tables describe."""
    return "".join("set_io -nowarn %s%s %d\n" % ("-pullup yes " if pullup == "yes" else "", port, pin)
                   for _, _, _, pin, port, pullup in parse_tables(doc_text) if port is not None and pin is not None)


def mutations(doc_text):
    """(what, pcf text) for every one-way change of the described pcf."""
    pcf = parse_pcf(described_pcf(doc_text))
    used = {pin for pin, _, _ in pcf.values()}
    spare = next(p for p in range(1, 100) if p not in used)

    def write(table):
        return "".join("set_io -nowarn %s%s %d\n" % ("-pullup yes " if up else "", port, pin)
                       for port, (pin, up) in table.items())

    base = {port: (pin, up) for port, (pin, up, _) in pcf.items()}
    for port, (pin, up) in base.items():
        yield "%s moved to pin %d" % (port, spare), write({**base, port: (spare, up)})
        yield "%s's pull-up flipped" % port, write({**base, port: (pin, not up)})
        yield "%s removed" % port, write({p: v for p, v in base.items() if p != port})
    yield "a port added", write({**base, "extra_port_i": (spare, False)})


def main():
    args = sys.argv[1:]
    if len(args) == 2 and args[0] == "--mutations":
        doc_text = open(args[1], encoding="utf-8").read()
        baseline = check(doc_text, described_pcf(doc_text), args[1])
        if baseline:
            print("\n".join(baseline))
            print("bench pins: the pcf the tables describe does not pass its own check")
            return 1
        missed = [what for what, text in mutations(doc_text) if not check(doc_text, text, args[1])]
        total = sum(1 for _ in mutations(doc_text))
        for what in missed:
            print("bench pins: a pcf with %s passes the check" % what)
        print("bench pins: %d changed pcfs, %d caught" % (total, total - len(missed)))
        return 1 if missed else 0
    if len(args) != 2 or args[0].startswith("-"):
        print("usage: check_bench_pins.py BENCH_MD PCF | check_bench_pins.py --mutations BENCH_MD", file=sys.stderr)
        return 2
    doc_text = open(args[0], encoding="utf-8").read()
    problems = check(doc_text, open(args[1], encoding="utf-8").read(), args[0])
    for problem in problems:
        print(problem)
    print("bench pins: %d wiring rows checked against %s, %d disagreements" %
          (sum(1 for row in parse_tables(doc_text) if row[4]), args[1], len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
