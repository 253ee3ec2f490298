"""Docs that cannot rot (issue 19): every relative link in README.md,
DEVELOPERS.md and docs/ resolves (files and #anchors); every ``roboray-*``
command line they show parses with the current command-line interfaces
(their real argparse parsers, nothing run), and every command they name in
prose or a usage line has the subcommands, options and choices named; the
repository files they name exist; the parameter reference is what its
generator writes from the parameter definitions now; and nothing in the
repository points outside it. Each checker is first shown to catch what it
is for on a made-up doc."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from roboray.tools import gen_param_docs

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted([ROOT / "README.md", ROOT / "DEVELOPERS.md"] + list((ROOT / "docs").rglob("*.md")))

#: The console scripts and the modules that build their parsers (pyproject.toml's [project.scripts]).
CLIS = {
    "roboray-sim": "roboray.sim.cli",
    "roboray-ground": "roboray.ground.cli",
    "roboray-flash": "roboray.tools.flash.cli",
}

_FENCE = re.compile(r"^\s*(```|~~~)")
_LINK = re.compile(r"!?\[(?:[^\]\\]|\\.)*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_REFERENCE = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)")
_HTML_LINK = re.compile(r"<(?:img|a|source)\b[^>]*?\s(?:src|href)=\"([^\"]+)\"", re.I)
_INLINE_CODE = re.compile(r"(`+)(.+?)\1")
_COMMAND = re.compile(r"^(?:\$\s+)?(?:\.venv/bin/)?(roboray-(?:sim|ground|flash))(?=\s|$)")
_MENTION = re.compile(r"^(roboray-(?:sim|ground|flash))\s+\S")


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def _prose_lines(path: Path):
    """``(line number, text)`` of the lines outside fenced code blocks."""
    fenced = False
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if _FENCE.match(line):
            fenced = not fenced
        elif not fenced:
            yield n, line


def _links(path: Path):
    for n, line in _prose_lines(path):
        line = _INLINE_CODE.sub("", line)
        for m in _LINK.finditer(line):
            yield n, m.group(1)
        for m in _HTML_LINK.finditer(line):
            yield n, m.group(1)
        m = _REFERENCE.match(line)
        if m:
            yield n, m.group(1)


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: markup dropped, lower case,
    punctuation other than hyphens and underscores removed, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)   # a link keeps its text
    text = re.sub(r"<[^>]+>", "", text).replace("`", "").replace("*", "")
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """The anchors a Markdown file has: its headings' (a repeated one gets
    ``-1``, ``-2``, ... as on GitHub) and explicit ``<a id=...>``/``name``."""
    found: set[str] = set()
    seen: dict[str, int] = {}
    fenced = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if _FENCE.match(line):
            fenced = not fenced
            continue
        if fenced:
            continue
        for m in re.finditer(r"<a\s+(?:id|name)=\"([^\"]+)\"", line):
            found.add(m.group(1))
        m = re.match(r"^\s{0,3}#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            base = github_anchor(m.group(1))
            k = seen.get(base, 0)
            seen[base] = k + 1
            found.add(base if k == 0 else "%s-%d" % (base, k))
    return found


def broken_links(path: Path) -> list[str]:
    problems = []
    for n, target in _links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):   # http:, https:, mailto:, ...
            continue
        file_part, _, fragment = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        where = "%s:%d: %s" % (_rel(path), n, target)
        if not dest.is_relative_to(ROOT):
            problems.append(where + " points outside the repository")
        elif not dest.exists():
            problems.append(where + " does not exist")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            problems.append(where + " has no heading #%s" % fragment)
    return problems


def _blocks(path: Path):
    """``(info string, [(line number, text), ...])`` of each fenced block."""
    block = None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if _FENCE.match(line):
            if block is None:
                block = (line.strip()[3:].strip(), [])
            else:
                yield block
                block = None
        elif block is not None:
            block[1].append((n, line))


def _shown(path: Path):
    """``(line number, kind, text)`` of every ``roboray-*`` command the file
    shows. kind "command": a whole command line: in a fenced block a line
    ``$ [.venv/bin/]roboray-...`` or ``.venv/bin/roboray-...``, and in a
    ``sh`` block without prompts (a script, not a session with output) a
    bare ``roboray-...`` line, continued over trailing backslashes; in prose
    an inline code span ``.venv/bin/roboray-...``. kind "synopsis": a
    command as prose names it (an inline span ``roboray-sim trim --wings
    ... [--json]``, ``roboray-ground --key``) or a block's usage line with
    ``[optional]`` parts, continued over the indented lines after it."""
    for n, line in _prose_lines(path):
        for m in _INLINE_CODE.finditer(line):
            text = m.group(2).strip()
            if text.startswith(".venv/bin/roboray-"):
                yield n, "command", text
            elif _MENTION.match(text):
                yield n, "synopsis", text
    for info, lines in _blocks(path):
        script = info in ("sh", "bash", "shell") and not any(t.lstrip().startswith("$ ") for _, t in lines)
        k = 0
        while k < len(lines):
            n, text = lines[k]
            indent = len(text) - len(text.lstrip())
            text = text.strip()
            k += 1
            if script and _MENTION.match(text) and "[" in text:
                while k < len(lines) and len(lines[k][1]) - len(lines[k][1].lstrip()) > indent:
                    text += " " + lines[k][1].strip()
                    k += 1
                yield n, "synopsis", text
                continue
            while text.endswith("\\") and k < len(lines):
                text = text[:-1] + " " + lines[k][1].strip()
                k += 1
            if text.startswith(("$ ", ".venv/bin/")) or (script and _MENTION.match(text)):
                yield n, "command", text


def command_lines(path: Path):
    """``(line number, script, argv)`` of each whole command line shown
    (``_shown``); shell syntax ends the command (``&``, ``;``, ``|``, a
    redirection, a comment)."""
    for n, kind, text in _shown(path):
        m = _COMMAND.match(text)
        if kind == "command" and m:
            yield n, m.group(1), _shell_words(text[m.end():])


def mentions(path: Path):
    """``(line number, text)`` of each command as prose or a usage line names it."""
    for n, kind, text in _shown(path):
        if kind == "synopsis":
            yield n, text


def _options(parser) -> dict:
    return dict(parser._option_string_actions)


def _subcommands(parser) -> dict:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices
    return {}


def synopsis_error(text: str) -> str:
    """What is wrong with a command as the prose names it, "" when nothing:
    its subcommands exist, each option it names is one of that command's
    (or of a command above it), and the choices it lists for an option with
    choices (``--interpreter micropython|cpython``) are the option's."""
    words = text.replace("[", " ").replace("]", " ").split()
    script, words = words[0], words[1:]
    parser = importlib.import_module(CLIS[script]).build_parser()
    known = _options(parser)
    prog = [script]
    k = 0
    while k < len(words) and words[k] in _subcommands(parser):
        parser = _subcommands(parser)[words[k]]
        known.update(_options(parser))
        prog.append(words[k])
        k += 1
    if k < len(words) and _subcommands(parser) and re.fullmatch(r"[a-z][a-z-]*", words[k]):
        return "%s has no command %r" % (" ".join(prog), words[k])
    for j in range(k, len(words)):
        word = words[j].split("=")[0].rstrip(",.")
        if not re.fullmatch(r"--?[A-Za-z][\w-]*", word):
            continue
        if word not in known:
            return "%s has no option %s" % (" ".join(prog), word)
        action = known[word]
        listed = words[j + 1].split("|") if j + 1 < len(words) and "|" in words[j + 1] else []
        if action.choices is not None and listed:
            wrong = [c for c in listed if c not in action.choices]
            if wrong:
                return "%s %s: no choice %s" % (" ".join(prog), word, ", ".join(wrong))
    return ""


