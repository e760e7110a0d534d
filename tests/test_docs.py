"""Every shell example of README.md and docs/**/*.md, run (see docs/README.md, "Examples
in the guide are tested", for the rules and the markers).

Run after `.ci/test` has built the binaries and the venv (it runs this file last):

    .venv/bin/python -m pytest tests/test_docs.py -q

Not part of `cargo test`: cargo holds the target directory's lock while its tests run,
so a `cargo` command in an example would wait for ever.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PAGES = [REPO / "README.md"] + sorted((REPO / "docs").rglob("*.md"))
RUN_LANGS = {"sh", "console", "python"}
DEFAULT_TIMEOUT = 300.0
READY_TIMEOUT = 60.0
README_MAX_LINES = 300
BENCHMARKS_MAX_LINES = 500
HISTORY = REPO / "docs" / "performance-history.md"
# words that tell of a past version: the guide says what the software does now, the
# history page (HISTORY) and git say what it did
PAST = re.compile(
    r"\bearlier (versions?|presets?)\b|\bused to\b|\bno longer\b|\bpreviously\b|\bformerly\b"
    r"|\bwas changed\b|\buntil recently\b|\bbefore (this|these|the) changes?\b",
    re.I,
)
ZENOH_BIN = Path(os.environ.get("CLIFF_DOCS_ZENOH_BIN", REPO / "target" / "py" / "release"))
RELEASE = REPO / "target" / "release"


# ---------------------------------------------------------------- parsing the pages


@dataclass
class Command:
    text: str  # the command as written (continuations joined)
    expected: list[str] = field(default_factory=list)


@dataclass
class Block:
    page: Path
    line: int  # 1-based line of the opening fence
    lang: str
    body: str
    background: bool = False
    ready: str | None = None
    skip: str | None = None
    timeout: float = DEFAULT_TIMEOUT
    stop_before: bool = False  # a `stop` marker came since the previous block

    @property
    def name(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.line}"

    def commands(self) -> list[Command]:
        if self.lang == "console":
            return parse_console(self.body)
        return parse_sh(self.body)


MARKER = re.compile(r"^\s*<!--\s*example:\s*(.*?)\s*-->\s*$")


def parse_marker(text: str, block: dict) -> None:
    for part in re.findall(r'(\w[\w-]*)(?:\s+"([^"]*)"|\s+([0-9.]+))?', text):
        key, quoted, number = part
        if key == "background":
            block["background"] = True
        elif key == "ready":
            block["ready"] = quoted
        elif key == "skip":
            block["skip"] = quoted
        elif key == "timeout":
            block["timeout"] = float(number)
        elif key == "stop":
            block["stop_before"] = True
        else:
            raise ValueError(f"unknown example marker '{key}' in <!-- example: {text} -->")


def parse_page(page: Path) -> list[Block]:
    blocks: list[Block] = []
    pending: dict = {}
    lines = page.read_text(encoding="utf-8").split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        m = MARKER.search(line)
        if m:
            parse_marker(m.group(1), pending)
            i += 1
            continue
        fence = re.match(r"^(`{3,})(\S*)\s*$", line)
        if fence:
            ticks, lang = fence.group(1), fence.group(2)
            start = i
            i += 1
            body = []
            while i < len(lines) and not lines[i].startswith(ticks):
                body.append(lines[i])
                i += 1
            if lang in RUN_LANGS or pending:
                if lang not in RUN_LANGS and not pending.get("skip"):
                    raise ValueError(f"{page}:{start + 1}: marker on a ```{lang} block")
                blocks.append(Block(page, start + 1, lang or "text", "\n".join(body), **pending))
                pending = {}
        elif line.strip() and not pending.get("stop_before"):
            # a marker applies to the next block only if nothing but blank lines and
            # markers stand between them (a pending `stop` waits for the next block)
            if pending:
                raise ValueError(f"{page}:{i + 1}: example marker not followed by a block")
        i += 1
    if pending.get("stop_before"):
        blocks.append(Block(page, len(lines), "stop", "", stop_before=True))
    return blocks


def join_continuations(lines: list[str]) -> list[tuple[str, bool]]:
    """(line, is_continued_command) pairs: a trailing backslash joins the next line."""
    out: list[tuple[str, bool]] = []
    buf = ""
    for line in lines:
        if buf:
            buf += "\n" + line
        else:
            buf = line
        if not line.endswith("\\"):
            out.append((buf, "\n" in buf))
            buf = ""
    if buf:
        out.append((buf, True))
    return out


def parse_sh(body: str) -> list[Command]:
    cmds: list[Command] = []
    for text, _ in join_continuations(body.split("\n")):
        stripped = text.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            if cmds and stripped.startswith("# "):
                cmds[-1].expected.append(stripped[2:])
            continue
        cmds.append(Command(text))
    return cmds


def parse_console(body: str) -> list[Command]:
    cmds: list[Command] = []
    lines = body.split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("$ "):
            text = line[2:]
            while text.endswith("\\") and i + 1 < len(lines):
                i += 1
                text += "\n" + lines[i]
            cmds.append(Command(text))
        elif line.strip() and cmds:
            cmds[-1].expected.append(line)
        elif line.strip():
            raise ValueError(f"console block: output before any command: {line!r}")
        i += 1
    return cmds


ALL_BLOCKS = [b for page in PAGES for b in parse_page(page)]


def run_blocks(blocks: list[Block]) -> list[Block]:
    """The blocks the harness runs; a `stop` marker before a block that is not run
    (skipped, or of a language not run) still stops the page's background commands."""
    run = []
    for b in blocks:
        if not b.skip and b.lang in RUN_LANGS | {"stop"}:
            run.append(b)
        elif b.stop_before:
            run.append(Block(b.page, b.line, "stop", "", stop_before=True))
    return run


