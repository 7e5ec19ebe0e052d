#!/usr/bin/env python3
"""`deltactl plot` on every kind of recording the project writes: `simulate` (the SPEC recording a
merge also writes), `cosim --out`, and against a model virtual board `host run --record`, the
board's `--truth` and `host record` (when the command exists; else a telemetry file of its
columns); each gives a real PNG of the width and the height its panels ask for, with the
series' colours drawn. A run shows no feed hold it was not asked for (its primed start and final
stop hold the board), a run the host ended with a fault is banded "end: fault", a drag (drives
off) has no tracking or current panel. Bad input: exit 2, one line naming the file (and the
line), no PNG.
Usage: plot_test.py DELTACTL WEIGHTS OUT_DIR (the PNGs stay there as artefacts)"""
import os
import re
import struct
import subprocess
import sys
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dashboard_bench import Failure, check  # noqa: E402

SERIES_COLOURS = [(0x1f, 0x77, 0xb4), (0xd6, 0x27, 0x28), (0x2c, 0xa0, 0x2c)]


def read_png(path):
    """(width, height, rows of RGB tuples) of an 8-bit RGB or RGBA PNG."""
    data = open(path, "rb").read()
    check(data[:8] == b"\x89PNG\r\n\x1a\n", path + " starts with the PNG signature")
    position, idat, width = 8, b"", None
    while position < len(data):
        length, kind = struct.unpack(">I4s", data[position:position + 8])
        body = data[position + 8:position + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            check(depth == 8 and colour in (2, 6), "%s: 8-bit RGB(A) (depth %d, colour type %d)" % (path, depth, colour))
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        position += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous, offset = [], bytearray(stride), 0
    for _ in range(height):
        kind, line = raw[offset], bytearray(raw[offset + 1:offset + 1 + stride])
        offset += 1 + stride
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = previous[i]
            c = previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        previous = line
    return width, height, rows, channels


def check_png(path, panels):
    width, height, rows, channels = read_png(path)
    check(width == 1200 and height == 300 * panels + 60,
          "%s: %dx%d pixels for %d panels (1200x%d)" % (os.path.basename(path), width, height, panels,
                                                        300 * panels + 60))
    colours, drawn, total = set(), 0, 0
    for line in rows[::2]:
        for i in range(0, len(line), channels * 2):
            pixel = tuple(line[i:i + 3])
            total += 1
            if pixel != (255, 255, 255):
                drawn += 1
            colours.add(pixel)
    check(drawn > total * 0.03, "%s: %.1f %% of the pixels drawn" % (os.path.basename(path), 100.0 * drawn / total))
    found = [c for c in SERIES_COLOURS if c in colours]
    check(len(found) >= 1, "%s: the joints' colours drawn (%d of 3)" % (os.path.basename(path), len(found)))


def plot(deltactl, csv, png):
    result = subprocess.run([deltactl, "plot", csv, "--out", png], capture_output=True, text=True, timeout=120)
    return result


def plot_ok(deltactl, csv, png, expect_kind, expect_panels, absent_panels=(), expect_bands=(), absent_bands=()):
    result = plot(deltactl, csv, png)
    check(result.returncode == 0, "deltactl plot %s: exit 0 (%d: %s)" % (os.path.basename(csv), result.returncode,
                                                                       result.stderr.strip()))
    check(expect_kind in result.stdout, "%s is told a %s (%s)" % (os.path.basename(csv), expect_kind,
                                                                  result.stdout.strip()))
    panel_text = result.stdout.split("panels:")[1]
    panels = panel_text.count(",") + 1
    bands = result.stdout.split("bands:")[1].split(";")[0] if "bands:" in result.stdout else ""
    for name in expect_panels:
        check(name in panel_text, "%s: panel '%s'" % (os.path.basename(csv), name))
    for name in absent_panels:
        check(name not in panel_text, "%s: no panel '%s' (%s)" % (os.path.basename(csv), name, panel_text.strip()))
    for name in expect_bands:
        check(name in bands, "%s: band '%s' (bands: %s)" % (os.path.basename(csv), name, bands.strip()))
    for name in absent_bands:
        check(name not in bands, "%s: no band '%s' (bands: %s)" % (os.path.basename(csv), name, bands.strip()))
    check_png(png, panels)


def plot_bad(deltactl, out, name, text, reason, line=None):
    csv = os.path.join(out, name + ".csv")
    png = os.path.join(out, name + ".png")
    if text is not None:
        with open(csv, "w") as f:
            f.write(text)
    result = plot(deltactl, csv, png)
    message = result.stderr.strip()
    where = csv + (":%d" % line if line else "")
    check(result.returncode == 2 and message.count("\n") == 0 and where in message and reason in message,
          "bad input (%s): exit 2, one line '%s' (%d: %s)" % (name, where, result.returncode, message))
    check(not os.path.exists(png), "bad input (%s): no PNG" % name)


def main():
    deltactl, weights, out = sys.argv[1], sys.argv[2], sys.argv[3]
    os.makedirs(out, exist_ok=True)
    for name in os.listdir(out):
        if name.endswith(".png") or name.endswith(".csv"):
            os.remove(os.path.join(out, name))
    try:
        # ---- recordings without a board ----
        sim = os.path.join(out, "simulate.csv")
        subprocess.run([deltactl, "simulate", "--experiment", "experiment1", "--out", sim], check=True,
                       capture_output=True, timeout=120)
        plot_ok(deltactl, sim, os.path.join(out, "simulate.png"), "recording (simulate, merge)",
                ["Joint angles", "Plate position (measured)"])
        cosim = os.path.join(out, "cosim.csv")
        subprocess.run([deltactl, "cosim", "--weights", weights, "--trajectory", "experiment1", "--duration", "1",
                        "--fidelity", "model", "--out", cosim], check=True, capture_output=True, timeout=300)
        plot_ok(deltactl, cosim, os.path.join(out, "cosim.png"), "co-simulation samples",
                ["Joint angles", "Tracking error", "Drive currents", "Plate position against its reference",
                 "Plate error"])

        # ---- against a model virtual board: host run, truth, host record ----
        link, truth = os.path.join(out, "tty"), os.path.join(out, "truth.csv")
        board = subprocess.Popen([deltactl, "virtual-board", "--link", link, "--weights", weights, "--truth", truth,
                                  "--fidelity", "model"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                 text=True)
        try:
            check(link in board.stdout.readline(), "the virtual board is ready")
            subprocess.run([deltactl, "host", "home", "--port", link, "--weights", weights, "--link-timeout-ms", "2000"],
                           check=True,
                           capture_output=True, timeout=60)
            run = os.path.join(out, "host_run.csv")
            subprocess.run([deltactl, "host", "run", "--port", link, "--weights", weights, "--trajectory",
                            "experiment1", "--duration", "3", "--record", run, "--link-timeout-ms", "1000"],
                           check=True, capture_output=True, timeout=120)
            # A run the host ends with a fault (a following-error bound no joint can keep): its
            # recording must not look like a normal end.
            faulted = os.path.join(out, "host_run_fault.csv")
            result = subprocess.run([deltactl, "host", "run", "--port", link, "--weights", weights, "--trajectory",
                                     "experiment1", "--duration", "3", "--record", faulted, "--link-timeout-ms",
                                     "1000", "--following-error-deg", "0.0001"], capture_output=True, text=True,
                                    timeout=120)
            check(result.returncode == 3, "a run beyond its following-error bound: exit 3 (%d: %s)" %
                  (result.returncode, result.stderr.strip()[-200:]))
            record = os.path.join(out, "host_record.csv")
            listed = subprocess.run([deltactl, "host", "--help"], capture_output=True, text=True).stdout
            has_record = re.search(r"^\s+record\s", listed, re.M) is not None
            if has_record:
                subprocess.run([deltactl, "host", "record", "--port", link, "--out", record, "--duration", "1"],
                               check=True, capture_output=True, timeout=60)
        finally:
            board.terminate()
            board.wait(30)
        # Primed start and final stop hold the board: no feed hold was asked, none is drawn.
        plot_ok(deltactl, run, os.path.join(out, "host_run.png"), "host run recording",
                ["Joint angles", "Tracking error", "Drive currents", "Plate reference"],
                expect_bands=["drives off"], absent_bands=["feed hold", "end:"])
        plot_ok(deltactl, faulted, os.path.join(out, "host_run_fault.png"), "host run recording",
                ["Joint angles", "Tracking error"], expect_bands=["end: fault"], absent_bands=["feed hold"])
        plot_ok(deltactl, truth, os.path.join(out, "truth.png"), "virtual-board truth",
                ["Joint angles", "Encoder error", "Drive currents", "Plate position (measured)"])
        if not has_record:  # the columns `host record` writes at least (SPEC), with the telemetry's status
            with open(run) as source, open(record, "w") as target:
                lines = [l for l in source.read().splitlines() if not l.startswith("#")]
                names = lines[0].split(",")
                keep = [names.index(n) for n in ["t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg", "fault_bits",
                                                 "flags", "drives_enabled"]]
                for l in lines:
                    fields = l.split(",")
                    target.write(",".join(fields[k] for k in keep) + "\n")
        # The drives off throughout (a drag's recording): no tracking, no currents.
        plot_ok(deltactl, record, os.path.join(out, "host_record.png"), "telemetry recording (host record)",
                ["Joint angles"], absent_panels=["Tracking error", "Drive currents"])

        # ---- bad input ----
        plot_bad(deltactl, out, "missing", None, "")
        plot_bad(deltactl, out, "empty", "", "")
        plot_bad(deltactl, out, "no_time", "alpha1_deg,alpha2_deg\n1,2\n", "t_s")
        plot_bad(deltactl, out, "not_a_number", "t_s,alpha1_deg\n0,1\n0.001,abc\n", "", line=3)
        plot_bad(deltactl, out, "backwards", "t_s,alpha1_deg\n0,1\n0.002,1\n0.001,1\n", "backwards", line=4)
        plot_bad(deltactl, out, "only_time", "t_s\n0\n0.001\n", "no column to plot")
        result = subprocess.run([deltactl, "plot", sim, "--out", os.path.join(out, "no_such_folder", "x.png")],
                                capture_output=True, text=True)
        check(result.returncode == 2 and "no_such_folder" in result.stderr, "an output folder that is missing: exit 2")
    except Failure:
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