def _shell_words(text: str) -> list[str]:
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    lexer.commenters = "#"
    words = []
    for word in lexer:
        if word and all(c in lexer.punctuation_chars for c in word):
            break
        words.append(word)
    return words


def parse_error(script: str, argv: list[str]) -> str:
    """What the script's argparse says about ``argv``, "" when it parses; nothing runs."""
    parser = importlib.import_module(CLIS[script]).build_parser()
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            parser.parse_args(argv)
    except SystemExit as e:
        if e.code not in (0, None):
            return err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else "exit %s" % e.code
    return ""


#: A path of this repository as the docs write one in code: ``sim/twin/board/``, ``tests/test_x.py``.
_REPO_PATH = re.compile(r"(?:shared|firmware|sim|ground|tools|tests|docs)/[\w./*-]*|[A-Z][A-Z_]*\.md")
#: ... unless it is another project's (``MicroPython's `tests/run-perfbench.py```).
_THEIRS = re.compile(r"\b(?!README\b|RoboRay\b)[A-Z][\w.-]*'s\s+$"
                     r"|\b(?i:pymavlink|mavproxy|micropython|ardupilot)'s\s+$")


def named_paths(path: Path):
    """``(line number, path)`` of the repository paths a doc names in code."""
    for n, line in _prose_lines(path):
        for m in _INLINE_CODE.finditer(line):
            name = m.group(2).strip().split("::")[0]
            if _REPO_PATH.fullmatch(name) and not _THEIRS.search(line[:m.start()]):
                yield n, name


