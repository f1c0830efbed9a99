"""The openpi client: DROID policies (pi0, pi0-FAST, pi0.5) served by openpi's websocket server.

Talks through the `openpi-client` package: `WebsocketClientPolicy` (msgpack-numpy frames; the server sends its
metadata on connect) and `image_tools.resize_with_pad`. Each query sends DROID's keys:

    observation/exterior_image_1_left, observation/wrist_image_left   uint8 224x224x3, resized with padding
    observation/joint_position (7,) float32 rad, observation/gripper_position (1,) float32 (0 open, 1 closed)
    prompt                                                              the task instruction

and reads `actions` (H, 8): 7 absolute joint targets and the gripper (> 0.5 closes). A robolab_ms server
(`robolab serve`, metadata `server: robolab_ms`) also gets `robolab/*` keys: task, variant, robot, seed and step,
with which it seeds and positions the policy it serves.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from robolab_ms.policies import PolicyConnectionLost, PolicyReplyError, PolicyTimeout, PolicyUnavailableError
from robolab_ms.policies.remote import ChunkedPolicy, check_chunk, probe_server

IMAGE_SIZE = 224
OPENPI_KEY_PREFIX = "observation/"  # openpi's DROID keys: observation/<DROID key>
ROBOLAB_KEY_PREFIX = "robolab/"


def droid_request(observation: dict[str, Any]) -> dict[str, Any]:
    """openpi's DROID request for one DROID observation of environment 0 (batched arrays from DroidObservation):
    the images resized with padding to 224x224 uint8, joint and gripper positions, the prompt. An observation
    made without images (DroidObservation(images=False)) gives a request without them."""
    from openpi_client import image_tools

    from robolab_ms.envs.droid_obs import EXTERIOR_IMAGE, WRIST_IMAGE

    request: dict[str, Any] = {}
    for key in (EXTERIOR_IMAGE, WRIST_IMAGE):
        if key in observation:
            resized = image_tools.resize_with_pad(np.asarray(observation[key])[0], IMAGE_SIZE, IMAGE_SIZE)
            request[OPENPI_KEY_PREFIX + key] = image_tools.convert_to_uint8(resized)
    request[OPENPI_KEY_PREFIX + "joint_position"] = np.asarray(observation["joint_position"], dtype=np.float32)[0]
    request[OPENPI_KEY_PREFIX + "gripper_position"] = np.asarray(observation["gripper_position"], dtype=np.float32)[0]
    request["prompt"] = str(observation["prompt"])
    return request


def _client_class() -> type:
    """WebsocketClientPolicy with a bounded wait for the metadata and for each reply."""
    import websockets.sync.client
    from openpi_client import msgpack_numpy
    from openpi_client.websocket_client_policy import WebsocketClientPolicy

    class TimedWebsocketClient(WebsocketClientPolicy):
        timeout: float = 60.0

        def _wait_for_server(self) -> tuple[Any, dict]:
            connection = websockets.sync.client.connect(
                self._uri, compression=None, max_size=None, open_timeout=self.timeout, legacy=True
            )
            return connection, msgpack_numpy.unpackb(connection.recv(timeout=self.timeout))

        def infer(self, obs: dict) -> dict:
            self._ws.send(self._packer.pack(obs))
            response = self._ws.recv(timeout=self.timeout)
            if isinstance(response, str):  # openpi servers send their errors as a text frame
                raise PolicyReplyError(f"the policy server reported an error: {response.strip()[-2000:]}")
            return msgpack_numpy.unpackb(response)

        def close(self) -> None:
            self._ws.close()

    return TimedWebsocketClient


class OpenPIPolicy(ChunkedPolicy):
    """A DROID policy behind an openpi websocket server (pi0, pi0-FAST, pi0.5, or `robolab serve`)."""

    name = "openpi"
    needs_images = True

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8000,
        open_loop_horizon: int = 8,
        timeout: float = 60.0,
        realtime: bool = False,
    ) -> None:
        super().__init__(open_loop_horizon, realtime)
        self.host, self.port, self.timeout = host, port, timeout
        self.endpoint = f"ws://{host}:{port}"
        self._client: Any = None
        self._metadata: dict[str, Any] = {}

    def connect(self) -> None:
        self.close()
        self.needs_reconnect = True  # until a connection is made
        probe_server(
            self.host,
            self.port,
            "openpi",
            f"`robolab serve --policy random --port {self.port}` to check the set-up here, or openpi's "
            f"`uv run scripts/serve_policy.py --env DROID` on a GPU machine",
        )
        client_class = _client_class()
        client_class.timeout = self.timeout
        try:
            self._client = client_class(host=self.host, port=self.port)
        except TimeoutError:
            raise PolicyUnavailableError(
                f"the server at {self.host}:{self.port} accepted a connection but sent no "
                f"openpi metadata within {self.timeout:g} s: is it an openpi policy "
                "server?"
            ) from None
        except Exception as exc:  # websockets' handshake errors, refused connections
            raise PolicyUnavailableError(
                f"cannot open an openpi websocket to {self.endpoint}: {type(exc).__name__}: {exc}"
            ) from None
        metadata = self._client.get_server_metadata()
        self._metadata = metadata if isinstance(metadata, dict) else {"metadata": metadata}
        self.needs_reconnect = False

    def metadata(self) -> dict[str, Any]:
        return self._metadata

    def reset(self, instruction: str, action_space: Any, seed: int) -> None:
        super().reset(instruction, action_space, seed)
        if not self._is_open():  # closed while idle (e.g. keep-alive pings unanswered during a long env build)
            self.connect()

    def _is_open(self) -> bool:
        from websockets.protocol import State

        return self._client is not None and getattr(self._client._ws, "state", None) is State.OPEN

    def observation_request(self, observation: dict[str, Any]) -> dict[str, Any]:
        """The openpi request for one DROID observation (batched arrays from DroidObservation)."""
        request = droid_request(observation)
        if self._metadata.get("server") == "robolab_ms":
            request.update({ROBOLAB_KEY_PREFIX + key: value for key, value in self.episode_fields().items()})
        return request

    def query(self, observation: dict[str, Any]) -> np.ndarray:
        if self._client is None:
            raise PolicyConnectionLost(f"not connected to the openpi server at {self.endpoint}")
        request = self.observation_request(observation)
        try:
            reply = self._client.infer(request)
        except PolicyReplyError:
            self.needs_reconnect = True  # openpi servers close the connection after reporting an error
            raise
        except TimeoutError:
            self.needs_reconnect = True  # a late reply would answer the next query: start afresh
            raise PolicyTimeout(
                f"the openpi server at {self.endpoint} did not answer within {self.timeout:g} s (--timeout)"
            ) from None
        except Exception as exc:  # the connection closed or broke
            self.needs_reconnect = True
            raise PolicyConnectionLost(
                f"lost the connection to the openpi server at {self.endpoint} ({type(exc).__name__}: {exc})"
            ) from None
        if not isinstance(reply, dict) or "actions" not in reply:
            keys = sorted(reply) if isinstance(reply, dict) else type(reply).__name__
            raise PolicyReplyError(f"reply from {self.endpoint} has no 'actions' (it holds {keys})")
        return check_chunk(reply["actions"], f"reply from {self.endpoint}")

    def close(self) -> None:
        if self._client is not None:
            try:
                self._client.close()
            except Exception:  # already closed or broken: nothing to release
                pass
            self._client = None
