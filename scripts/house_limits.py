#!/usr/bin/env python3
"""The house's size limits, checked on the tree (the CTest Layout.HouseLimits runs it).

  functions   no C++ function or lambda at namespace or class scope in host/ and sim/ longer than
              120 lines (from the line of its opening brace to the line of its closing one); a table
              of data is excepted where the line before its opening line says `// house: table`
  rtl columns no line of rtl/**/*.sv(h) longer than 100 columns (lowRISC's style guide)
  test names  no GoogleTest suite or test named by a number (Defect01, Case3, Issue12, ...)
  test areas  tests/README.md names every tests/<area>.cmake

A limit the tree does not meet yet is held by tests/layout/house_limits_known.txt: each line
`functions|rtl-columns PATH[:NAME] N` allows that function N lines, or that file N lines over 100
columns, and no more; a line the tree has outgrown (now within the limit, or smaller than N) is
itself an error, so the list only shrinks. Anything new over a limit is an error.

Usage: scripts/house_limits.py [ROOT]   (exit 0: within the limits; 1: each problem on a line)
       scripts/house_limits.py --list [ROOT]   (every function over the limit and RTL file over the
       column limit, as lines for the known list)
"""

import pathlib
import re
import sys

FUNCTION_LINES = 120
RTL_COLUMNS = 100
KNOWN = "tests/layout/house_limits_known.txt"
NUMBER_NAME = re.compile(r"^(Defect|Case|Issue|Bug|Review|Test|Regression)\d+", re.IGNORECASE)


