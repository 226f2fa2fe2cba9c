"""The commands documented in README.md, bags/README.md and docs/*.md, read
from the files themselves so that commands added later are covered too.

A command is:

* every line of a fenced ```bash (or ```sh) block, without its trailing
  ``# comment``, with ``\\`` continuations joined;
* every line of an indented (4-space) code block, likewise;
* a fenced ```python block, run as one script;
* an inline code span whose first word is ``make``, ``ros2run``, ``source``
  or ``python`` (``make run`` mentioned five times is run once).

Each runs verbatim, in a bash shell that has sourced ``tools/env.sh`` (as the
README tells a user to), and must exit 0. A long command may name its short
form, and a command that cannot be run by a test (the suite itself) must say
why, with an HTML comment anywhere in the same file (invisible on GitHub)::

    <!-- readme-test: make run -> make run RUN_ARGS="--set duration_s=4" -->
    <!-- readme-test: make test -> skip: the test suite itself -->

The text left of ``->`` is the command exactly as documented.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

COMMAND_WORDS = ("make", "ros2run", "source", "python")
MARKER = re.compile(r"<!--\s*readme-test:\s*(.+?)\s*->\s*(.+?)\s*-->", re.S)


@dataclass(frozen=True)
class Command:
    source: str          # file it came from
    text: str            # the command as documented
    kind: str = "bash"   # "bash" or "python"
    run: str | None = None     # what is run (a short form), None = the text itself
    skip: str | None = None    # why it is not run


def _join_continuations(lines):
    out, cur = [], ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            cur += line.rstrip()[:-1].strip() + " "
        else:
            out.append((cur + line.strip()).strip())
            cur = ""
    if cur.strip():
        out.append(cur.strip())
    return out


def _strip_comment(line: str) -> str:
    return re.sub(r"\s+#.*$", "", line).strip() if not line.lstrip().startswith("#") else ""


def _normalise(text: str) -> str:
    return " ".join(text.split())


def commands(path) -> list[Command]:
    """The commands of one markdown file, markers applied, in order, unique."""
    text = open(path, encoding="utf-8").read()
    markers = {_normalise(a): b.strip() for a, b in MARKER.findall(text)}
    found: list[tuple[str, str]] = []
    prose: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        fence = re.match(r"^\s*```(\w*)", line)
        if fence:
            lang, body = fence.group(1), []
            i += 1
            while i < len(lines) and not re.match(r"^\s*```", lines[i]):
                body.append(lines[i])
                i += 1
            if lang in ("bash", "sh", "shell"):
                found += [("bash", c) for c in _join_continuations([_strip_comment(b) for b in body]) if c]
            elif lang == "python":
                found.append(("python", "\n".join(body)))
            prose.append("")
        elif line.startswith("    ") and line.strip() and (not prose or not prose[-1].strip()) \
                and not re.match(r"^\s*([*-]|\d+\.)\s", line):
            body = []
            while i < len(lines) and (lines[i].startswith("    ") or not lines[i].strip()):
                body.append(lines[i])
                i += 1
            found += [("bash", c) for c in _join_continuations([_strip_comment(b) for b in body]) if c]
            prose.append("")
            continue
        else:
            prose.append(line)
        i += 1
    # inline code spans in the prose (a span may wrap to the next line)
    for span in re.findall(r"`([^`]+)`", "\n".join(prose)):
        span = _normalise(span)
        if span.split(" ", 1)[0] in COMMAND_WORDS and " " in span:
            found.append(("bash", span))
    out, seen = [], set()
    for kind, cmd in found:
        key = _normalise(cmd)
        if key in seen:
            continue
        seen.add(key)
        action = markers.get(key)
        if action is None:
            out.append(Command(str(path), cmd, kind))
        elif action.startswith("skip:"):
            out.append(Command(str(path), cmd, kind, skip=action[len("skip:"):].strip()))
        else:
            out.append(Command(str(path), cmd, kind, run=action))
    unused = set(markers) - seen
    if unused:
        raise ValueError(f"{path}: readme-test markers for commands not in the file: {sorted(unused)}")
    return out
