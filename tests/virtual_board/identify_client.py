#!/usr/bin/env python3
"""An independent client of `deltactl virtual-board`: pyserial and this file only, no project code.

Starts the virtual board on a pseudo-terminal with no model (`--no-model`), opens its path as a
serial port, sends an identify request built here from docs/board_link.md (sync 0x7E, length,
sequence, type 0x01, CRC-16/CCITT-FALSE high byte first over length..payload), and checks the reply
and the telemetry: protocol version 3, setpoint depth 256, the build id `deltactl quantise` prints,
weights CRC 0 and the model flag (telemetry flags bit 7) clear. Then `deltactl host load` loads the
weights, and the same client reads them back: the weights CRC quantise prints, the model flag set.
Then SIGTERM: the board must exit 0 and remove the path.

Usage: identify_client.py DELTACTL WEIGHTS WORK_DIR
"""
import os
import re
import signal
import struct
import subprocess
import sys
import time

import serial


def crc16_ccitt_false(data):
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def frame(sequence, frame_type, payload=b""):
    body = bytes([len(payload), sequence, frame_type]) + payload
    crc = crc16_ccitt_false(body)
    return bytes([0x7E]) + body + bytes([crc >> 8, crc & 0xFF])


PAYLOAD_BYTES = {0x81: 24, 0x82: 48}  # what a host takes


def read_frames(port, deadline):
    """Yields (sequence, type, payload) of every checked frame until the deadline."""
    buffer = bytearray()
    while time.monotonic() < deadline:
        buffer += port.read(256)
        while True:
            start = buffer.find(b"\x7e")
            if start < 0:
                buffer.clear()
                break
            del buffer[:start]
            if len(buffer) < 4:
                break
            length, sequence, frame_type = buffer[1], buffer[2], buffer[3]
            if PAYLOAD_BYTES.get(frame_type) != length:
                del buffer[:1]
                continue
            if len(buffer) < 4 + length + 2:
                break
            crc = (buffer[4 + length] << 8) | buffer[5 + length]
            if crc != crc16_ccitt_false(buffer[1:4 + length]):
                del buffer[:1]
                continue
            yield sequence, frame_type, bytes(buffer[4:4 + length])
            del buffer[:6 + length]


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def main():
    deltactl, weights, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    assert crc16_ccitt_false(b"123456789") == 0x29B1

    mem = os.path.join(work, "mem")
    os.makedirs(mem, exist_ok=True)
    quantise = subprocess.run([deltactl, "quantise", "--weights", weights, "--out-dir", mem],
                              capture_output=True, text=True, check=True)
    printed = quantise.stdout + quantise.stderr
    match = re.search(r"weights CRC-32 ([0-9a-f]{8}), gateware build id ([0-9a-f]{8})", printed)
    if not match:
        fail("deltactl quantise did not print the weights CRC and build id: " + printed)
    expected_crc, expected_build = int(match.group(1), 16), int(match.group(2), 16)

    link = os.path.join(work, "tty")
    board = subprocess.Popen([deltactl, "virtual-board", "--link", link, "--no-model"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ready = board.stdout.readline()
        if link not in ready:
            fail("no ready line naming the link; got %r, stderr %r" % (ready, board.stderr.read()))
        print("board: " + ready.strip())
        if not os.path.islink(link):
            fail(link + " is not a symbolic link")

        def identify_and_flags():
            port = serial.Serial(link, 1000000, timeout=0.05)
            port.reset_input_buffer()  # telemetry sent before we opened
            sequence = 0x5A
            port.write(frame(sequence, 0x01))
            reply, flags, telemetry = None, None, 0
            for got_sequence, frame_type, payload in read_frames(port, time.monotonic() + 30):
                if frame_type == 0x82:
                    telemetry += 1
                    flags = payload[33]  # TelemetryFlagsOffset
                elif frame_type == 0x81:
                    reply = (got_sequence, payload)
                if reply is not None and flags is not None:
                    break
            port.close()
            if reply is None or flags is None:
                fail("no identify reply and telemetry within 30 s")
            got_sequence, payload = reply
            fields = struct.unpack("<HHIIIIHH", payload)
            print("identify: protocol %d, depth %d, build id %08x, weights CRC %08x, clocks %d / %d Hz, rates %d / %d"
                  " Hz; telemetry flags %02x (%d frames)" % (fields + (flags, telemetry)))
            if got_sequence != sequence:
                fail("reply sequence %d, request %d" % (got_sequence, sequence))
            return fields, flags

        def check(fields, flags, crc, model):
            (protocol, depth, build_id, weights_crc, network_hz, board_hz, control_hz, setpoint_hz) = fields
            checks = [(protocol == 3, "protocol version %d" % protocol),
                      (depth == 256, "setpoint depth %d" % depth),
                      (build_id == expected_build, "build id %08x, quantise says %08x" % (build_id, expected_build)),
                      (weights_crc == crc, "weights CRC %08x, expected %08x" % (weights_crc, crc)),
                      (bool(flags & 0x80) == model, "model flag (bit 7) %s" % ("clear" if model else "set")),
                      ((network_hz, board_hz, control_hz, setpoint_hz) == (46500000, 23250000, 10000, 1000),
                       "clocks and rates")]
            for ok, what in checks:
                if not ok:
                    fail(what)

        fields, flags = identify_and_flags()
        check(fields, flags, 0, False)  # no model
        load = subprocess.run([deltactl, "host", "load", "--port", link, "--weights", weights],
                              capture_output=True, text=True)
        print(load.stdout.strip())
        if load.returncode != 0:
            fail("host load exit %d: %s" % (load.returncode, load.stderr))
        fields, flags = identify_and_flags()
        check(fields, flags, expected_crc, True)
    finally:
        if board.poll() is None:
            board.send_signal(signal.SIGTERM)
        try:
            code = board.wait(timeout=30)
        except subprocess.TimeoutExpired:
            board.kill()
            fail("the virtual board did not stop on SIGTERM")
    if code != 0:
        fail("virtual board exit code %d: %s" % (code, board.stderr.read()))
    if os.path.lexists(link):
        fail(link + " still exists after SIGTERM")
    print("PASS")


if __name__ == "__main__":
    main()
