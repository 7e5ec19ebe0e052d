#!/usr/bin/env python3
"""Every link of the project's Markdown resolves inside the repository: in README.md, docs/ and every
other Markdown file of the tree (build folders and .git left out), each relative link or image
`[text](target)` and each reference definition `[name]: target` names a file or folder that exists,
and each `#anchor` (alone, or after a Markdown file) names a heading of that file by GitHub's rule
(the heading's text lower-cased, every character but letters, digits, `_`, `-` and spaces dropped,
spaces made `-`, a repeated slug numbered -1, -2, ...) or an explicit `<a name=...>`/`id=`. Links
inside code (fenced blocks, `inline code`) are text, not links; http(s) and mailto links are not
followed. A path of the tree named in the text (`docs/...`, `scripts/...`, `host/...`, from the
repository root or from the file's folder) names a file or folder that exists, unless it is a
pattern (followed by `*`, `<` or `{`). Usage: check_doc_links.py SOURCE_DIR. Prints each broken link as FILE:LINE: reason; exit 1
when there is one, else 0."""
import os
import re
import sys
import urllib.parse

SKIPPED_FOLDERS = {".git", "build", "node_modules", "__pycache__"}
INLINE_LINK = re.compile(r"!?\[((?:[^\[\]]|\[[^\]]*\])*)\]\(\s*<?([^)\s>]*)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE_DEFINITION = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
EXPLICIT_ANCHOR = re.compile(r"<a\s+(?:name|id)=\"([^\"]+)\"", re.IGNORECASE)
FENCE = re.compile(r"^\s{0,3}(```|~~~)")
TREE_PATH = re.compile(r"(?<![\w./~$-])((?:docs|scripts|tests|host|sim|rtl|hls|weights|cmake|\.ci)/[\w./-]*[\w])(?![\w*<{])")


def markdown_files(root):
    found = []
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders
                               if d not in SKIPPED_FOLDERS and not d.startswith("build") and not d.startswith("."))
        found += [os.path.join(folder, f) for f in sorted(files) if f.endswith(".md")]
    return found


def prose_lines(text):
    """(line number, line) outside fenced code blocks, with inline code spans blanked."""
    inside = False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if inside:
            continue
        yield number, re.sub(r"(`+)(.+?)\1", lambda m: " " * len(m.group(0)), line)


def github_slug(heading_text):
    """The anchor GitHub gives a heading (its rendered text: links as their text, no markup)."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading_text)  # links and images: their text
    text = re.sub(r"<[^>]+>", "", text)  # inline HTML
    text = text.lower()
    text = re.sub(r"[^\w\- ]", "", text)  # \w: letters, digits and _ in any script, as Ruby's \p{Word}
    return text.replace(" ", "-")


def anchors_of(path, cache):
    if path not in cache:
        slugs, counts = set(), {}
        with open(path, encoding="utf-8") as f:
            text = f.read()
        inside = False
        for line in text.splitlines():
            if FENCE.match(line):
                inside = not inside
                continue
            if inside:
                continue
            slugs.update(EXPLICIT_ANCHOR.findall(line))
            match = HEADING.match(line)
            if not match:
                continue
            slug = github_slug(match.group(2))
            n = counts.get(slug, 0)
            counts[slug] = n + 1
            slugs.add(slug if n == 0 else "%s-%d" % (slug, n))
        cache[path] = slugs
    return cache[path]


def check_target(root, source, target, anchors):
    """None when the target resolves, else the reason."""
    if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target):  # http:, https:, mailto: ...
        return None
    path_part, _, anchor = target.partition("#")
    path_part = urllib.parse.unquote(path_part)
    if path_part.startswith("/"):
        return "an absolute path (GitHub resolves it against the site, not the repository): %s" % target
    resolved = os.path.normpath(os.path.join(os.path.dirname(source), path_part)) if path_part else source
    if not (resolved == root or resolved.startswith(root + os.sep)):
        return "leaves the repository: %s" % target
    if not os.path.exists(resolved):
        return "no such file or folder: %s (%s)" % (target, os.path.relpath(resolved, root))
    if anchor:
        if not resolved.endswith(".md") or os.path.isdir(resolved):
            return "an anchor into a file that is not Markdown: %s" % target
        if urllib.parse.unquote(anchor) not in anchors_of(resolved, anchors):
            return "no heading with the anchor #%s in %s" % (anchor, os.path.relpath(resolved, root))
    return None


def check_tree_paths(root, source, text):
    """FILE:LINE: reason for each path of the tree named in the text (code included) that does not exist."""
    broken = []
    for number, line in enumerate(text.splitlines(), 1):
        for match in TREE_PATH.finditer(line):
            path = match.group(1).rstrip(".")
            if not any(os.path.exists(os.path.join(base, path)) for base in (root, os.path.dirname(source))):
                broken.append("%s:%d: names %s, which is not in the tree" % (os.path.relpath(source, root), number, path))
    return broken


def main():
    if len(sys.argv) != 2:
        print("usage: check_doc_links.py SOURCE_DIR", file=sys.stderr)
        return 2
    root = os.path.realpath(sys.argv[1])
    anchors, broken, links, files = {}, [], 0, markdown_files(root)
    for source in files:
        with open(source, encoding="utf-8") as f:
            text = f.read()
        for number, line in prose_lines(text):
            targets = [m.group(2) for m in INLINE_LINK.finditer(line)]
            definition = REFERENCE_DEFINITION.match(line)
            if definition:
                targets.append(definition.group(1))
            for target in targets:
                links += 1
                reason = check_target(root, source, target, anchors) if target else "an empty link"
                if reason:
                    broken.append("%s:%d: %s" % (os.path.relpath(source, root), number, reason))
        broken += check_tree_paths(root, source, text)
    for line in broken:
        print(line)
    print("doc links: %d links in %d Markdown files, %d broken" % (links, len(files), len(broken)))
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
