"""The GR00T client: NVIDIA GR00T policies served for DROID over ZMQ request/reply with msgpack.

Each query is `{"endpoint": "get_action", "data": {"observation": observation, "options": null}}` (GR00T N1.6's
policy server, the default) or `{"endpoint": "get_action", "data": observation}` (N1.5's inference service,
`--gr00t-version n1.5`), with numpy arrays packed as `.npy` bytes inside msgpack
(`{"__ndarray_class__": true, "as_npy": ...}`). The observation:

    video.exterior_image_1_left, video.wrist_image_left   uint8 (1, 1, 180, 320, 3): batch, time, H, W, RGB;
                                                           resized without padding (stretched) when needed
    state.joint_position (1, 1, 7), state.gripper_position (1, 1, 1)   float32, 0 open to 1 closed
    state.eef_9d (1, 1, 9)         gripper position (m) and 6-D rotation in the robot frame (DROID's convention)
    annotation.language.language_instruction   [instruction]

The reply holds `action.joint_position` (1, H, 7) and `action.gripper_position` (1, H, 1) (also accepted: the keys
without `action.`, no batch dimension, or an `[actions, info]` pair as newer GR00T servers send). A reply with
`error` is a server error. `ping` checks the server before any episode; its answer is the recorded metadata.
"""

from __future__ import annotations

import io
import time
from typing import Any

import numpy as np

from robolab_ms.policies import PolicyConnectionLost, PolicyReplyError, PolicyTimeout, PolicyUnavailableError
from robolab_ms.policies.remote import ChunkedPolicy, check_chunk, probe_server

IMAGE_HEIGHT, IMAGE_WIDTH = 180, 320
ROBOLAB_KEY_PREFIX = "robolab."
# DROID's end-effector frame in GR00T's training data differs from the gripper frame by this fixed rotation
# (post-multiplied); the 6-D rotation is the first two rows of the corrected matrix.
DROID_EEF_CORRECTION = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
PING_TIMEOUT = 5.0  # s
VERSIONS = ("n1.6", "n1.5")


