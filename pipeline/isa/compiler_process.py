"""A shader compiler's process kept running between batches (Mesa's GL ES driver under qemu, RADV
in `vulkan_pipeline.py`): a batch is one line written to its standard input, its answer every line
it prints up to the batch's end marker. The process is started once per command and key in this
process (`running`), so its start (the driver's and the device's set-up) is paid once, not per
batch. It reads its input to the end, so it ends when this process ends, whatever ends it."""

from __future__ import annotations

import atexit
import os
import select
import subprocess
import tempfile
import threading
import time


class Ended(RuntimeError):
    """The process ended inside a batch: its exit status and the end of what it printed."""

    def __init__(self, returncode: int | None, printed: str):
        super().__init__(f"exit {returncode}: {printed}")
        self.returncode = returncode
        self.printed = printed


class CompilerProcess:
    """One compiler process. Any failure or interruption inside a batch ends it (its output would be
    out of step); `running` then starts another for the next batch."""

    def __init__(self, command: list[str], env: dict[str, str]):
        self.folder = tempfile.TemporaryDirectory()
        self.process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, env=env, cwd=self.folder.name)
        self.lock = threading.Lock()
        self.pending = b""

    def alive(self) -> bool:
        return self.process.poll() is None

    def batch(self, line: str, end: str, timeout: float) -> str:
        """What the process printed after reading `line`, up to the line `end` (one batch at a time:
        callers in other threads wait); TimeoutError after `timeout` seconds, `Ended` where it ended
        first."""
        printed = []
        with self.lock:
            try:
                self.process.stdin.write(line.encode() + b"\n")
                self.process.stdin.flush()
                for out in self._lines(timeout):
                    if out == end:
                        return "\n".join(printed)
                    printed.append(out)
            except BrokenPipeError:
                pass
            except BaseException:
                self.close()
                raise
            self.close()
        raise Ended(self.process.returncode, "\n".join(printed).strip()[-2000:])

    def _lines(self, timeout: float):
        """The process's output lines until it ends; TimeoutError after `timeout` seconds."""
        deadline = time.monotonic() + timeout
        stream = self.process.stdout.fileno()
        while True:
            while b"\n" in self.pending:
                line, self.pending = self.pending.split(b"\n", 1)
                yield line.decode(errors="replace")
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([stream], [], [], left)[0]:
                raise TimeoutError
            chunk = os.read(stream, 1 << 16)
            if not chunk:
                if self.pending:
                    yield self.pending.decode(errors="replace")
                    self.pending = b""
                return
            self.pending += chunk

    def close(self) -> None:
        """Ends the process: its input closed, killed if it has not ended within 5 s."""
        for stream in (self.process.stdin, self.process.stdout):
            try:
                stream.close()
            except OSError:
                pass
        try:
            self.process.wait(5)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.folder.cleanup()


_RUNNING: dict[tuple, CompilerProcess] = {}
_LOCK = threading.Lock()


def running(command: list[str], key: tuple, env) -> CompilerProcess:
    """This process's running compiler for `command` and `key` (the variables that make it compile
    for one chip), started with the variables `env()` gives where none runs."""
    full = (os.getpid(), tuple(command), key)
    with _LOCK:
        found = _RUNNING.get(full)
        if found is not None and not found.alive():
            found.close()
            found = None
        if found is None:
            found = _RUNNING[full] = CompilerProcess(command, env())
        return found


@atexit.register
def close_all() -> None:
    """Ends this process's compilers (a process started by fork leaves its parent's alone)."""
    with _LOCK:
        for full in [full for full in _RUNNING if full[0] == os.getpid()]:
            _RUNNING.pop(full).close()
