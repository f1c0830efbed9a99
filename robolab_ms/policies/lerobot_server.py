"""A LeRobot policy served over openpi's websocket protocol, for `robolab eval --policy openpi`.

LeRobot 0.5 and later need Python 3.12 and numpy 2, so LeRobot policies run in their own environment
(`make lerobot-env`, see docs/policies.md) and reach the benchmark through this server. It imports numpy, torch,
lerobot, websockets and msgpack, and from robolab_ms only light modules (errors, the LeRobot key names, the action
size; their gymnasium is a LeRobot dependency too), never the simulator:

    PYTHONPATH=. .venv-lerobot/bin/python -m robolab_ms.policies.lerobot_server --checkpoint DIR --port 8000
    PYTHONPATH=. .venv-lerobot/bin/python -m robolab_ms.policies.lerobot_server --policy-type act --port 8000

The policy is any LeRobot `PreTrainedPolicy`: a checkpoint folder on this machine (`from_pretrained`, with the
pre- and post-processors saved beside it; nothing is fetched from a hub), or a policy type built from its config
class with random weights and DROID's features (for checking a set-up). Each openpi request (DROID's keys, see
robolab_ms/policies/openpi.py) becomes the batch LeRobot's own evaluation feeds its pre-processor: every image
feature float32 (1, 3, H, W) in [0, 1] at the feature's size, the state float32 (1, D), `task` [prompt]. Then the
pre-processor, `select_action` until the policy's action queue (`n_action_steps`) is spent, and the
post-processor for each action, as LeRobot's evaluation loop does; the reply's `actions` is that chunk mapped to
DROID's 8-D actions (7 absolute joint targets and the gripper).

Metadata says `server: robolab_ms`, so our client also sends the episode's task, seed and step (`robolab/*` keys):
the policy and its processors are reset, and torch seeded, when an episode starts.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import os
import sys
import threading
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script file: import from its checkout, not from its own folder
    sys.path[0] = str(Path(__file__).resolve().parents[2])  # (whose lerobot.py would hide LeRobot)

import numpy as np

from robolab_ms.errors import RoboLabError
from robolab_ms.policies.lerobot import CAMERA_KEYS
from robolab_ms.policies.remote import ACTION_DIM

log = logging.getLogger("robolab_ms.lerobot_server")

IMAGE_SOURCES = ("exterior_image_1_left", "wrist_image_left")  # the images of an openpi DROID request
VECTOR_SOURCES = {"joint_position": 7, "gripper_position": 1}  # and its vectors, with their lengths
DEFAULT_IMAGE_SIZE = (224, 224)
READY = "lerobot_server: serving"


class RequestError(Exception):
    """A request the policy cannot be fed from (a missing key, a wrong shape); sent back as the error text."""


# ------------------------------------------------------------------------------------------ the wire format
def _encode_numpy(value: Any) -> Any:
    """msgpack hook: numpy arrays and scalars in openpi's msgpack-numpy layout."""
    if isinstance(value, (np.ndarray, np.generic)) and value.dtype.kind in "VOc":
        raise TypeError(f"cannot send numpy dtype {value.dtype}")
    if isinstance(value, np.ndarray):
        return {b"__ndarray__": True, b"data": value.tobytes(), b"dtype": value.dtype.str, b"shape": value.shape}
    if isinstance(value, np.generic):
        return {b"__npgeneric__": True, b"data": value.item(), b"dtype": value.dtype.str}
    return value


def _decode_numpy(mapping: dict) -> Any:
    if b"__ndarray__" in mapping:
        return np.frombuffer(mapping[b"data"], dtype=np.dtype(mapping[b"dtype"])).reshape(mapping[b"shape"])
    if b"__npgeneric__" in mapping:
        return np.dtype(mapping[b"dtype"]).type(mapping[b"data"])
    return mapping


def pack(message: Any) -> bytes:
    import msgpack

    return msgpack.packb(message, default=_encode_numpy)


def unpack(frame: bytes) -> Any:
    import msgpack

    return msgpack.unpackb(frame, object_hook=_decode_numpy)