def missing_paths(path: Path) -> list[str]:
    """The repository paths a doc names in code that are not there."""
    return ["%s:%d: %s is not in the repository" % (_rel(path), n, name) for n, name in named_paths(path)
            if not (any(ROOT.glob(name.rstrip("/"))) if "*" in name else (ROOT / name).exists())]


def pointers_outside(files: list[Path]) -> list[str]:
    """What in ``files`` points outside the repository: a symbolic link that
    leads out, the sibling ``shared`` folder of an old layout named
    relatively, a doc's relative path (linked or not) that climbs out."""
    sibling = ".." + "/shared"   # spelled apart so that this file does not match itself
    problems = []
    for path in files:
        if path.is_symlink():
            if not path.resolve().is_relative_to(ROOT):
                problems.append("%s is a link to %s" % (_rel(path), path.resolve()))
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, IsADirectoryError):
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if sibling in line:
                problems.append("%s:%d: %s" % (_rel(path), n, line.strip()))
            if path.suffix == ".md":
                for m in re.finditer(r"(?<![\w./])(?:\.\./)+[\w.-]*", line):
                    if not (path.parent / m.group(0)).resolve().is_relative_to(ROOT):
                        problems.append("%s:%d: %s points outside the repository" % (_rel(path), n, m.group(0)))
    return problems


def _repository_files() -> list[Path]:
    """The repository's files, tracked or new (not the ignored: .venv, build output)."""
    try:
        names = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                               cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    except (OSError, subprocess.CalledProcessError) as e:
        pytest.skip("not a git checkout (%s): cannot list the repository's files" % e)
    return [ROOT / name for name in names if name and (ROOT / name).exists()]


# ---------------------------------------------------------------- the checker itself


def test_github_anchors_are_made_as_github_makes_them():
    assert github_anchor("Identity, link") == "identity-link"
    assert github_anchor("`roboray-flash`") == "roboray-flash"
    assert github_anchor("Step 2: flash it (once)") == "step-2-flash-it-once"
    assert github_anchor("[Links](x.md) and *more*") == "links-and-more"


