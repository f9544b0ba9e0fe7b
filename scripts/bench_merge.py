#!/usr/bin/python3
"""Puts the sections `make bench` measured into BENCHMARKS.md, leaving everything else as it is.

Each benchmark script prints Markdown: one or more sections, each starting with a heading. In
BENCHMARKS.md every measured section sits between two markers,

    <!-- make bench: scripts/bench/camera.sh: Chessboard detection per frame -->
    ...the section as the script printed it...
    <!-- make bench: end -->

and only what lies between them is replaced. The text around them (the analysis of the figures,
runs made by hand) is kept. A section that has no block yet goes after the script's last block,
or, for a script with none, at the end of its topic (the "## " heading given for it; added at the
end of the file when missing). A block whose script no longer prints its heading is removed.

    /usr/bin/python3 scripts/bench_merge.py BENCHMARKS.md PARTS_DIR "Camera=camera.sh,..." ...

PARTS_DIR holds each script's output as NAME.md (camera.sh -> camera.md); a topic lists its
scripts in the order their blocks are placed. The header block "scripts/bench.sh: machine" is
PARTS_DIR/machine.md.
"""
import os
import re
import sys

END = "<!-- make bench: end -->"
BEGIN = re.compile(r"^<!-- make bench: (\S+?)(?:: (.+))? -->$")


class MarkerError(Exception):
    pass


def sections(output):
    """The script's output split at its headings: [(heading text, section text)]. Text before the
    first heading belongs to the first section; a script that prints no heading gives one section
    without a name ("")."""
    pieces = []
    for line in output.rstrip("\n").split("\n"):
        m = re.match(r"^#+ (.*)$", line)
        if m or not pieces:
            pieces.append([m.group(1).strip() if m else "", []])
        pieces[-1][1].append(line)
    return [(h, "\n".join(lines).strip("\n")) for h, lines in pieces]


def parse(doc):
    """The document as a list of items: plain lines (str) and blocks ((script, heading, text))."""
    items, block = [], None
    for n, line in enumerate(doc.split("\n"), 1):
        m = BEGIN.match(line)
        if line == END:
            if block is None:
                raise MarkerError(f"line {n}: a block ends that never began")
            items.append((block[0], block[1], "\n".join(block[2]).strip("\n")))
            block = None
        elif m:
            if block is not None:
                raise MarkerError(f"line {n}: a block begins inside the block of line {block[3]}")
            block = [m.group(1), m.group(2) or "", [], n]
        elif block is not None:
            block[2].append(line)
        else:
            items.append(line)
    if block is not None:
        raise MarkerError(f"line {block[3]}: the block never ends")
    return items


def render(items):
    out = []
    for item in items:
        if isinstance(item, str):
            out.append(item)
        else:
            name = item[0] + (": " + item[1] if item[1] else "")
            out += [f"<!-- make bench: {name} -->", "", item[2], "", END]
    return "\n".join(out)


def topic_end(items, topic):
    """The index after the last item of the "## topic" section, or None without that heading."""
    start = next((i for i, it in enumerate(items) if it == "## " + topic), None)
    if start is None:
        return None
    end = next((i for i in range(start + 1, len(items))
                if isinstance(items[i], str) and re.match(r"^#{1,2} ", items[i])), len(items))
    while end > start + 1 and items[end - 1] == "":
        end -= 1
    return end


def merge(doc, topics, outputs):
    """doc with each script's sections from outputs {script: output}; topics: [(topic, [script])].
    Scripts without output are left as they are."""
    items = parse(doc)
    for topic, scripts in topics:
        for script in scripts:
            if script not in outputs:
                continue
            new = sections(outputs[script])
            headings = [h for h, _ in new]
            # Blocks of headings the script no longer prints go, with the blank line after them.
            kept = []
            for it in items:
                if not isinstance(it, str) and it[0] == script and it[1] not in headings:
                    continue
                kept.append(it)
            items = kept
            for heading, text in new:
                at = next((i for i, it in enumerate(items)
                           if not isinstance(it, str) and it[:2] == (script, heading)), None)
                if at is not None:
                    items[at] = (script, heading, text)
                    continue
                last = [i for i, it in enumerate(items) if not isinstance(it, str) and it[0] == script]
                if last:
                    where = last[-1] + 1
                else:
                    before = scripts[:scripts.index(script)]
                    prior = [i for i, it in enumerate(items)
                             if not isinstance(it, str) and it[0] in before]
                    if prior:
                        where = prior[-1] + 1
                    elif not topic:  # the header: after the title
                        where = min(1, len(items))
                    else:
                        where = topic_end(items, topic)
                    if where is None:
                        items += ["", "## " + topic]
                        where = len(items)
                items[where:where] = ["", (script, heading, text)]
    return re.sub(r"\n{3,}", "\n\n", render(items)).strip("\n") + "\n"


def main(argv):
    if len(argv) < 3:
        sys.stderr.write(__doc__)
        return 2
    path, parts = argv[0], argv[1]
    topics = [("", ["scripts/bench.sh"])]
    for arg in argv[2:]:
        topic, _, names = arg.partition("=")
        topics.append((topic, ["scripts/bench/" + n for n in names.split(",") if n]))
    outputs = {}
    for _, scripts in topics:
        for script in scripts:
            name = "machine" if script == "scripts/bench.sh" else os.path.basename(script)[:-3]
            f = os.path.join(parts, name + ".md")
            if os.path.exists(f):
                with open(f) as fh:
                    outputs[script] = fh.read()
    with open(path) as fh:
        doc = fh.read()
    try:
        merged = merge(doc, topics, outputs)
    except MarkerError as e:
        sys.stderr.write(f"bench_merge: {path}: {e}\n")
        return 1
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(merged)
    os.replace(tmp, path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