# ------------------------------------------------------------------------------------------ the policy
@dataclass
class ServedPolicy:
    """A LeRobot policy with its processors, what feeds each of its inputs, and how its action becomes DROID's."""

    policy: Any
    preprocessor: Any
    postprocessor: Any
    source: str  # the checkpoint folder, or "random weights"
    device: str
    sources: dict[str, list[str]]  # policy input feature -> request keys (images: one; vectors: concatenated)
    action_indices: list[int] | None  # which of the policy's action values fill DROID's 8
    warned: set[str] = field(default_factory=set)

    @property
    def config(self) -> Any:
        return self.policy.config

    @property
    def action_dim(self) -> int:
        return int(self.config.output_features["action"].shape[0])

    @property
    def actions_per_reply(self) -> int:
        """select_action calls per request: the policy's action queue, spent before it looks again."""
        return max(1, int(getattr(self.config, "n_action_steps", 1) or 1))

    def metadata(self) -> dict[str, Any]:
        import lerobot
        import torch

        return {
            "server": "robolab_ms",
            "protocol": "openpi",
            "policy": f"lerobot-{self.config.type}",
            "policy_type": self.config.type,
            "policy_source": self.source,
            "action_horizon": self.actions_per_reply,
            "action_dim": ACTION_DIM,
            "policy_action_dim": self.action_dim,
            "inputs": {name: "+".join(keys) for name, keys in self.sources.items()},
            "lerobot_version": getattr(lerobot, "__version__", "unknown"),
            "torch_version": torch.__version__,
            "device": self.device,
        }

    def reset(self, seed: int | None) -> None:
        """A new episode: the policy's queues and the processors' state cleared, torch seeded."""
        import torch

        if seed is not None:
            torch.manual_seed(seed)
            np.random.seed(seed % 2**32)
        self.policy.reset()
        for pipeline in (self.preprocessor, self.postprocessor):
            pipeline.reset()

    def batch(self, request: dict[str, Any]) -> dict[str, Any]:
        """The raw batch for one openpi request, as LeRobot's evaluation hands it to the pre-processor."""
        import torch

        batch: dict[str, Any] = {}
        for name, keys in self.sources.items():
            feature = self.config.input_features[name]
            if keys[0] in IMAGE_SOURCES:
                image = _request_array(request, keys[0])
                if image.ndim != 3 or image.shape[-1] != 3 or image.dtype != np.uint8:
                    raise RequestError(
                        f"'observation/{keys[0]}' is {image.dtype} {image.shape}; expected uint8 (H, W, 3)"
                    )
                batch[name] = image_to_feature(image, tuple(feature.shape)).to(self.device)
            else:
                vector = np.concatenate([_request_array(request, key).astype(np.float32).reshape(-1) for key in keys])
                size = int(np.prod(feature.shape))
                if vector.size != size:
                    self._warn_once(
                        name,
                        f"'{name}' takes {size} values and {'+'.join(keys)} has {vector.size}: "
                        f"{'padded with zeros' if vector.size < size else 'cut'} to fit (map it "
                        "with --map)",
                    )
                    vector = np.pad(vector, (0, max(0, size - vector.size)))[:size]
                batch[name] = torch.from_numpy(vector.reshape(1, *feature.shape)).to(self.device)
        batch["task"] = [str(request.get("prompt", ""))]
        return batch

    def chunk(self, batch: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
        """(the post-processed actions (H, policy action dim), the same as DROID actions (H, 8))."""
        import torch

        processed = self.preprocessor(batch)
        actions = []
        with torch.inference_mode():
            for _ in range(self.actions_per_reply):
                action = self.postprocessor(self.policy.select_action(processed))
                actions.append(action.detach().to("cpu", torch.float32).numpy().reshape(-1))
        raw = np.stack(actions)
        return raw, self.to_droid(raw)

    def to_droid(self, actions: np.ndarray) -> np.ndarray:
        if self.action_indices is not None:
            return np.ascontiguousarray(actions[:, self.action_indices], dtype=np.float32)
        if actions.shape[1] != ACTION_DIM:
            self._warn_once(
                "action",
                f"the policy's action has {actions.shape[1]} values and DROID's has "
                f"{ACTION_DIM} (7 joint targets, gripper): "
                f"{'padded with zeros' if actions.shape[1] < ACTION_DIM else 'cut'} to "
                f"{ACTION_DIM}; choose them with --action-indices",
            )
            actions = np.pad(actions, ((0, 0), (0, max(0, ACTION_DIM - actions.shape[1]))))
        return np.ascontiguousarray(actions[:, :ACTION_DIM], dtype=np.float32)

    def check_sizes(self) -> None:
        """Warn, before serving, about a state or an action whose length differs from what DROID has."""
        for name, keys in self.sources.items():
            if keys[0] not in IMAGE_SOURCES:
                size, given = int(np.prod(self.config.input_features[name].shape)), sum(VECTOR_SOURCES[k] for k in keys)
                if size != given:
                    self._warn_once(
                        name,
                        f"'{name}' takes {size} values and {'+'.join(keys)} has {given}: "
                        f"{'padded with zeros' if given < size else 'cut'} to fit (map it with "
                        "--map)",
                    )
        if self.action_indices is None and self.action_dim != ACTION_DIM:
            self.to_droid(np.zeros((1, self.action_dim), np.float32))

    def _warn_once(self, key: str, message: str) -> None:
        if key not in self.warned:
            self.warned.add(key)
            print(f"lerobot_server: warning: {message}", flush=True)


def _request_array(request: dict[str, Any], key: str) -> np.ndarray:
    value = request.get(f"observation/{key}")
    if value is None:
        keys = sorted(k for k in request if isinstance(k, str))
        raise RequestError(f"the request has no 'observation/{key}' (it holds {keys})")
    return np.asarray(value)


def image_to_feature(image: np.ndarray, shape: tuple[int, ...]) -> Any:
    """uint8 (H, W, 3) -> float32 (1, C, h, w) in [0, 1] for a feature of shape (C, h, w).

    openpi's clients pad their images to a square (224x224): the black border is taken off, then the picture is
    scaled to fit (h, w) and padded with black, so that it keeps its aspect ratio. An image that already has the
    feature's size is passed as it is."""
    import torch
    from torch.nn import functional

    channels, height, width = shape
    if channels != 3:
        raise RequestError(f"an image feature of shape {shape}: only 3-channel (RGB) images can be fed from DROID's")
    tensor = torch.from_numpy(np.array(image)).permute(2, 0, 1)[None].to(torch.float32) / 255.0
    if image.shape[:2] == (height, width):
        return tensor
    rows, cols = np.flatnonzero(image.any(axis=(1, 2))), np.flatnonzero(image.any(axis=(0, 2)))
    if rows.size and cols.size:
        tensor = tensor[:, :, rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    scale = min(height / tensor.shape[2], width / tensor.shape[3])
    size = (max(1, round(tensor.shape[2] * scale)), max(1, round(tensor.shape[3] * scale)))
    tensor = functional.interpolate(tensor, size=size, mode="bilinear", align_corners=False, antialias=True)
    top, left = (height - size[0]) // 2, (width - size[1]) // 2
    padded = torch.zeros((1, 3, height, width), dtype=torch.float32)
    padded[:, :, top : top + size[0], left : left + size[1]] = tensor.clamp(0.0, 1.0)
    return padded


def default_sources(input_features: dict[str, Any], mapping: dict[str, list[str]]) -> dict[str, list[str]]:
    """What feeds each input feature: --map first, then cameras by name (wrist / the other one) and the state
    from the joints and the gripper."""
    from lerobot.configs.types import FeatureType

    sources: dict[str, list[str]] = {}
    unknown = sorted(set(mapping) - set(input_features))
    if unknown:
        raise RoboLabError(
            f"--map {unknown[0]}=...: the policy has no input feature '{unknown[0]}'; its inputs are "
            f"{sorted(input_features)}"
        )
    cameras = [name for name, feature in input_features.items() if feature.type is FeatureType.VISUAL]
    unmapped_cameras = [name for name in cameras if name not in mapping]
    wrist = [name for name in unmapped_cameras if "wrist" in name]
    exterior = [name for name in unmapped_cameras if "wrist" not in name]
    if len(wrist) > 1 or len(exterior) > 1:
        raise RoboLabError(
            f"the policy takes cameras {cameras}, and an openpi DROID request carries two "
            f"images ({', '.join(IMAGE_SOURCES)}): say which feeds which with --map "
            "FEATURE=SOURCE"
        )
    for name, feature in input_features.items():
        if name in mapping:
            keys = mapping[name]
            is_image = feature.type is FeatureType.VISUAL
            allowed = IMAGE_SOURCES if is_image else tuple(VECTOR_SOURCES)
            bad = [key for key in keys if key not in allowed]
            if bad or (is_image and len(keys) != 1):
                takes = (
                    f"an image feature takes one of {' or '.join(allowed)}"
                    if is_image
                    else f"a vector feature takes {' + '.join(allowed)} (any of them)"
                )
                raise RoboLabError(f"--map {name}={'+'.join(keys)}: {takes}")
            sources[name] = keys
        elif feature.type is FeatureType.VISUAL:
            sources[name] = [IMAGE_SOURCES[1] if "wrist" in name else IMAGE_SOURCES[0]]
        elif feature.type is FeatureType.STATE:
            sources[name] = list(VECTOR_SOURCES)
        elif feature.type in (FeatureType.ENV,):
            raise RoboLabError(
                f"the policy's input '{name}' ({feature.type.name}, shape {tuple(feature.shape)}) has "
                "no counterpart in DROID's request: feed it with --map "
                f"{name}=joint_position+gripper_position (or a part of that)"
            )
    return sources


def parse_map(items: list[str]) -> dict[str, list[str]]:
    mapping: dict[str, list[str]] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise RoboLabError(
                f"--map {item!r}: write FEATURE=SOURCE or FEATURE=SOURCE+SOURCE, e.g. "
                "observation.images.top=exterior_image_1_left"
            )
        mapping[name.strip()] = [part.strip() for part in value.split("+")]
    return mapping


def parse_settings(items: list[str]) -> dict[str, Any]:
    """--set KEY=VALUE: VALUE as JSON where it parses (numbers, null, true, lists), else as a string."""
    settings: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise RoboLabError(f"--set {item!r}: write KEY=VALUE, e.g. n_action_steps=16")
        try:
            settings[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            settings[key.strip()] = value
    return settings


def _apply_settings(config: Any, settings: dict[str, Any]) -> None:
    import dataclasses

    names = {item.name for item in dataclasses.fields(config)}
    for key, value in settings.items():
        if key not in names:
            close = sorted(name for name in names if key.split("_")[0] in name)[:6]
            raise RoboLabError(
                f"--set {key}=...: {type(config).__name__} has no field '{key}'"
                + (f" (similar: {', '.join(close)})" if close else "")
            )
        current = getattr(config, key)
        setattr(config, key, tuple(value) if isinstance(current, tuple) and isinstance(value, list) else value)


def _device(requested: str) -> str:
    import torch

    if requested != "auto":
        return requested
    return "cuda" if torch.cuda.is_available() else "cpu"


def _stats(path: str | None) -> dict[str, dict[str, Any]] | None:
    if path is None:
        return None
    try:
        stats = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise RoboLabError(f"--stats {path}: cannot read it as JSON ({exc})") from None
    if not isinstance(stats, dict) or not all(isinstance(value, dict) for value in stats.values()):
        raise RoboLabError(f'--stats {path}: expected {{feature: {{"mean": [...], "std": [...], ...}}}}')
    return {
        name: {stat: np.asarray(values, dtype=np.float32) for stat, values in entry.items()}
        for name, entry in stats.items()
    }


def load_policy(args: argparse.Namespace) -> ServedPolicy:
    """The served policy from the command line: a checkpoint folder or a policy type with random weights."""
    settings = parse_settings(args.set)
    mapping = parse_map(args.map)
    if args.checkpoint:
        if not (Path(args.checkpoint) / "config.json").is_file():
            raise RoboLabError(
                f"--checkpoint {args.checkpoint}: no config.json there; give the folder LeRobot saved "
                "the policy in (e.g. outputs/train/.../checkpoints/last/pretrained_model)"
            )
        if args.stats:
            raise RoboLabError("--stats is for --policy-type; a checkpoint keeps its statistics in its processors")
    device = _device(args.device)
    what = f"--checkpoint {args.checkpoint}" if args.checkpoint else f"--policy-type {args.policy_type}"
    try:
        if args.checkpoint:
            policy, preprocessor, postprocessor = _from_checkpoint(Path(args.checkpoint), settings, device)
        else:
            policy, preprocessor, postprocessor = _from_config(args, settings, device)
    except RoboLabError:
        raise
    except Exception as exc:  # LeRobot's own errors: a version mismatch, a missing extra, a tokenizer not cached
        message = " ".join(str(exc).split())[:1500]
        raise RoboLabError(f"{what}: LeRobot could not build the policy: {type(exc).__name__}: {message}") from None
    policy.to(device)
    policy.eval()
    config = policy.config
    sources = default_sources(dict(config.input_features), mapping)
    indices = _action_indices(args.action_indices, int(config.output_features["action"].shape[0]))
    source = str(args.checkpoint) if args.checkpoint else "random weights"
    served = ServedPolicy(policy, preprocessor, postprocessor, source, device, sources, indices)
    served.check_sizes()
    return served


def _from_checkpoint(folder: Path, settings: dict[str, Any], device: str) -> tuple[Any, Any, Any]:
    """The policy and its saved processors, as LeRobot's evaluation loads them."""
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    config = PreTrainedConfig.from_pretrained(folder)
    _apply_settings(config, settings)
    config.device = device
    policy = get_policy_class(config.type).from_pretrained(folder, config=config)
    overrides = {"device_processor": {"device": device}}
    try:
        preprocessor, postprocessor = make_pre_post_processors(
            config, pretrained_path=str(folder), preprocessor_overrides=overrides, postprocessor_overrides=overrides
        )
    except FileNotFoundError as exc:
        raise RoboLabError(
            f"--checkpoint {folder}: no saved pre-/post-processor ({exc}); a checkpoint of an "
            "older LeRobot needs converting with lerobot's "
            "processor/migrate_policy_normalization.py"
        ) from None
    return policy, preprocessor, postprocessor


def _from_config(args: argparse.Namespace, settings: dict[str, Any], device: str) -> tuple[Any, Any, Any]:
    """A policy type built from its config class with DROID's features and random weights, and fresh processors.
    A pretrained vision backbone (a download) is off unless --set asks for one."""
    import dataclasses

    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors

    try:
        config = make_policy_config(args.policy_type, device=device)
    except ValueError:
        known = ", ".join(sorted(PreTrainedConfig.get_known_choices()))
        raise RoboLabError(f"--policy-type {args.policy_type}: not a LeRobot policy type; known: {known}") from None
    if "pretrained_backbone_weights" in {item.name for item in dataclasses.fields(config)}:
        settings = {"pretrained_backbone_weights": None, **settings}
    _apply_settings(config, settings)
    height, width = args.image_size
    image = PolicyFeature(type=FeatureType.VISUAL, shape=(3, height, width))
    config.input_features = {CAMERA_KEYS[key]: image for key in IMAGE_SOURCES}
    config.input_features["observation.state"] = PolicyFeature(type=FeatureType.STATE, shape=(ACTION_DIM,))
    config.output_features = {"action": PolicyFeature(type=FeatureType.ACTION, shape=(ACTION_DIM,))}
    config.validate_features()
    policy = get_policy_class(config.type)(config=config)
    overrides = {"device_processor": {"device": device}}
    preprocessor, postprocessor = make_pre_post_processors(
        config, dataset_stats=_stats(args.stats), preprocessor_overrides=overrides, postprocessor_overrides=overrides
    )
    return policy, preprocessor, postprocessor


def _action_indices(text: str | None, action_dim: int) -> list[int] | None:
    if text is None:
        return None
    try:
        indices = [int(part) for part in text.split(",")]
    except ValueError:
        indices = []
    if len(indices) != ACTION_DIM or not all(0 <= index < action_dim for index in indices):
        raise RoboLabError(
            f"--action-indices {text}: give {ACTION_DIM} comma-separated indices into the "
            f"policy's action (0 to {action_dim - 1}): 7 joint targets, then the gripper"
        )
    return indices


# ------------------------------------------------------------------------------------------ the server
def _summary(batch: dict[str, Any]) -> dict[str, Any]:
    """What a batch holds, per key: shape, dtype and value range (tensors) or the value (strings)."""
    summary: dict[str, Any] = {}
    for key, value in batch.items():
        if hasattr(value, "detach"):
            array = value.detach().to("cpu").float().numpy()
            summary[key] = {
                "shape": list(value.shape),
                "dtype": str(value.dtype).removeprefix("torch."),
                "min": float(array.min()),
                "max": float(array.max()),
                "mean": float(array.mean()),
            }
        else:
            summary[key] = value
    return summary


class Server:
    """Answers openpi requests with the served policy's chunks, one request at a time."""

    def __init__(self, served: ServedPolicy, log_inputs: str | None, log_actions: str | None) -> None:
        self.served = served
        self.log_inputs, self.log_actions = log_inputs, log_actions
        self.lock = threading.Lock()
        self.episode: tuple | None = None
        self.connections = 0

    def answer(self, connection_id: int, request: dict[str, Any]) -> np.ndarray:
        if not isinstance(request, dict):
            raise RequestError(f"a request is a msgpack map of DROID's keys, got {type(request).__name__}")
        robolab = {
            key.removeprefix("robolab/"): value
            for key, value in request.items()
            if isinstance(key, str) and key.startswith("robolab/")
        }
        key = (connection_id, *(robolab.get(name) for name in ("task", "instruction_variant", "robot", "seed")))
        with self.lock:  # one policy: requests of several clients are answered in turn
            if key != self.episode or robolab.get("step") == 0:
                seed = robolab.get("seed")
                self.served.reset(int(seed) if seed is not None else None)
                self.episode = key
            batch = self.served.batch(request)
            if self.log_inputs:
                logged = {"batch": _summary(batch), "inputs": self.served.metadata()["inputs"]}
                Path(self.log_inputs).write_text(json.dumps(logged, indent=1))
                self.log_inputs = None  # the first batch only
            raw, actions = self.served.chunk(batch)
            if self.log_actions:
                line = {
                    **{name: _plain(robolab.get(name)) for name in ("task", "seed", "step")},
                    "policy_actions": raw.tolist(),
                    "actions": actions.tolist(),
                }
                with open(self.log_actions, "a") as handle:
                    handle.write(json.dumps(line) + "\n")
        return actions

    async def handle(self, connection: Any) -> None:
        import websockets
        import websockets.frames

        self.connections += 1
        connection_id = self.connections
        log.info("client %s connected", connection.remote_address)
        try:
            await connection.send(pack(self.served.metadata()))
            while True:
                message = await connection.recv()
                start = time.perf_counter()
                try:
                    if isinstance(message, str):
                        raise RequestError("expected a binary msgpack frame, got text")
                    actions = await asyncio.to_thread(self.answer, connection_id, unpack(message))
                except Exception as exc:  # sent back as openpi's servers do: a text frame, then the connection closes
                    text = f"{type(exc).__name__}: {exc}" if isinstance(exc, RequestError) else traceback.format_exc()
                    log.error("request failed: %s", text)
                    await connection.send(text)
                    await connection.close(code=websockets.frames.CloseCode.INTERNAL_ERROR, reason="policy error")
                    return
                infer_ms = (time.perf_counter() - start) * 1000.0
                await connection.send(pack({"actions": actions, "server_timing": {"infer_ms": infer_ms}}))
        except websockets.ConnectionClosed:
            pass
        finally:
            log.info("client %s gone", connection.remote_address)

    async def serve(self, host: str, port: int) -> None:
        import http

        import websockets.asyncio.server as ws_server

        def health(connection: Any, request: Any) -> Any:
            return connection.respond(http.HTTPStatus.OK, "OK\n") if request.path == "/healthz" else None

        async with ws_server.serve(
            self.handle, host, port, compression=None, max_size=None, process_request=health
        ) as server:
            bound = next(iter(server.sockets)).getsockname()[1]
            config = self.served.config
            print(
                f"{READY} {config.type} ({self.served.source}, {self.served.device}) on ws://{host}:{bound}, "
                f"{self.served.actions_per_reply} actions per reply; evaluate with `robolab eval --policy openpi "
                f"--host {host if host not in ('0.0.0.0', '') else '127.0.0.1'} --port {bound} --task ...`; "
                "Ctrl-C stops",
                flush=True,
            )
            await server.serve_forever()


def _plain(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def _image_size(text: str) -> tuple[int, int]:
    try:
        height, width = (int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: write HEIGHT,WIDTH, e.g. 180,320") from None
    return height, width


def parser() -> argparse.ArgumentParser:
    parse = argparse.ArgumentParser(
        prog="python -m robolab_ms.policies.lerobot_server",
        description="Serve a LeRobot policy over openpi's websocket protocol, for `robolab eval --policy openpi`. "
        "Runs in the LeRobot environment (make lerobot-env); see docs/policies.md.",
    )
    which = parse.add_mutually_exclusive_group(required=True)
    which.add_argument(
        "--checkpoint",
        metavar="DIR",
        help="a LeRobot checkpoint folder on this machine (config.json, "
        "model.safetensors, policy_preprocessor.json ...)",
    )
    which.add_argument(
        "--policy-type",
        metavar="TYPE",
        help="build this policy type (act, diffusion, ...) from its "
        "config class with random weights and DROID's features (no pretrained vision backbone "
        "unless --set pretrained_backbone_weights=... asks for one)",
    )
    parse.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="set a field of the policy's config (VALUE as JSON where it parses), e.g. "
        "n_action_steps=16 or num_inference_steps=10; repeatable",
    )
    parse.add_argument(
        "--image-size",
        type=_image_size,
        default=DEFAULT_IMAGE_SIZE,
        metavar="H,W",
        help="--policy-type: the size of its image features (default: 224,224)",
    )
    parse.add_argument(
        "--stats",
        metavar="FILE",
        help="--policy-type: normalization statistics, JSON "
        "{feature: {mean, std, min, max: [...]}} (default: none, values pass unnormalized)",
    )
    parse.add_argument(
        "--map",
        action="append",
        default=[],
        metavar="FEATURE=SOURCE[+SOURCE]",
        help=f"feed a policy input from the request: images from one of {', '.join(IMAGE_SOURCES)}; "
        f"vectors from {' + '.join(VECTOR_SOURCES)} (concatenated); repeatable. Default: a camera "
        "named *wrist* from the wrist image, another from the exterior one, the state from the "
        "joints and the gripper",
    )
    parse.add_argument(
        "--action-indices",
        metavar="I,I,I,I,I,I,I,I",
        help="which 8 values of the policy's action are DROID's 7 joint targets and gripper "
        "(default: the first 8, zero-padded when fewer)",
    )
    parse.add_argument("--device", default="auto", help="torch device (default: cuda when there is one, else cpu)")
    parse.add_argument("--host", default="0.0.0.0", help="address to listen on (default: 0.0.0.0)")
    parse.add_argument("--port", type=int, default=8000, help="port (default: 8000; 0 picks a free one)")
    parse.add_argument(
        "--log-inputs",
        metavar="FILE",
        help="write the first batch fed into the pre-processor (keys, shapes, dtypes, value ranges) as JSON",
    )
    parse.add_argument(
        "--log-actions",
        metavar="FILE",
        help="append one JSON line per reply: task, seed, step, the post-processed actions and the DROID actions sent",
    )
    return parse


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    os.environ.setdefault("HF_HUB_OFFLINE", "1")  # a local checkout or random weights: never a download
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    try:
        served = load_policy(args)
    except RoboLabError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        asyncio.run(Server(served, args.log_inputs, args.log_actions).serve(args.host, args.port))
    except OSError as exc:
        print(
            f"error: cannot listen on {args.host}:{args.port}: {exc.strerror or exc}; is another server running "
            "there? Choose another --port",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