RUN_BLOCKS = run_blocks(ALL_BLOCKS)


# ---------------------------------------------------------------- running


CARGO_RUN = re.compile(r"^\s*cargo run (?P<opts>(?:(?!\s--(?:\s|$)).)*?)(?:\s--(?:\s+(?P<args>.*))?)?$", re.S)


def substitute(cmd: str, port: int) -> str:
    """Rewrite `cargo run` into the built binary, and the zenoh port into a free one."""
    cmd = cmd.replace("127.0.0.1:7447", f"127.0.0.1:{port}")
    m = CARGO_RUN.match(cmd)
    if not m:
        return cmd
    opts = shlex.split(m.group("opts").replace("\\\n", " "))
    args = m.group("args") or ""
    if "--release" not in opts:
        raise AssertionError(f"examples build with --release: {cmd}")
    zenoh = any("zenoh" in o for o in opts)
    bindir = ZENOH_BIN if zenoh else RELEASE
    if "--bin" in opts:
        exe = bindir / opts[opts.index("--bin") + 1]
    elif "--example" in opts:
        exe = bindir / "examples" / opts[opts.index("--example") + 1]
    elif all(o in ("--release", "-p", "cliff") for o in opts):
        exe = bindir / "cliff"
    else:
        raise AssertionError(f"cannot map onto a built binary: {cmd}")
    if not exe.exists():
        raise AssertionError(f"{exe} is missing (build it first, e.g. with .ci/test)")
    return f"{shlex.quote(str(exe))} {args}".rstrip()


VOLATILE = [
    (re.compile(r"\b\d+(\.\d+)? s (reading|fitting)"), r"T s \2"),
    (re.compile(r"done in \d+(\.\d+)? s"), "done in T s"),
    (re.compile(r"(seed\(s\)|seeds), \d+(\.\d+)? s\)"), r"\1, T s)"),
    (re.compile(r"^time \d+(\.\d+)? s$"), "time T s"),
    (re.compile(r"iceoryx2 prefix '[^']*'"), "iceoryx2 prefix 'P'"),
]


