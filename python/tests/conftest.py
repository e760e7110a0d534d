"""Fixtures of the cliff_lhmp test suite.

Paths are relative to the repository root (this file's grandparent): the real data in
../shared/data, the release binaries in target/release (the test script builds them
before pytest runs; set CLIFF_BIN_DIR to use others).

The zenoh tests (test_zenoh.py) need the package built with the cargo feature zenoh and
a cliffd built with it: by default target/py/release/cliffd, which .ci/test builds (set
CLIFF_ZENOH_CLIFFD to use another). Without either they fail, naming what is missing and
how to build it; locally, CLIFF_SKIP_ZENOH=<reason> turns that failure into a skip that
reports the reason (.ci/test unsets it, so CI never skips them).
"""

import os
import signal
import socket
import subprocess
import threading
import time
import uuid
from pathlib import Path
from typing import Iterator, List, Optional

import pytest

import cliff_lhmp

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"
BIN = Path(os.environ.get("CLIFF_BIN_DIR", ROOT / "target" / "release"))
THOR1_MAP = DATA / "thor1" / "cliffmap.csv"
THOR1_TRACKS = DATA / "thor1" / "exp-1-run-2.csv"
SERVICE = "cliff/pytest"
ZENOH_CLIFFD = Path(
    os.environ.get("CLIFF_ZENOH_CLIFFD", ROOT / "target" / "py" / "release" / "cliffd")
)
ZENOH_BUILD = (
    "CARGO_TARGET_DIR=target/py cargo build --release -p cliff-service -p cliff-python "
    "--features cliff-service/zenoh,cliff-python/zenoh --bin cliffd"
)


def binary(name: str) -> Path:
    path = BIN / name
    if not path.exists():
        pytest.fail(
            f"{path} is missing: build it first (cargo build --release -p cliff -p cliff-service)"
        )
    return path


def run_cli(*args: str) -> str:
    """Run the `cliff` command line and return its standard output."""
    out = subprocess.run(
        [str(binary("cliff")), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, f"cliff {' '.join(args)} failed:\n{out.stderr}"
    return out.stdout


def new_prefix(tag: str) -> str:
    """An iceoryx2 namespace unique to this test session."""
    return f"clpy_{tag}_{os.getpid()}_{uuid.uuid4().hex[:8]}_"


def remove_namespace(prefix: str) -> None:
    """Remove the files iceoryx2 left for `prefix` (as the Rust service tests do), once
    the clients of that namespace are gone."""
    import gc

    gc.collect()
    for top in (Path("/dev/shm"), Path("/tmp/iceoryx2")):
        _remove_matching(top, prefix, 0)


def _remove_matching(d: Path, prefix: str, depth: int) -> bool:
    removed = False
    try:
        entries = list(d.iterdir())
    except OSError:
        return False
    for e in entries:
        try:
            if e.name.startswith(prefix):
                if e.is_dir():
                    import shutil

                    shutil.rmtree(e, ignore_errors=True)
                else:
                    e.unlink()
                removed = True
            elif e.is_dir() and depth < 4 and _remove_matching(e, prefix, depth + 1):
                removed = True
                try:
                    e.rmdir()
                except OSError:
                    pass
        except OSError:
            pass
    return removed


def zenoh_problems() -> List[str]:
    """What keeps the zenoh tests from running: an empty list when nothing does."""
    problems = []
    if not cliff_lhmp.HAS_ZENOH:
        problems.append(
            "the installed cliff_lhmp was built without the cargo feature zenoh "
            "(pip install ./python -C maturin.build-args=\"--features zenoh\")"
        )
    if not ZENOH_CLIFFD.exists():
        problems.append(f"{ZENOH_CLIFFD} is missing (build it: {ZENOH_BUILD})")
    else:
        out = subprocess.run([str(ZENOH_CLIFFD), "--help"], capture_output=True, text=True,
                             timeout=60)
        if "--zenoh" not in out.stdout:
            problems.append(f"{ZENOH_CLIFFD} was built without the feature zenoh ({ZENOH_BUILD})")
    return problems


def require_zenoh() -> None:
    """Fail unless the zenoh tests can run; skip instead when CLIFF_SKIP_ZENOH gives a
    reason (local use only: .ci/test unsets it)."""
    problems = zenoh_problems()
    if not problems:
        return
    reason = os.environ.get("CLIFF_SKIP_ZENOH", "").strip()
    text = "; ".join(problems)
    if reason:
        pytest.skip(f"zenoh tests skipped (CLIFF_SKIP_ZENOH={reason!r}): {text}")
    pytest.fail(f"cannot run the zenoh tests: {text} (set CLIFF_SKIP_ZENOH=<reason> to skip "
                "them locally)")


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Daemon:
    """A `cliffd` child process in its own namespace, stopped with SIGTERM."""

    def __init__(self, prefix: str, maps: List[str], log: Path, extra: Optional[List[str]] = None,
                 exe: Optional[Path] = None, service: str = SERVICE):
        self.prefix = prefix
        self.maps = maps
        self.log = log
        self.extra = extra or []
        self.exe = exe
        self.service = service
        self.proc: Optional[subprocess.Popen] = None

    def start(self) -> "Daemon":
        exe = self.exe or binary("cliffd")
        args = [str(exe), "--service", self.service, "--prefix", self.prefix]
        for m in self.maps:
            args += ["--map", m]
        args += self.extra
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                args, stdout=subprocess.PIPE, stderr=log, cwd=ROOT, text=True
            )
        assert self.proc.stdout is not None
        ready = threading.Event()
        stdout = self.proc.stdout

        def read() -> None:
            for line in stdout:
                if "ready" in line:
                    ready.set()

        threading.Thread(target=read, daemon=True).start()
        if not ready.wait(30):
            self.stop()
            pytest.fail(f"cliffd did not become ready; its log:\n{self.log.read_text()}")
        return self

    def signal(self, sig: int) -> None:
        assert self.proc is not None
        self.proc.send_signal(sig)

    def stop(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGCONT)
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    def client(self, **kwargs: object) -> cliff_lhmp.Client:
        kwargs.setdefault("deadline", 5.0)
        return cliff_lhmp.Client(self.service, prefix=self.prefix, **kwargs)  # type: ignore[arg-type]


@pytest.fixture(scope="session")
def thor1_map() -> cliff_lhmp.Map:
    return cliff_lhmp.Map.load(THOR1_MAP)


@pytest.fixture(scope="session")
def demo_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("maps") / "demo.csv"
    cliff_lhmp.Map.demo().save(path)
    return path


@pytest.fixture(scope="session")
def daemon(tmp_path_factory: pytest.TempPathFactory, demo_file: Path) -> Iterator[Daemon]:
    """One daemon for the session serving `thor1` and `demo` (from a file)."""
    prefix = new_prefix("s")
    log = tmp_path_factory.mktemp("logs") / "cliffd.log"
    d = Daemon(prefix, [f"thor1={THOR1_MAP}", f"demo={demo_file}"], log).start()
    try:
        yield d
    finally:
        d.stop()
        remove_namespace(prefix)


@pytest.fixture
def own_daemon(tmp_path: Path, demo_file: Path) -> Iterator[Daemon]:
    """A daemon for one test (to stop, kill or restart)."""
    prefix = new_prefix("f")
    d = Daemon(prefix, [f"demo={demo_file}"], tmp_path / "cliffd.log").start()
    try:
        yield d
    finally:
        d.stop()
        remove_namespace(prefix)


def wait_until(cond, timeout: float = 10.0) -> bool:  # type: ignore[no-untyped-def]
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.01)
    return False
