#!/usr/bin/env python3
"""Every `deltactl` command line the docs show names a command and options that exist: in README.md,
docs/*.md and every README.md of the tree, each `deltactl ...` in a fenced block or in inline code
(its `\\` continuations joined, up to a `|`, `;`, `&`, `)` or `#`) is read as `deltactl COMMAND
[SUBCOMMAND ...] [ARGUMENTS]`: each command word must be one the `Subcommands:` of the `--help` above
it lists (or one of the choices `{a,b,...}` of its first positional), and each `--option` must be in
the `--help` of the command it belongs to. Each `scripts/NAME` command line names a script of the
tree and options the script's text reads. A paragraph or bullet that says "Not in this version yet"
(a contract still to come, docs/contracts.md) is left out. Usage: check_doc_commands.py DELTACTL
SOURCE_DIR. Prints each unknown command or option as FILE:LINE: reason; exit 1 when there is one."""
import os
import re
import subprocess
import sys

NOT_YET = "Not in this version yet"
FENCE = re.compile(r"^\s{0,3}(```|~~~)")


class Help:
    def __init__(self, deltactl):
        self.deltactl, self.cache = deltactl, {}

    def text(self, words):
        key = tuple(words)
        if key not in self.cache:
            result = subprocess.run([self.deltactl, *words, "--help"], capture_output=True, text=True, timeout=30)
            self.cache[key] = result.stdout if result.returncode == 0 else None
        return self.cache[key]

    def subcommands(self, words):
        text = self.text(words) or ""
        names, inside = set(), False
        for line in text.splitlines():
            if line.startswith("Subcommands:"):
                inside = True
            elif inside and re.match(r"^  \S", line):
                names.add(line.split()[0])
            elif inside and line.strip() and not line.startswith(" "):
                inside = False
        choices = re.search(r"^Positionals:\n\s+\S+\s+\S*:\{([^}]*)\}", text, re.MULTILINE)
        return names, set(choices.group(1).split(",")) if choices else set()

    def options(self, words):
        return set(re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", self.text(words) or ""))


def snippets(path):
    """(line number, text after `deltactl`) of every deltactl command line in code, outside NOT_YET blocks."""
    text = open(path, encoding="utf-8").read()
    lines = text.splitlines()
    # Blocks: runs of non-blank lines outside fences; a block saying NOT_YET is skipped whole.
    skipped, block, inside = set(), [], False
    for number, line in enumerate(lines, 1):
        if FENCE.match(line):
            inside = not inside
        if inside or FENCE.match(line) or line.strip():
            block.append(number)
        if not inside and not line.strip() or number == len(lines):
            if any(NOT_YET in lines[n - 1] for n in block):
                skipped.update(block)
            block = []
    found, inside, pending = [], False, None
    for number, line in enumerate(lines, 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if number in skipped:
            continue
        pieces = [line] if inside else re.findall(r"`([^`]*)`", line)
        if inside and pending is not None:
            pieces = [pending[1] + " " + line.strip()]
            start = pending[0]
            pending = None
        else:
            start = number
        for piece in pieces:
            if inside and piece.rstrip().endswith("\\"):
                pending = (start, piece.rstrip()[:-1])
                continue
            for match in re.finditer(r"(?:^|[\s(/])deltactl((?:\s+[^\s|;&)#]+)*)", piece):
                found.append((start, match.group(1)))
            for match in re.finditer(r"(?:^|[\s(])((?:bash |python3 )?scripts/[\w/]+\.(?:sh|py))((?:\s+[^\s|;&)#]+)*)", piece):
                found.append((start, match.group(1).split()[-1] + " " + match.group(2)))
    return found


def check_script(root, words):
    """The reasons `scripts/NAME --option ...` names an option the script does not read, or []."""
    path = os.path.join(root, words[0])
    if not os.path.isfile(path):
        return ["%s is not in the tree" % words[0]]
    text = open(path, encoding="utf-8").read()
    if '"$@"' in text and "case" not in text:  # hands its arguments on (build.sh to cmake --build)
        return []
    return ["%s has no option %s" % (words[0], option.group(1)) for option in
            (re.match(r"^(--[a-z][a-z0-9-]*)", w) for w in words[1:]) if option and option.group(1) not in text]


def check(help_, words):
    """The reasons the words after `deltactl` do not name a command and its options, or []."""
    command, reasons = [], []
    rest = list(words)
    while rest and not rest[0].startswith("-"):
        names, choices = help_.subcommands(command)
        if rest[0] in names:
            command.append(rest.pop(0))
        elif choices:
            if rest[0] not in choices:
                reasons.append("`%s` has no command '%s' (it takes %s)" %
                               (" ".join(["deltactl"] + command), rest[0], ", ".join(sorted(choices))))
            rest.pop(0)
            break
        elif not command or names:
            if names and re.match(r"^[a-z][a-z0-9-]*$", rest[0]):
                reasons.append("`%s` has no command '%s'" % (" ".join(["deltactl"] + command), rest[0]))
            break
        else:
            break
    if not command or reasons:
        return reasons
    known = help_.options(command)
    for word in rest:
        option = re.match(r"^(--[a-z][a-z0-9-]*)", word)
        if option and option.group(1) not in known:
            reasons.append("`deltactl %s` has no option %s" % (" ".join(command), option.group(1)))
    return reasons


def main():
    if len(sys.argv) != 3:
        print("usage: check_doc_commands.py DELTACTL SOURCE_DIR", file=sys.stderr)
        return 2
    deltactl, root = sys.argv[1], os.path.realpath(sys.argv[2])
    files = [os.path.join(root, "README.md")]
    files += sorted(os.path.join(root, "docs", f) for f in os.listdir(os.path.join(root, "docs")) if f.endswith(".md"))
    for folder, subfolders, names in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders if not d.startswith(".") and not d.startswith("build"))
        if folder != root and "README.md" in names:
            files.append(os.path.join(folder, "README.md"))
    help_ = Help(deltactl)
    broken, count = [], 0
    for path in sorted(set(files)):
        for number, text in snippets(path):
            words = text.split()
            if words and words[0] == "deltactl":  # `sudo -u deltactl deltactl ...`: the user, then the command
                words.pop(0)
            if not words:
                continue
            count += 1
            reasons = check_script(root, words) if words[0].startswith("scripts/") else check(help_, words)
            broken += ["%s:%d: %s" % (os.path.relpath(path, root), number, r) for r in reasons]
    for line in broken:
        print(line)
    print("doc commands: %d deltactl and scripts/ command lines, %d unknown commands or options" % (count, len(broken)))
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