# ---------------------------------------------------------------------------------------------------- wire format
def _encode(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise TypeError("object arrays cannot be sent to a GR00T server")
        buffer = io.BytesIO()
        np.save(buffer, value, allow_pickle=False)
        return {"__ndarray_class__": True, "as_npy": buffer.getvalue()}
    if isinstance(value, np.generic):
        return value.item()
    return value


def _decode(value: dict) -> Any:
    if "__ndarray_class__" in value:
        return np.load(io.BytesIO(value["as_npy"]), allow_pickle=False)
    return value


def pack(message: Any) -> bytes:
    """A message in GR00T's wire format (msgpack, numpy arrays as .npy bytes)."""
    import msgpack

    return msgpack.packb(message, default=_encode)


def unpack(data: bytes) -> Any:
    import msgpack

    return msgpack.unpackb(data, object_hook=_decode)


# ---------------------------------------------------------------------------------------------------- observations
def eef_9d(pose: np.ndarray) -> np.ndarray:
    """(E, 7) position + quaternion (w, x, y, z) in the robot frame -> (E, 9) position + DROID 6-D rotation."""
    pose = np.asarray(pose, dtype=np.float64).reshape(-1, 7)
    w, x, y, z = (pose[:, i] / np.linalg.norm(pose[:, 3:], axis=1) for i in range(3, 7))
    rotation = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
    six = (rotation @ DROID_EEF_CORRECTION)[:, :2, :].reshape(-1, 6)
    return np.concatenate([pose[:, :3], six], axis=1).astype(np.float32)


def _resize(image: np.ndarray) -> np.ndarray:
    if image.shape[:2] == (IMAGE_HEIGHT, IMAGE_WIDTH):
        return image
    import cv2

    return cv2.resize(image, (IMAGE_WIDTH, IMAGE_HEIGHT), interpolation=cv2.INTER_AREA)


def droid_to_gr00t(observation: dict[str, Any]) -> dict[str, Any]:
    """GR00T's DROID request data for one DROID observation (batched arrays from DroidObservation)."""

    def video(key: str) -> np.ndarray:
        return _resize(np.asarray(observation[key])[0]).astype(np.uint8)[None, None]

    def state(value: Any) -> np.ndarray:
        return np.asarray(value, dtype=np.float32)[0][None, None]

    return {
        "video.exterior_image_1_left": video("exterior_image_1_left"),
        "video.wrist_image_left": video("wrist_image_left"),
        "state.joint_position": state(observation["joint_position"]),
        "state.gripper_position": state(observation["gripper_position"]),
        "state.eef_9d": eef_9d(np.asarray(observation["eef_pose"])[:1])[None],
        "annotation.language.language_instruction": [str(observation["prompt"])],
    }


def gr00t_request_to_droid(data: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """GR00T request data (either version) -> (DROID observation with a leading env dimension, robolab episode
    fields)."""
    if isinstance(data.get("observation"), dict):
        data = data["observation"]
    observation: dict[str, Any] = {}
    episode: dict[str, Any] = {}
    for key, value in data.items():
        if key.startswith("video."):
            observation[key.removeprefix("video.")] = np.asarray(value)[:, -1]
        elif key.startswith("state."):
            observation[key.removeprefix("state.")] = np.asarray(value)[:, -1]
        elif key.startswith(ROBOLAB_KEY_PREFIX):
            episode[key.removeprefix(ROBOLAB_KEY_PREFIX)] = value
    instruction = data.get("annotation.language.language_instruction", [""])
    if isinstance(instruction, (list, tuple)):
        instruction = instruction[0] if instruction else ""
    observation["prompt"] = str(instruction)
    return observation, episode


def _reply_part(reply: dict[str, Any], name: str, width: int, source: str) -> np.ndarray:
    for key in (f"action.{name}", name):
        if key in reply:
            value = reply[key]
            break
    else:
        raise PolicyReplyError(f"{source}: the reply has no 'action.{name}' (it holds {sorted(reply)})")
    if not isinstance(value, np.ndarray):
        raise PolicyReplyError(f"{source}: 'action.{name}' is a {type(value).__name__}, not an array")
    if value.dtype.kind != "f":
        raise PolicyReplyError(f"{source}: 'action.{name}' has dtype {value.dtype}; expected floating point")
    if value.ndim == 3 and value.shape[0] == 1:
        value = value[0]  # batch of one
    if width == 1 and value.ndim == 1:
        value = value[:, None]
    if value.ndim != 2 or value.shape[1] != width:
        raise PolicyReplyError(f"{source}: 'action.{name}' has shape {np.shape(reply[key])}; expected (1, H, {width})")
    return value


def gr00t_reply_chunk(reply: Any, source: str) -> np.ndarray:
    """The (H, 8) chunk of a GR00T reply, or PolicyReplyError saying what is wrong with it."""
    if isinstance(reply, (list, tuple)) and len(reply) == 2 and isinstance(reply[0], dict):
        reply = reply[0]  # (actions, info)
    if not isinstance(reply, dict):
        raise PolicyReplyError(f"{source}: the reply is a {type(reply).__name__}, not a dict of actions")
    if "error" in reply:
        raise PolicyReplyError(f"{source}: the policy server reported an error: {reply['error']}")
    joints = _reply_part(reply, "joint_position", 7, source)
    gripper = _reply_part(reply, "gripper_position", 1, source)
    if len(joints) != len(gripper):
        raise PolicyReplyError(f"{source}: {len(joints)} joint targets but {len(gripper)} gripper values")
    return check_chunk(np.concatenate([joints, gripper], axis=1).astype(np.result_type(joints, gripper)), source)


# ---------------------------------------------------------------------------------------------------- client
class Gr00tPolicy(ChunkedPolicy):
    """A DROID policy behind a GR00T inference server (ZMQ REQ/REP, msgpack)."""

    name = "gr00t"
    needs_images = True

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 5555,
        open_loop_horizon: int = 8,
        timeout: float = 60.0,
        version: str = "n1.6",
        realtime: bool = False,
    ) -> None:
        super().__init__(open_loop_horizon, realtime)
        if version not in VERSIONS:
            raise PolicyUnavailableError(f"--gr00t-version must be one of {', '.join(VERSIONS)}, got {version!r}")
        self.host, self.port, self.timeout, self.version = host, port, timeout, version
        self.endpoint = f"tcp://{host}:{port}"
        self._context: Any = None
        self._socket: Any = None
        self._monitor: Any = None
        self._metadata: dict[str, Any] = {}

    def connect(self) -> None:
        import zmq

        self.close()
        self.needs_reconnect = True  # until the server answers
        probe_server(
            self.host,
            self.port,
            "GR00T",
            f"`robolab serve --protocol gr00t --policy random --port {self.port}` to check the set-up here, "
            f"or GR00T's `python scripts/inference_service.py --server --port {self.port}` (DROID "
            "embodiment) on a GPU machine",
        )
        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.REQ)
        self._socket.setsockopt(zmq.LINGER, 0)
        self._monitor = self._socket.get_monitor_socket(zmq.EVENT_DISCONNECTED)
        self._socket.connect(self.endpoint)
        try:
            reply = self._call({"endpoint": "ping"}, min(self.timeout, PING_TIMEOUT))
        except (PolicyTimeout, PolicyConnectionLost) as exc:
            self.close()
            raise PolicyUnavailableError(
                f"the server at {self.host}:{self.port} does not answer GR00T's ping "
                f"({exc}): is it a GR00T policy server?"
            ) from None
        self._metadata = dict(reply) if isinstance(reply, dict) else {"ping": reply}
        self._metadata.setdefault("protocol", "gr00t")
        self._metadata.setdefault("request_format", self.version)
        self.needs_reconnect = False

    def metadata(self) -> dict[str, Any]:
        return self._metadata

    def command_line_options(self) -> list[str]:
        return [*super().command_line_options(), "--gr00t-version", self.version]

    def _call(self, request: dict[str, Any], timeout: float) -> Any:
        import zmq
        from zmq.utils.monitor import recv_monitor_message

        self._socket.send(pack(request))
        poller = zmq.Poller()
        poller.register(self._socket, zmq.POLLIN)
        poller.register(self._monitor, zmq.POLLIN)
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.needs_reconnect = True  # a REQ socket without its reply cannot send again
                raise PolicyTimeout(
                    f"the GR00T server at {self.endpoint} did not answer within {timeout:g} s (--timeout)"
                )
            events = dict(poller.poll(remaining * 1000.0))
            if self._socket in events:
                return unpack(self._socket.recv())
            if self._monitor in events and recv_monitor_message(self._monitor)["event"] == zmq.EVENT_DISCONNECTED:
                self.needs_reconnect = True
                raise PolicyConnectionLost(f"the GR00T server at {self.endpoint} closed the connection")

    def query(self, observation: dict[str, Any]) -> np.ndarray:
        if self._socket is None:
            raise PolicyConnectionLost(f"not connected to the GR00T server at {self.endpoint}")
        data = droid_to_gr00t(observation)
        if self._metadata.get("server") == "robolab_ms":
            data.update({ROBOLAB_KEY_PREFIX + key: value for key, value in self.episode_fields().items()})
        try:
            envelope = {"observation": data, "options": None} if self.version == "n1.6" else data
            reply = self._call({"endpoint": "get_action", "data": envelope}, self.timeout)
        except Exception as exc:
            if isinstance(exc, (PolicyTimeout, PolicyConnectionLost)):
                raise
            self.needs_reconnect = True
            raise PolicyReplyError(f"unreadable reply from {self.endpoint}: {type(exc).__name__}: {exc}") from None
        return gr00t_reply_chunk(reply, f"reply from {self.endpoint}")

    def close(self) -> None:
        for sock in (self._monitor, self._socket):
            if sock is not None:
                sock.close(linger=0)
        if self._context is not None:
            self._context.term()
        self._context = self._socket = self._monitor = None
