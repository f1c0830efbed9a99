"""The LLM client that scene and task generation share: an OpenAI-compatible chat endpoint answering in JSON.

Settings come from options first, then from environment variables: ROBOLAB_LLM_BASE_URL, ROBOLAB_LLM_MODEL,
ROBOLAB_LLM_API_KEY (OPENAI_BASE_URL and OPENAI_API_KEY are used when the RoboLab ones are unset). Every round of a
conversation (what was sent, what came back, the feedback given) is kept in a `Transcript`, saved next to the
generated file.
"""

from __future__ import annotations

import json
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from robolab_ms.errors import RoboLabError


class GenerationError(RoboLabError):
    """An answer of the model that cannot be used (not JSON, not an object); `raw` is the text it sent."""

    def __init__(self, message: str, raw: str = "") -> None:
        self.raw = raw
        super().__init__(message)


@dataclass
class EndpointSettings:
    """Where and how to reach an OpenAI-compatible chat-completions endpoint."""

    base_url: str
    model: str
    api_key: str


def endpoint_settings(base_url: str | None, model: str | None, api_key: str | None) -> EndpointSettings:
    """The endpoint from options, else environment variables; a clear error naming what to set when one is missing."""
    env = os.environ
    resolved_url = base_url or env.get("ROBOLAB_LLM_BASE_URL") or env.get("OPENAI_BASE_URL")
    resolved_model = model or env.get("ROBOLAB_LLM_MODEL")
    resolved_key = api_key or env.get("ROBOLAB_LLM_API_KEY") or env.get("OPENAI_API_KEY")
    missing = []
    if not resolved_url:
        missing.append(
            "the endpoint: --base-url URL (or ROBOLAB_LLM_BASE_URL / OPENAI_BASE_URL), e.g. http://localhost:8000/v1"
        )
    if not resolved_model:
        missing.append("the model: --model NAME (or ROBOLAB_LLM_MODEL)")
    if not resolved_key:
        missing.append(
            "the key: --api-key KEY (or ROBOLAB_LLM_API_KEY / OPENAI_API_KEY); "
            "any non-empty text for a local server without keys"
        )
    if missing:
        raise RoboLabError(
            "--llm openai needs " + "; ".join(missing) + ". Or use --llm offline, which needs no endpoint."
        )
    return EndpointSettings(base_url=resolved_url, model=resolved_model, api_key=resolved_key)


class JsonModel(Protocol):
    """Anything that answers a conversation with one JSON object: the HTTP client or an offline generator."""

    name: str

    def ask_json(self, system: str, messages: list[dict[str, str]]) -> tuple[dict, str]: ...


_FENCE = re.compile(r"^\s*```[A-Za-z0-9_-]*\s*\n?(.*?)\n?\s*```\s*$", re.DOTALL)


def parse_json_object(raw: str) -> dict:
    """The JSON object in a model's answer, code fences removed; GenerationError (with the text) when there is none."""
    text = raw.strip()
    fenced = _FENCE.match(text)
    if fenced:
        text = fenced.group(1).strip()
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        # Some models wrap the object in prose: take the outermost braces as a last try.
        start, end = text.find("{"), text.rfind("}")
        value = None
        if 0 <= start < end:
            try:
                value = json.loads(text[start : end + 1])
            except json.JSONDecodeError:
                value = None
        if value is None:
            raise GenerationError(
                f"the answer is not JSON ({exc.msg} at line {exc.lineno} column {exc.colno}); "
                "answer with one JSON object and nothing else",
                raw,
            ) from None
    if not isinstance(value, dict):
        raise GenerationError(
            f"the answer is JSON but a {type(value).__name__}, not an object; answer with one JSON object ({{...}})",
            raw,
        )
    return value