def normalize(line: str) -> str:
    line = " ".join(line.split())
    for rx, rep in VOLATILE:
        line = rx.sub(rep, line)
    return line


def expected_pattern(line: str) -> re.Pattern:
    parts = [re.escape(p) for p in normalize(line).split("...")]
    return re.compile("^" + ".*".join(parts) + "$")


def check_output(expected: list[str], output: str) -> str | None:
    """None if the expected lines appear in order in the output, else what is missing."""
    actual = [normalize(line) for line in output.split("\n")]
    pos = 0
    for want in expected:
        if want.strip() == "...":
            continue
        rx = expected_pattern(want)
        while pos < len(actual) and not rx.match(actual[pos]):
            pos += 1
        if pos == len(actual):
            return f"expected line not found (in order): {want!r}"
        pos += 1
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Background:
    def __init__(self, name: str, cmd: str, cwd: Path, env: dict, ready: str | None):
        self.name = name
        self.lines: list[str] = []
        self.event = threading.Event()
        self.ready = ready
        self.proc = subprocess.Popen(
            ["bash", "-c", "exec " + cmd], cwd=cwd, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, start_new_session=True)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))
            if self.ready is None or self.ready in line:
                self.event.set()
        self.event.set()

    def wait_ready(self) -> None:
        if not self.event.wait(READY_TIMEOUT) or self.proc.poll() is not None:
            self.stop()
            raise AssertionError(f"{self.name}: no ready line {self.ready!r}:\n" + "\n".join(self.lines[-30:]))

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