def strip_code(text):
    """The text with comments, string and character literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == '_')):
            k = text.find("(", i + 2)
            delim = text[i + 2:k]
            j = text.find(")" + delim + '"', k)
            j = n if j < 0 else j + len(delim) + 2
            out.append('"' + re.sub(r"[^\n]", " ", text[i + 1:j - 1]) + '"')
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator: 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else text[i:j])
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path):
    """(name, first line, lines, excepted as a table) of every function body at namespace or class
    scope in a C++ file."""
    raw = path.read_text(encoding="utf-8", errors="replace")
    code = strip_code(raw)
    raw_lines = raw.split("\n")
    # Per open brace: its kind ('scope': namespace, class, extern; 'function'; 'init': a member's
    # brace initialiser; 'block'), its function's name, its line and the line its statement starts on.
    opened = []
    start = 0  # where the current statement's text begins
    line = 1
    found = []
    for i, c in enumerate(code):
        if c == "\n":
            line += 1
        elif c == ";":
            start = i + 1
        elif c == "{":
            head = code[start:i]
            head_flat = " ".join(head.split())
            in_scope = all(entry[0] == "scope" for entry in opened)
            if re.search(r"\b(namespace|class|struct|union|enum)\b[^()=]*$", head_flat) or re.search(
                    r'\bextern\s+"', head_flat):
                kind, name = "scope", ""
            elif in_scope and ")" in head_flat and not re.search(r"=\s*$", head_flat):
                kind = "function"
                parts = re.split(r"\)\s*(?:noexcept\s*)?:(?!:)", head_flat, maxsplit=1)
                signature = parts[0] + ")" if len(parts) > 1 else head_flat
                m = re.search(r"([~\w:<>]+)\s*\((?:[^()]|\([^()]*\))*\)[^()]*$", signature)
                name = m.group(1) if m else head_flat[-40:]
                if re.search(r"\[[^\]]*\]\s*\(", head_flat):  # a lambda at namespace scope: its variable's name
                    m = re.search(r"(\w+)\s*[(={]", head_flat)
                    name = m.group(1) if m else name
            else:
                kind, name = "block", ""
            if kind == "function" and re.search(r"\)\s*(?:noexcept\s*)?:[^:]", head_flat) and re.search(r"\w\s*$", head_flat):
                kind = "init"  # a member's brace initialiser in a constructor's initialiser list
            p = start + (len(head) - len(head.lstrip()))
            head_line = line - code[p:i].count("\n")
            opened.append((kind, name, line, head_line))
            if kind != "init":
                start = i + 1
        elif c == "}":
            if opened:
                kind, name, first, head_line = opened.pop()
                if kind == "function":
                    marker = raw_lines[head_line - 2].strip() if head_line >= 2 else ""
                    found.append((name, head_line, line - first + 1, marker.startswith("// house: table")))
                if kind == "init":
                    continue
            start = i + 1
    return found


def cpp_files(root):
    for folder in ("host", "sim"):
        for path in sorted((root / folder).rglob("*")):
            if path.suffix in (".cpp", ".hpp", ".cc", ".h") and path.is_file():
                yield path


def rtl_files(root):
    for path in sorted((root / "rtl").rglob("*")):
        if path.suffix in (".sv", ".svh") and path.is_file():
            yield path


def measure(root):
    """{('functions', 'path:name'): lines, ('rtl-columns', 'path'): count} over the limits, and the
    other problems."""
    over = {}
    problems = []
    for path in cpp_files(root):
        rel = path.relative_to(root).as_posix()
        for name, first, lines, table in functions(path):
            if lines > FUNCTION_LINES and not table:
                key = ("functions", f"{rel}:{name}")
                if lines > over.get(key, (0, 0))[0]:
                    over[key] = (lines, first)
    for path in rtl_files(root):
        rel = path.relative_to(root).as_posix()
        long_lines = [i + 1 for i, text in enumerate(path.read_text(encoding="utf-8").split("\n"))
                      if len(text) > RTL_COLUMNS]
        if long_lines:
            over[("rtl-columns", rel)] = (len(long_lines), long_lines[0])
    test_name = re.compile(r"\bTEST(?:_F|_P)?\(\s*(\w+)\s*,\s*(\w+)\s*\)")
    for path in sorted((root / "tests").rglob("*.cpp")):
        text = path.read_text(encoding="utf-8", errors="replace")
        for m in test_name.finditer(text):
            for part in m.groups():
                if NUMBER_NAME.match(part):
                    line = text.count("\n", 0, m.start()) + 1
                    problems.append(f"{path.relative_to(root)}:{line}: test {m.group(1)}.{m.group(2)}: "
                                    f"'{part}' is a number, not what the test checks: name it after the behaviour")
    readme = (root / "tests" / "README.md").read_text(encoding="utf-8")
    for area in sorted((root / "tests").glob("*.cmake")):
        if f"`{area.name}`" not in readme:
            problems.append(f"tests/README.md: the test area tests/{area.name} is not in its table: add a row "
                            f"saying what it checks")
    return over, problems


def read_known(root):
    known = {}
    path = root / KNOWN
    if not path.exists():
        return known, []
    problems = []
    for number, text in enumerate(path.read_text(encoding="utf-8").split("\n"), 1):
        text = text.strip()
        if not text or text.startswith("#"):
            continue
        fields = text.split()
        if len(fields) != 3 or fields[0] not in ("functions", "rtl-columns") or not fields[2].isdigit():
            problems.append(f"{KNOWN}:{number}: '{text}' is not 'functions|rtl-columns PATH[:NAME] N'")
            continue
        known[(fields[0], fields[1])] = (int(fields[2]), number)
    return known, problems


def main(argv):
    if "-h" in argv or "--help" in argv:
        print(__doc__.strip())
        return 0
    listing = "--list" in argv
    args = [a for a in argv if a != "--list"]
    root = pathlib.Path(args[0] if args else pathlib.Path(__file__).resolve().parent.parent).resolve()
    over, problems = measure(root)
    if listing:
        for (kind, where), (count, _) in sorted(over.items()):
            print(f"{kind} {where} {count}")
        return 0
    known, known_problems = read_known(root)
    problems += known_problems
    for (kind, where), (count, first) in sorted(over.items()):
        allowed = known.get((kind, where))
        path = where.split(":")[0]
        if kind == "functions":
            what = f"{path}:{first}: function {where.split(':', 1)[1]} is {count} lines (limit {FUNCTION_LINES})"
        else:
            what = f"{path}:{first}: {count} lines over {RTL_COLUMNS} columns"
        if allowed is None:
            problems.append(what + (": split it (or, for a table of data, say `// house: table` on the line before)"
                                    if kind == "functions" else ": break them"))
        elif count > allowed[0]:
            problems.append(what + f", more than the {allowed[0]} {KNOWN}:{allowed[1]} allows: do not grow it")
        elif count < allowed[0]:
            problems.append(what + f": {KNOWN}:{allowed[1]} still allows {allowed[0]}: lower it to {count}")
    for (kind, where), (count, number) in sorted(known.items()):
        if (kind, where) not in over:
            problems.append(f"{KNOWN}:{number}: {kind} {where} is within the limit now (or gone): remove the line")
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
