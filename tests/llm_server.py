"""A real OpenAI-compatible chat-completions server for the generation tests, answering from a script.

    python tests/llm_server.py --port P --answers ANSWERS.json --log REQUESTS.jsonl [--no-json-mode]

ANSWERS.json is a list; the n-th POST /v1/chat/completions gets the n-th entry as choices[0].message.content (a
string is sent as is, anything else as its JSON text). After the last entry the server answers 503. Every request
is appended to REQUESTS.jsonl (path, model, messages, response_format, whether a bearer key came). With
--no-json-mode it refuses response_format with a 400, as some local servers do. It prints "ready" when listening.

`LLMServer` starts it as a subprocess on a free port of 127.0.0.1 (the `llm_server` fixture in conftest.py).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path


def make_handler(answers: list, log_path: Path, json_mode: bool) -> type[BaseHTTPRequestHandler]:
    state = {"next": 0}

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, format: str, *args: object) -> None:  # noqa: A002 (quiet: the JSONL log is the record)
            pass

        def _send(self, status: int, body: dict) -> None:
            data = json.dumps(body).encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self) -> None:  # noqa: N802
            if self.path.rstrip("/").endswith("/models"):
                self._send(200, {"object": "list", "data": [{"id": "scripted", "object": "model"}]})
            else:
                self._send(404, {"error": {"message": f"no route {self.path}", "type": "not_found"}})

        def do_POST(self) -> None:  # noqa: N802
            length = int(self.headers.get("Content-Length") or 0)
            try:
                body = json.loads(self.rfile.read(length) or b"{}")
            except json.JSONDecodeError:
                self._send(400, {"error": {"message": "body is not JSON", "type": "invalid_request_error"}})
                return
            entry = {
                "path": self.path,
                "model": body.get("model"),
                "messages": body.get("messages"),
                "response_format": body.get("response_format"),
                "bearer": self.headers.get("Authorization", "").startswith("Bearer "),
            }
            with log_path.open("a", encoding="utf-8") as log:
                log.write(json.dumps(entry) + "\n")
            if not self.path.rstrip("/").endswith("/chat/completions"):
                self._send(404, {"error": {"message": f"no route {self.path}", "type": "not_found"}})
                return
            if body.get("response_format") and not json_mode:
                self._send(
                    400,
                    {
                        "error": {
                            "message": "response_format is not supported",
                            "type": "invalid_request_error",
                            "param": "response_format",
                        }
                    },
                )
                return
            if state["next"] >= len(answers):
                self._send(503, {"error": {"message": "no scripted answers left", "type": "server_error"}})
                return
            answer = answers[state["next"]]
            state["next"] += 1
            content = answer if isinstance(answer, str) else json.dumps(answer)
            self._send(
                200,
                {
                    "id": f"chatcmpl-{state['next']}",
                    "object": "chat.completion",
                    "created": int(time.time()),
                    "model": body.get("model") or "scripted",
                    "choices": [
                        {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}
                    ],
                    "usage": {"prompt_tokens": 0, "completion_tokens": 0, "total_tokens": 0},
                },
            )

    return Handler


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--answers", required=True)
    parser.add_argument("--log", required=True)
    parser.add_argument("--no-json-mode", action="store_true")
    args = parser.parse_args()
    answers = json.loads(Path(args.answers).read_text(encoding="utf-8"))
    server = ThreadingHTTPServer(("127.0.0.1", args.port), make_handler(answers, Path(args.log), not args.no_json_mode))
    print("ready", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass


class LLMServer:
    """tests/llm_server.py as a subprocess on a free port, with its scripted answers and its request log."""

    def __init__(self, answers: list, workdir: Path, json_mode: bool = True) -> None:
        from servers import ServerProcess, free_port

        workdir.mkdir(parents=True, exist_ok=True)
        self.answers_file = workdir / "answers.json"
        self.answers_file.write_text(json.dumps(answers), encoding="utf-8")
        self.log = workdir / "requests.jsonl"
        self.log.write_text("", encoding="utf-8")
        self.port = free_port()
        self.base_url = f"http://127.0.0.1:{self.port}/v1"
        args = [
            sys.executable,
            str(Path(__file__)),
            "--port",
            str(self.port),
            "--answers",
            str(self.answers_file),
            "--log",
            str(self.log),
        ] + ([] if json_mode else ["--no-json-mode"])
        self.process = ServerProcess(args, ready="ready", timeout=30)

    def requests(self) -> list[dict]:
        """The requests received so far, in order."""
        return [json.loads(line) for line in self.log.read_text(encoding="utf-8").splitlines() if line.strip()]

    def stop(self) -> None:
        self.process.stop()


if __name__ == "__main__":
    main()
