#!/usr/bin/env bash
# `deltactl host serve` under many control connections: starts serve with no board (the socket
# alone), makes N connections one after another (each asks status and reads the answer), then
# prints serve's RSS and thread count before and after. The acceptance: 50,000 connections, serve
# alive, RSS under 100 MB. Usage: scripts/serve_connections.sh [BUILD] [N]   (defaults: build 50000)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
count=${2:-50000}
work=$(mktemp -d)
trap 'kill "$serve" 2>/dev/null || true; rm -rf "$work"' EXIT
"$build/bin/deltactl" host serve --port "$work/no_board" --weights "$root/weights/paper_like.json" \
  --socket "$work/ctl.sock" --record-folder "$work/runs" 2>"$work/serve.err" &
serve=$!
for _ in $(seq 100); do [[ -S $work/ctl.sock ]] && break; sleep 0.1; done
rss() { awk '/^VmRSS/ {print $2}' "/proc/$serve/status"; }
threads() { awk '/^Threads/ {print $2}' "/proc/$serve/status"; }
echo "serve: RSS $(rss) kB, $(threads) threads; $count connections ..."
start=$(date +%s.%N)
python3 - "$work/ctl.sock" "$count" <<'PY'
import socket, sys
path, count = sys.argv[1], int(sys.argv[2])
answered = 0
for i in range(count):
    s = socket.socket(socket.AF_UNIX)
    s.connect(path)
    s.sendall(b'{"cmd":"status"}\n')
    data = b''
    while not data.endswith(b'\n'):
        chunk = s.recv(65536)
        if not chunk:
            break
        data += chunk
    s.close()
    answered += data.endswith(b'\n')
    if (i + 1) % 10000 == 0:
        print(f"  {i + 1} connections", file=sys.stderr)
print(f"answered {answered} of {count}")
sys.exit(0 if answered == count else 1)
PY
end=$(date +%s.%N)
echo "serve: RSS $(rss) kB, $(threads) threads after $count connections in $(echo "$end - $start" | bc) s"
kill -0 "$serve" && echo "serve alive"
