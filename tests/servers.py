"""Policy server processes for the policy tests: started on a free port of 127.0.0.1, stopped by the test."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

TESTS = Path(__file__).parent
ROBOLAB = [sys.executable, "-m", "robolab_ms.cli"]


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class ServerProcess:
    """A server subprocess whose stdout is collected line by line; `ready` is the text it prints when listening."""

    def __init__(self, args: list[str], ready: str, timeout: float = 120.0, env: dict[str, str] | None = None) -> None:
        self.args, self.lines = args, []
        self.process = subprocess.Popen(
            args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True, env=env
        )
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self.process.stdout.readline()
            if not line:
                raise RuntimeError(f"{args} exited before it was ready:\n" + "".join(self.lines))
            self.lines.append(line)
            if ready in line:
                return
        self.stop()
        raise RuntimeError(f"{args} not ready after {timeout} s:\n" + "".join(self.lines))

    def wait_for(self, text: str, timeout: float = 300.0) -> str:
        """Read output until a line containing `text` (the server must print lines as it works)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = self.process.stdout.readline()
            if not line:
                break
            self.lines.append(line)
            if text in line:
                return line
        raise RuntimeError(f"no line with {text!r} from {self.args}:\n" + "".join(self.lines[-30:]))

    def kill(self) -> None:
        """SIGKILL: the server dies without closing its connections."""
        os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=30)

    def stop(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.kill()


def robolab_serve(*args: str) -> ServerProcess:
    return ServerProcess([*ROBOLAB, "serve", *args], ready="robolab serve:")


def fault_server(protocol: str, port: int, faults: dict[int, str], log: Path, delay: float = 0.0) -> ServerProcess:
    import json

    return ServerProcess(
        [
            sys.executable,
            str(TESTS / "fault_server.py"),
            "--protocol",
            protocol,
            "--port",
            str(port),
            "--faults",
            json.dumps(faults),
            "--log",
            str(log),
            "--delay",
            str(delay),
        ],
        ready="ready",
    )