class ChatClient:
    """A chat-completions client (the openai package) that asks for JSON objects."""

    def __init__(self, settings: EndpointSettings, timeout: float = 120.0) -> None:
        from openai import OpenAI

        self.settings = settings
        self.name = f"openai:{settings.model}@{settings.base_url}"
        self._client = OpenAI(base_url=settings.base_url, api_key=settings.api_key, timeout=timeout, max_retries=1)
        self._json_mode = True  # switched off when the server refuses response_format

    def ask_json(self, system: str, messages: list[dict[str, str]]) -> tuple[dict, str]:
        """Send the system prompt and the conversation; return the answer's JSON object and its raw text."""
        import openai

        request = [{"role": "system", "content": system}, *messages]
        try:
            completion = self._create(request)
        except openai.APIConnectionError as exc:
            raise RoboLabError(
                f"cannot reach the LLM endpoint {self.settings.base_url}: {exc}. "
                "Check --base-url and that the server runs, or use --llm offline"
            ) from None
        except openai.AuthenticationError as exc:
            raise RoboLabError(
                f"the LLM endpoint {self.settings.base_url} refused the key: {exc}. "
                "Check --api-key / ROBOLAB_LLM_API_KEY"
            ) from None
        except openai.NotFoundError as exc:
            raise RoboLabError(
                f"the LLM endpoint {self.settings.base_url} does not know model "
                f"'{self.settings.model}' or the path: {exc}. Check --model and --base-url "
                "(it usually ends in /v1)"
            ) from None
        except openai.APIError as exc:
            raise RoboLabError(f"the LLM endpoint {self.settings.base_url} failed: {exc}") from None
        if not completion.choices:
            raise GenerationError("the endpoint answered without a choice", "")
        raw = completion.choices[0].message.content or ""
        return parse_json_object(raw), raw

    def _create(self, request: list[dict[str, str]]) -> Any:
        import openai

        if self._json_mode:
            try:
                return self._client.chat.completions.create(
                    model=self.settings.model, messages=request, response_format={"type": "json_object"}
                )
            except openai.BadRequestError as exc:
                if "response_format" not in str(exc) and "json" not in str(exc).lower():
                    raise
                self._json_mode = False  # the server does not take response_format: ask in plain text
        return self._client.chat.completions.create(model=self.settings.model, messages=request)


@dataclass
class Transcript:
    """Every round of a generation: the messages sent, the raw answer, and the feedback it got."""

    kind: str  # "scene" or "task"
    prompt: str
    backend: str
    system: str = ""
    rounds: list[dict[str, Any]] = field(default_factory=list)
    outcome: str = ""
    started: float = field(default_factory=time.time)

    def record(self, messages: list[dict[str, str]], raw: str, feedback: list[str] | None = None, **extra: Any) -> None:
        """One round: the conversation as sent (without the system prompt), the raw answer, the feedback to it."""
        self.rounds.append(
            {
                "round": len(self.rounds) + 1,
                "messages": [dict(m) for m in messages],
                "answer": raw,
                "feedback": list(feedback or []),
                **extra,
            }
        )

    def add_feedback(self, feedback: list[str]) -> None:
        """Feedback found after the round was recorded (for example by the physics check)."""
        if self.rounds:
            self.rounds[-1]["feedback"].extend(feedback)

    @staticmethod
    def path_for(output: str | Path) -> Path:
        """Where the transcript of OUTPUT goes: next to it, OUTPUT's stem + '.transcript.json'."""
        output = Path(output)
        return output.with_name(output.stem + ".transcript.json")

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "prompt": self.prompt,
            "backend": self.backend,
            "outcome": self.outcome,
            "seconds": round(time.time() - self.started, 3),
            "system": self.system,
            "rounds": self.rounds,
        }

    def save(self, output: str | Path) -> Path:
        """Write the transcript next to OUTPUT; returns its path."""
        path = self.path_for(output)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
        return path


def add_endpoint_arguments(parser: Any) -> None:
    """The options every `robolab generate` command shares: the backend and the endpoint's settings."""
    parser.add_argument(
        "--llm",
        choices=("openai", "offline"),
        default="offline",
        help="openai: an OpenAI-compatible chat endpoint (--base-url, --model, --api-key or "
        "ROBOLAB_LLM_BASE_URL / ROBOLAB_LLM_MODEL / ROBOLAB_LLM_API_KEY); offline: the deterministic "
        "generator, no network (default)",
    )
    parser.add_argument(
        "--base-url",
        help="the endpoint, e.g. http://localhost:8000/v1 (default $ROBOLAB_LLM_BASE_URL, then $OPENAI_BASE_URL)",
    )
    parser.add_argument("--model", help="the model name the endpoint serves (default $ROBOLAB_LLM_MODEL)")
    parser.add_argument("--api-key", help="the endpoint's key (default $ROBOLAB_LLM_API_KEY, then $OPENAI_API_KEY)")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds to wait for an answer (default 120)")


def chat_client_from_args(args: Any) -> ChatClient:
    """The HTTP client for `--llm openai` and its options."""
    return ChatClient(endpoint_settings(args.base_url, args.model, args.api_key), timeout=args.timeout)