def test_broken_links_and_missing_anchors_are_found(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    (tmp_path / "b.md").write_text("# Real heading\n\n## Twice\n\n## Twice\n")
    a = tmp_path / "a.md"
    a.write_text("[ok](b.md#real-heading) [ok2](b.md#twice-1) [gone](c.md)\n"
                 "[no anchor](b.md#nope) [out](../x.md) `[code](c.md)` [web](https://example.com/c.md)\n"
                 "```\n[in a block](c.md)\n```\n[self](#top)\n# Top\n"
                 '<img src="b.md" width="40%"> <img src="fig.png">\n')
    problems = broken_links(a)
    assert problems == ["a.md:1: c.md does not exist", "a.md:2: b.md#nope has no heading #nope",
                        "a.md:2: ../x.md points outside the repository", "a.md:8: fig.png does not exist"]


def test_command_lines_are_found_and_a_wrong_one_is_reported(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("Run `.venv/bin/roboray-flash build --json` then:\n\n"
                   "  ```sh\n  $ .venv/bin/roboray-sim trim --wings 0,45,90,45 --json | head -1\n"
                   "  output line\n  .venv/bin/roboray-ground watch \\\n    --master /dev/pts/0 &  # the path\n"
                   "  $ .venv/bin/roboray-sim trim --no-such-option\n  ```\n")
    found = list(command_lines(doc))
    assert found == [(1, "roboray-flash", ["build", "--json"]),
                     (4, "roboray-sim", ["trim", "--wings", "0,45,90,45", "--json"]),
                     (6, "roboray-ground", ["watch", "--master", "/dev/pts/0"]),
                     (8, "roboray-sim", ["trim", "--no-such-option"])]
    assert [parse_error(script, argv) for _, script, argv in found[:3]] == ["", "", ""]
    assert "unrecognized arguments: --no-such-option" in parse_error(*found[3][1:])


def test_a_script_block_and_usage_lines_are_read_and_a_renamed_option_is_reported(tmp_path):
    doc = tmp_path / "d.md"
    doc.write_text("As `roboray-sim trim --wings ... [--json]` and `roboray-flash --port auto` do:\n\n"
                   "```sh\nroboray-ground fixes SOURCE [--format auto|nmea|xml]\n    [--max-age S] --master DEVICE\n"
                   "roboray-ground fixes udpin:0.0.0.0:2947 --master /dev/ttyUSB0\n```\n\n"
                   "```\n$ roboray-ground status --master /dev/pts/0\nroboray-ground status: no heartbeat\n```\n")
    assert list(command_lines(doc)) == [
        (6, "roboray-ground", ["fixes", "udpin:0.0.0.0:2947", "--master", "/dev/ttyUSB0"]),
        (10, "roboray-ground", ["status", "--master", "/dev/pts/0"])]
    found = list(mentions(doc))
    assert [n for n, _ in found] == [1, 1, 4]
    assert found[2][1].endswith("[--max-age S] --master DEVICE")
    assert [synopsis_error(text) for _, text in found] == [
        "", "roboray-flash has no option --port", "roboray-ground fixes --format: no choice xml"]
    assert synopsis_error("roboray-sim bench nope") == "roboray-sim bench has no command 'nope'"
    assert synopsis_error("roboray-sim sil [--scenario target-landing|velocity] [--jsn]") == \
        "roboray-sim sil has no option --jsn"


def test_a_file_a_doc_names_must_exist_unless_it_is_another_projects(tmp_path, monkeypatch):
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_a.py").write_text("")
    doc = tmp_path / "d.md"
    doc.write_text("`tests/test_a.py`, `tests/test_*.py`, `NOTES.md`, `tests/test_b.py::test_x`,\n"
                   "MicroPython's `tests/run-perfbench.py`, `tests/test_c*.py`, `roboray-sim`,\n"
                   "the project's `docs/x.md`\n"
                   "```\n`tests/in_a_block.py`\n```\n")
    assert missing_paths(doc) == ["d.md:1: NOTES.md is not in the repository",
                                  "d.md:1: tests/test_b.py is not in the repository",
                                  "d.md:2: tests/test_c*.py is not in the repository",
                                  "d.md:3: docs/x.md is not in the repository"]


def test_links_out_of_the_repository_and_the_old_sibling_folder_are_found(tmp_path, monkeypatch):
    repo = tmp_path / "repo"
    (repo / "docs").mkdir(parents=True)
    monkeypatch.setattr(sys.modules[__name__], "ROOT", repo)
    (tmp_path / "elsewhere.py").write_text("")
    (repo / "inside.py").write_text("")
    (repo / "out.py").symlink_to(tmp_path / "elsewhere.py")
    (repo / "in.py").symlink_to(repo / "inside.py")
    (repo / "setup.cfg").write_text("[paths]\nboard = " + ".." + "/shared/x.py\n")
    (repo / "docs" / "a.md").write_text("see `../inside.py` and ../../elsewhere.py\n")
    files = [repo / name for name in ("out.py", "in.py", "inside.py", "setup.cfg", "docs/a.md")]
    assert pointers_outside(files) == [
        "out.py is a link to %s" % (tmp_path / "elsewhere.py"),
        "setup.cfg:2: board = " + ".." + "/shared/x.py",
        "docs/a.md:1: ../../elsewhere.py points outside the repository"]


# ---------------------------------------------------------------- the docs


def test_every_relative_link_in_the_docs_resolves():
    assert ROOT / "docs" / "user" / "parameters.md" in DOCS
    problems = [p for path in DOCS for p in broken_links(path)]
    assert not problems, "broken links:\n" + "\n".join(problems)


def test_every_command_line_in_the_docs_parses_with_the_current_cli(monkeypatch):
    # relative paths in the examples (--plot docs/figures/x.png) are the repository's
    monkeypatch.chdir(ROOT)
    shown = [(path, n, script, argv) for path in DOCS for n, script, argv in command_lines(path)]
    assert len(shown) > 50 and {s for _, _, s, _ in shown} == set(CLIS)
    problems = ["%s:%d: %s %s: %s" % (_rel(path), n, script, " ".join(argv), error)
                for path, n, script, argv in shown for error in [parse_error(script, argv)] if error]
    assert not problems, "doc command lines the CLIs refuse:\n" + "\n".join(problems)


def test_every_command_the_docs_name_has_the_options_and_choices_they_name():
    shown = [(path, n, text) for path in DOCS for n, text in mentions(path)]
    assert len(shown) > 50
    problems = ["%s:%d: %s: %s" % (_rel(path), n, text, error)
                for path, n, text in shown for error in [synopsis_error(text)] if error]
    assert not problems, "commands the docs name wrongly:\n" + "\n".join(problems)


#: Options commands.md names once for a whole family instead of on each command's line.
_SAID_ONCE = {
    "roboray-sim": {"--vehicle", "--water"},                 # "Simulation and analysis commands take ..."
    "roboray-ground": {"--master", "--baudrate", "--source-system", "--key", "--key-file", "--timeout",
                       "--json", "--ack-timeout"},                 # "The vehicle commands share ..."
    "roboray-flash": set(),
}


def missing_from_usage(usages: list[str]) -> list[str]:
    """The options (and an option's word choices) of the command that
    ``usages`` (the reference's synopsis lines of one command) leave out."""
    words = usages[0].replace("[", " ").replace("]", " ").split()
    script, parser, k = words[0], importlib.import_module(CLIS[words[0]]).build_parser(), 1
    while k < len(words) and words[k] in _subcommands(parser):
        parser = _subcommands(parser)[words[k]]
        k += 1
    if _subcommands(parser):
        return []   # a family's line ("roboray-ground log ..."), its commands have their own
    text = " ".join(usages)
    missing = []
    for action in parser._actions:
        if not action.option_strings or isinstance(action, argparse._HelpAction):
            continue
        if not any(re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(o), text) for o in action.option_strings):
            if not set(action.option_strings) & _SAID_ONCE[script]:
                missing.append(action.option_strings[-1])
        elif action.choices and all(isinstance(c, str) and not c[:1].isdigit() for c in action.choices):
            missing += ["%s %s" % (action.option_strings[-1], c) for c in action.choices
                        if not re.search(r"(?<![\w.-])%s(?![\w-])" % re.escape(c), text)]
    return missing


def reference_usages(path: Path) -> list[tuple[int, list[str]]]:
    """``(line, synopses)`` of each command a reference bullet documents:
    ``- `roboray-sim trim --wings ... [--json]`:``, with the further
    synopses of the same command in that bullet (``or `roboray-sim ...```)."""
    out: list[tuple[int, list[str]]] = []
    section = ""
    for n, line in _prose_lines(path):
        if line.startswith("## "):
            section = line[3:].strip()
        m = re.match(r"^- `(roboray-(?:sim|ground|flash) [^`]*)`", line)
        if m:
            out.append((n, [m.group(1)]))
            continue
        if section == "roboray-ground" and re.match(r"^- `[a-z]", line):
            # the vehicle commands go by their names alone (`status`, `arm [--force]`), and one
            # command's actions over several bullets (`log list`, ..., `log record FILE.tlog`)
            for code in _INLINE_CODE.finditer(line):
                if re.match(r"[a-z]", code.group(2)):
                    usage = "roboray-ground " + code.group(2)
                    same = [u for _, u in out if u[0].split()[:2] == usage.split()[:2]]
                    if same:
                        same[0].append(usage)
                    else:
                        out.append((n, [usage]))
            continue
        if out and line.startswith("  "):
            for code in _INLINE_CODE.finditer(line):
                if code.group(2).startswith(out[-1][1][0].split(" [")[0].split(" --")[0] + " "):
                    out[-1][1].append(code.group(2))
    return out


def test_the_command_reference_gives_every_option_of_each_command():
    # a user reads commands.md for what a command takes: 24 lines had fallen behind their parsers
    usages = reference_usages(ROOT / "docs/user/commands.md")
    assert len(usages) > 30
    problems = ["docs/user/commands.md:%d: %s leaves out %s" % (n, u[0].split(" [")[0], ", ".join(missing))
                for n, u in usages for missing in [missing_from_usage(u)] if missing]
    assert not problems, "\n".join(problems)
    assert missing_from_usage(["roboray-sim bench board [--cpu-mhz MHZ] [--json]"]) == [
        "--build", "--no-romfs", "--write-model"]
    assert missing_from_usage(["roboray-sim sil [--interpreter micropython|cpython]"])[:2] == [
        "--scenario", "--speedup"]
    assert "--interpreter roboray-unix" in missing_from_usage(["roboray-sim sil [--interpreter micropython|cpython]"])


def test_every_file_the_docs_name_is_in_the_repository():
    assert sum(1 for path in DOCS for _ in named_paths(path)) > 50
    problems = [p for path in DOCS for p in missing_paths(path)]
    assert not problems, "\n".join(problems)


def test_the_parameter_reference_is_what_the_generator_writes_now():
    committed = gen_param_docs.default_out().read_text(encoding="utf-8")
    assert committed == gen_param_docs.generate(), "run .venv/bin/python -m roboray.tools.gen_param_docs"
    from roboray.firmware.app import PARAMS

    for d in PARAMS:
        assert "| `%s` |" % d[0] in committed, d[0]


def test_every_count_of_the_parameters_the_docs_give_is_the_firmwares():
    # The docs show `param fetch` transcripts; a parameter added since makes them lie (83 stood for 89).
    from roboray.firmware.app import PARAMS

    said = re.compile(r"(?:\b(\d+) parameters\b|parameters, all (\d+)\b|all (\d+) values\b)")
    wrong = []
    for doc in DOCS:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for m in said.finditer(line):
                count = int(next(g for g in m.groups() if g))
                if count != len(PARAMS):
                    wrong.append("%s:%d says %d, the firmware has %d" % (doc.relative_to(ROOT), n, count, len(PARAMS)))
    assert not wrong, wrong
    assert any("%d parameters" % len(PARAMS) in d.read_text(encoding="utf-8") for d in DOCS)


def test_the_parameter_reference_is_linked_from_the_readme_and_the_commands():
    for doc in ("README.md", "docs/user/commands.md"):
        targets = [(ROOT / doc).parent.joinpath(t.partition("#")[0]).resolve() for _, t in _links(ROOT / doc)]
        assert gen_param_docs.default_out() in targets, doc


def test_gen_param_docs_check_says_whether_the_page_is_current(tmp_path):
    out = tmp_path / "parameters.md"
    assert gen_param_docs.main(["--out", str(out), "--check"]) == 1
    assert gen_param_docs.main(["--out", str(out)]) == 0
    assert gen_param_docs.main(["--out", str(out), "--check"]) == 0
    out.write_text(out.read_text().replace("| 57600 |", "| 9600 |"))
    assert gen_param_docs.main(["--out", str(out), "--check"]) == 1


def test_the_reference_groups_every_parameter_once_as_param_meta_orders_them():
    from roboray.shared.param_meta import META

    groups = gen_param_docs.meta_groups()
    assert [title for title, _ in groups][:3] == ["identity, link", "streams", "failsafes"]
    assert [name for _, names in groups for name in names] == list(META)
    page = gen_param_docs.generate()
    headings = re.findall(r"^## (.+)$", page, re.M)
    assert [h.lower() for h in headings] == [title for title, _ in groups]
    assert "| `SERIAL_BAUD` | 57600 | 1200 to 921600 |  |" in page and "Read-only." in page
    assert "0 Off, 1 Warn, 2 Disarm, 3 FAILSAFE mode." in page and "| s (seconds) |" in page


def test_gen_param_docs_says_in_one_line_what_it_cannot_write(tmp_path, capsys):
    assert gen_param_docs.main(["--out", str(tmp_path / "no" / "such" / "parameters.md")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write" in err and "Traceback" not in err
    with pytest.raises(SystemExit) as e:
        gen_param_docs.main(["--no-such-option"])
    assert e.value.code == 2


def test_nothing_in_the_repository_points_outside_it():
    files = _repository_files()
    assert len(files) > 100 and ROOT / "shared" / "param_meta.py" in files
    problems = pointers_outside(files)
    assert not problems, "\n".join(problems)
