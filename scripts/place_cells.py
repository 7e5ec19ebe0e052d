#!/usr/bin/env python3
"""Sets nextpnr's BEL attribute on netlist cells from a placement file (scripts/fpga_flow.sh --place).

Usage: place_cells.py PLACE_FILE NETLIST.json TOP

PLACE_FILE: lines "TYPE PREFIX BEL..." ('#' comments): the cells of TYPE (SB_MAC16, ...) whose names
start with PREFIX take the BELs in the order of their names; the count of cells must equal the
count of BELs. The netlist is
rewritten in place only when every line holds; else one line on stderr naming the file, line and
reason, exit 1, the netlist untouched.
"""
import json
import sys


def fail(where, why):
    print(f"place_cells: {where}: {why}", file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) != 4:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        sys.exit(2)
    place_path, netlist_path, top = sys.argv[1:]
    with open(netlist_path) as f:
        netlist = json.load(f)
    if top not in netlist.get("modules", {}):
        fail(netlist_path, f"no module {top}")
    cells = netlist["modules"][top]["cells"]
    taken = {}
    with open(place_path) as f:
        for number, line in enumerate(f, 1):
            words = line.split("#", 1)[0].split()
            if not words:
                continue
            where = f"{place_path}:{number}"
            if len(words) < 3:
                fail(where, "expected TYPE PREFIX BEL...")
            kind, prefix, bels = words[0], words[1], words[2:]
            names = sorted(n for n, c in cells.items() if c["type"] == kind and n.startswith(prefix))
            if len(names) != len(bels):
                fail(where, f"{kind} '{prefix}' matches {len(names)} cells of the netlist, the line gives "
                            f"{len(bels)} BELs (the design changed: update the file)")
            for name, bel in zip(names, bels):
                if bel in taken:
                    fail(where, f"BEL {bel} given twice (also to {taken[bel]})")
                taken[bel] = name
                cells[name].setdefault("attributes", {})["BEL"] = bel
    with open(netlist_path, "w") as f:
        json.dump(netlist, f)
    for bel, name in sorted(taken.items()):
        print(f"place_cells: {bel} <- {name}", file=sys.stderr)


if __name__ == "__main__":
    main()
