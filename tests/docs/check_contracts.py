#!/usr/bin/env python3
"""docs/contracts.md holds every contract of the project's contract list (SPEC.md), section by section,
so the copy in the repository cannot drift from it: each `## ` section of SPEC.md (its title without
a trailing "(added with ...)") is a section of docs/contracts.md, and each of its items (a bullet
with its continuation lines, a paragraph, a table row, a line of a code block) is in that section,
word for word (line breaks and runs of spaces aside). The text before SPEC.md's first section (how
the list is kept) is not a contract. Usage: check_contracts.py CONTRACTS_MD SPEC_MD. Exit 77 (the test
skipped) when SPEC_MD is absent (a clone without ../shared beside it); 1 naming each missing
section or item with its SPEC.md line; 0 otherwise."""
import os
import re
import sys

SECTION = re.compile(r"^## (.*?)(?: \(added with [^)]*\))?\s*$")


def sections(lines):
    """[(title, [(line number, line)])] for each `## ` section, in order."""
    found = []
    for number, line in enumerate(lines, 1):
        match = SECTION.match(line)
        if match:
            found.append((match.group(1).strip(), []))
        elif found:
            found[-1][1].append((number, line))
    return found


def items(numbered_lines):
    """[(first line number, text)]: bullets with their continuation lines, paragraphs, table rows and
    each line of a fenced block, as separate items."""
    result, current, fenced = [], None, False

    def close():
        nonlocal current
        if current:
            result.append((current[0], " ".join(current[1])))
        current = None

    for number, line in numbered_lines:
        stripped = line.strip()
        if stripped.startswith("```"):
            close()
            result.append((number, stripped))
            fenced = not fenced
            continue
        if fenced:
            if stripped:
                result.append((number, stripped))
            continue
        if not stripped:
            close()
        elif stripped.startswith("|") or stripped.startswith("#"):
            close()
            result.append((number, stripped))
        elif re.match(r"^[-*] ", stripped) or current is None:
            close()
            current = (number, [stripped])
        else:
            current[1].append(stripped)
    close()
    return result


def normalised(text):
    return re.sub(r"\s+", " ", text).strip()


def main():
    if len(sys.argv) != 3:
        print("usage: check_contracts.py CONTRACTS_MD SPEC_MD", file=sys.stderr)
        return 2
    contracts_path, spec_path = sys.argv[1], sys.argv[2]
    if not os.path.isfile(spec_path):
        print("contracts: %s is absent (no contract list beside this clone): skipped" % spec_path)
        return 77
    with open(spec_path, encoding="utf-8") as f:
        spec = sections(f.read().splitlines())
    with open(contracts_path, encoding="utf-8") as f:
        ours = {title: normalised(" ".join(line for _, line in body))
                for title, body in sections(f.read().splitlines())}
    missing, checked = [], 0
    for title, body in spec:
        if title not in ours:
            missing.append("%s: no section '## %s' (SPEC.md line %d)" % (contracts_path, title, body[0][0] - 1))
            continue
        for number, text in items(body):
            checked += 1
            if normalised(text) not in ours[title]:
                missing.append("%s: section '%s' lacks SPEC.md line %d: %s" %
                               (contracts_path, title, number, text[:100] + ("..." if len(text) > 100 else "")))
    for line in missing:
        print(line)
    print("contracts: %d sections, %d items of %s checked, %d missing" % (len(spec), checked, spec_path, len(missing)))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