class Runner:
    """State shared by the tests: one work directory, the background commands of the
    page being run, the outputs of the commands already run."""

    def __init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="cliff-docs-"))
        self.work = self.root / "work"
        self.work.mkdir()
        (self.root / "shared").symlink_to((REPO.parent / "shared").resolve())
        for entry in REPO.iterdir():
            if entry.name in ("docs", ".git"):
                continue
            (self.work / entry.name).symlink_to(entry)
        shutil.copytree(REPO / "docs", self.work / "docs")
        self.page: Path | None = None
        self.background: list[Background] = []
        self.cache: dict[str, tuple[int, str]] = {}
        self.port = free_port()
        self.env = dict(os.environ)
        self.env["PATH"] = f"{RELEASE}:{self.env.get('PATH', '')}"
        self.env.pop("RUST_LOG", None)
        self.session = f"docs{os.getpid()}"
        # `cargo` commands other than `cargo run` run in the repository itself
        self.prelude = f'cargo() {{ (cd {shlex.quote(str(REPO))} && command cargo "$@"); }}\n'

    def enter(self, page: Path) -> None:
        if page != self.page:
            self.stop_background()
            self.page = page
            index = PAGES.index(page)
            self.env["CLIFF_IPC_PREFIX"] = f"{self.session}_{index}_"
            self.port = free_port()

    def stop_background(self) -> None:
        for bg in self.background:
            bg.stop()
        self.background = []

    def run(self, block: Block) -> None:
        self.enter(block.page)
        if block.stop_before:
            self.stop_background()
        if block.lang == "stop":
            return
        if block.lang == "python":
            self.run_python(block)
            return
        cmds = block.commands()
        if block.background:
            assert len(cmds) == 1, f"{block.name}: a background block holds one command"
            bg = Background(block.name, substitute(cmds[0].text, self.port), self.work, self.env, block.ready)
            self.background.append(bg)
            bg.wait_ready()
            problem = check_output(self.expected(cmds[0]), "\n".join(bg.lines))
            assert problem is None, f"{block.name}: {problem}\noutput:\n" + "\n".join(bg.lines)
            return
        for cmd in cmds:
            self.run_command(block, cmd)

    def run_command(self, block: Block, cmd: Command) -> None:
        text = substitute(cmd.text, self.port)
        # the key: the command without line breaks and without a trailing comment
        key = " ".join(re.sub(r"\s#\s.*$", "", text.replace("\\\n", " ")).split())
        if key in self.cache:
            status, output = self.cache[key]
        else:
            started = time.monotonic()
            proc = subprocess.Popen(
                ["bash", "-o", "pipefail", "-c", self.prelude + text], cwd=self.work, env=self.env,
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
            try:
                output, _ = proc.communicate(timeout=block.timeout)
            except subprocess.TimeoutExpired as e:
                os.killpg(proc.pid, signal.SIGKILL)  # the command and everything it started
                proc.communicate()
                raise AssertionError(f"{block.name}: timed out after {block.timeout} s: {cmd.text}") from e
            status = proc.returncode
            print(f"{time.monotonic() - started:7.1f} s  {key[:120]}")
            self.cache[key] = (status, output)
        must_fail = any(line.startswith("error:") for line in cmd.expected)
        shown = f"{block.name}: {cmd.text}\nstatus {status}, output:\n{output[-4000:]}"
        if must_fail:
            assert status != 0, f"expected to fail: {shown}"
        else:
            assert status == 0, f"failed: {shown}"
        problem = check_output(self.expected(cmd), output)
        assert problem is None, f"{problem}\n{shown}"

    def expected(self, cmd: Command) -> list[str]:
        """The command's expected lines, with the port it was given."""
        return [line.replace("127.0.0.1:7447", f"127.0.0.1:{self.port}") for line in cmd.expected]

    def run_python(self, block: Block) -> None:
        script = self.work / f"example-{block.page.stem}-{block.line}.py"
        script.write_text(block.body.replace("127.0.0.1:7447", f"127.0.0.1:{self.port}"))
        proc = subprocess.run([sys.executable, script.name], cwd=self.work, env=self.env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              timeout=block.timeout)
        assert proc.returncode == 0, f"{block.name}: python block failed:\n{proc.stdout[-4000:]}"

    def close(self) -> None:
        self.stop_background()
        if os.environ.get("CLIFF_DOCS_KEEP"):
            print(f"work directory kept: {self.work}")
        else:
            shutil.rmtree(self.root, ignore_errors=True)


@pytest.fixture(scope="session")
def runner():
    r = Runner()
    yield r
    r.close()


@pytest.mark.parametrize("block", RUN_BLOCKS, ids=[b.name for b in RUN_BLOCKS])
def test_example(runner: Runner, block: Block) -> None:
    runner.run(block)


# ---------------------------------------------------------------- the pages themselves


def test_skipped_blocks() -> None:
    """Blocks not run say why; the list is printed (pytest -s) for the record."""
    skipped = [b for b in ALL_BLOCKS if b.skip is not None]
    for b in skipped:
        assert b.skip.strip(), f"{b.name}: a skip marker needs a reason"
        print(f"not run: {b.name}: {b.skip}")


def test_stop_before_a_skipped_block_still_stops(tmp_path: Path) -> None:
    """A `stop` marker followed by a skipped block stops the background commands before
    the page's next run block (a daemon left running would answer the next example)."""
    page = tmp_path / "page.md"
    page.write_text("\n".join([
        '<!-- example: background, ready "up" -->', "```sh", "serve", "```",
        "<!-- example: stop -->", "", '<!-- example: skip "not here" -->', "```sh", "install", "```",
        "```sh", "ask", "```", ""]), encoding="utf-8")
    run = run_blocks(parse_page(page))
    assert [(b.lang, b.stop_before) for b in run] == [("sh", False), ("stop", True), ("sh", False)]


def github_anchor(heading: str) -> str:
    text = re.sub(r"[`*]", "", heading.strip().lower())
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    out: set[str] = set()
    seen: dict[str, int] = {}
    fence = False
    for line in page.read_text(encoding="utf-8").split("\n"):
        if line.startswith("```"):
            fence = not fence
        m = re.match(r"^#+\s+(.*)$", line)
        if m and not fence:
            a = github_anchor(m.group(1))
            n = seen.get(a, 0)
            seen[a] = n + 1
            out.add(a if n == 0 else f"{a}-{n}")
    return out


LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


@pytest.mark.parametrize("page", PAGES + [REPO / "BENCHMARKS.md"], ids=lambda p: str(p.relative_to(REPO)))
def test_links(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    bad = []
    for target in LINK.findall(text):
        if re.match(r"^[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{target}: no heading with anchor #{anchor}")
    assert not bad, f"{page.relative_to(REPO)}: broken links:\n" + "\n".join(bad)


def test_front_page_is_short() -> None:
    lines = (REPO / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines; the guide (docs/) takes the details"


def test_benchmarks_page_holds_todays_figures() -> None:
    """BENCHMARKS.md is a few hundred lines of current figures; the journal of how they
    came about is the history page, which it links."""
    text = (REPO / "BENCHMARKS.md").read_text(encoding="utf-8")
    lines = text.count("\n")
    assert lines <= BENCHMARKS_MAX_LINES, (
        f"BENCHMARKS.md has {lines} lines (at most {BENCHMARKS_MAX_LINES}): keep today's figures "
        f"there and move how they came about to {HISTORY.relative_to(REPO)}"
    )
    assert "docs/performance-history.md" in text, "BENCHMARKS.md does not link the history page"


def test_remeasure_script_runs_every_benchmark_of_the_page() -> None:
    """benches/remeasure.sh (the rows of BENCHMARKS.md in one session) names every bench
    script and cargo bench the page's rows name; `--list` runs nothing."""
    text = (REPO / "BENCHMARKS.md").read_text(encoding="utf-8")
    subjects = ["predictor", "motion", "accuracy", "ros2", "build", "python", "daemon", "sharing",
                "zenoh", "zenoh-build", "learning"]
    out = subprocess.run(["bash", str(REPO / "benches" / "remeasure.sh"), "--list", *subjects],
                         capture_output=True, text=True, timeout=60, cwd=REPO)
    assert out.returncode == 0, out.stderr
    listed = out.stdout
    named = set(re.findall(r"benches/(\w+\.(?:sh|py))", text)) - {"remeasure.sh"}
    named |= {f"--bench {b}" for b in re.findall(r"--bench (\w+)", text)}
    assert named, "BENCHMARKS.md names no bench"
    missing = sorted(n for n in named if n not in listed)
    assert not missing, f"benches/remeasure.sh does not run: {missing}"
    bad = subprocess.run(["bash", str(REPO / "benches" / "remeasure.sh"), "--list", "no-such-subject"],
                         capture_output=True, text=True, timeout=60, cwd=REPO)
    assert bad.returncode != 0 and "no-such-subject" in bad.stderr


def test_guide_speaks_in_the_present() -> None:
    """README.md and the guide say what the software does now; words of its past
    belong on the history page."""
    found = []
    for page in PAGES:
        if page == HISTORY:
            continue
        for n, line in enumerate(page.read_text(encoding="utf-8").split("\n"), 1):
            m = PAST.search(line)
            if m:
                found.append(f"{page.relative_to(REPO)}:{n}: '{m.group(0)}' in: {line.strip()}")
    assert not found, "words of the past in the guide (move them to docs/performance-history.md):\n" + "\n".join(found)


def test_words_about_the_software() -> None:
    """Docs and bench scripts speak of the software, not of the tracker's issues."""
    files = PAGES + [REPO / "BENCHMARKS.md", REPO / "fuzz" / "README.md"] + sorted((REPO / "benches").glob("*"))
    found = []
    for f in files:
        if f.is_file():
            for n, line in enumerate(f.read_text(encoding="utf-8", errors="replace").split("\n"), 1):
                if re.search(r"\bissues?\b|\bissue's\b", line, re.I):
                    found.append(f"{f.relative_to(REPO)}:{n}: {line.strip()}")
    assert not found, "mentions of issues:\n" + "\n".join(found)
