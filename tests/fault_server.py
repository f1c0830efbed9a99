"""A misbehaving policy server for the fault tests, written independently of robolab_ms.policies.server.

    python tests/fault_server.py --protocol openpi|gr00t --port P --faults '{"0": "shape", "1": "nan"}' --log FILE
        [--delay SECONDS]

It announces itself as a robolab_ms server, so clients send the episode seed, and answers each query of the
episode with seed S according to faults[S]: ok (home pose), shape (7 instead of 8 actions values), dtype (int64),
nan, inf, missing (no actions key), late (answers after 3 s), error (a server error), limits (a joint
target beyond the robot's limits), timed (the home pose, but the last arm joint of action i of a query sent at step
k is timed_target(k + i): each action tells the step it is meant for). --delay holds every reply back that long (an
openpi reply: measured from the request's arrival). Every received request is
logged to FILE as one JSON line: its keys with the shape and dtype of each array (and the values of scalars).
"""

from __future__ import annotations

import argparse
import io
import json
import time

import msgpack
import numpy as np

HOME = np.array([0.0, -0.6283, 0.0, -2.5133, 0.0, 1.885, 0.0, 0.0], dtype=np.float32)
HORIZON = 10


def timed_target(step: int) -> float:
    """The last arm joint's target in the action meant for this step (fault `timed`)."""
    return 0.5 + 0.01 * step


def chunk_for(fault: str, step: int = 0) -> np.ndarray | None:
    chunk = np.tile(HOME, (HORIZON, 1))
    if fault == "timed":
        chunk[:, 6] = [timed_target(step + i) for i in range(HORIZON)]
    if fault == "shape":
        return chunk[:, :7]
    if fault == "dtype":
        return chunk.astype(np.int64)
    if fault == "nan":
        chunk[3, 2] = np.nan
    if fault == "inf":
        chunk[0, 0] = np.inf
    if fault == "limits":
        chunk[:, 1] = 5.0  # beyond joint 2's limit of 1.7628 rad
    if fault == "late":
        time.sleep(3.0)
    return chunk


def describe(request: dict) -> dict:
    return {
        str(k): (
            [list(v.shape), str(v.dtype)]
            if isinstance(v, np.ndarray)
            else v
            if isinstance(v, (str, int, float))
            else type(v).__name__
        )
        for k, v in request.items()
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--protocol", choices=("openpi", "gr00t"), default="openpi")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--faults", default="{}")
    parser.add_argument("--log", required=True)
    parser.add_argument("--delay", type=float, default=0.0)
    args = parser.parse_args()
    faults = {int(k): v for k, v in json.loads(args.faults).items()}
    log = open(args.log, "a", encoding="utf-8")

    def fault_of(seed: object) -> str:
        return faults.get(int(seed), "ok") if seed is not None else "ok"

    if args.protocol == "openpi":
        serve_openpi(args.port, fault_of, log, args.delay)
    else:
        serve_gr00t(args.port, fault_of, log, args.delay)


def serve_openpi(port: int, fault_of, log, delay: float) -> None:
    import asyncio

    import websockets.asyncio.server
    from openpi_client import msgpack_numpy

    async def handle(connection) -> None:
        await connection.send(msgpack_numpy.packb({"server": "robolab_ms", "policy": "faulty"}))
        async for message in connection:
            arrived = time.perf_counter()
            request = msgpack_numpy.unpackb(message)
            log.write(json.dumps(describe(request)) + "\n")
            log.flush()
            fault = fault_of(request.get("robolab/seed"))
            if fault == "error":
                await connection.send("Traceback: the policy failed on purpose")
                await connection.close()
                return
            chunk = await asyncio.to_thread(chunk_for, fault, int(request.get("robolab/step", 0)))
            await asyncio.sleep(max(0.0, delay - (time.perf_counter() - arrived)))
            try:
                await connection.send(
                    msgpack_numpy.packb({"wrong": chunk} if fault == "missing" else {"actions": chunk})
                )
            except websockets.ConnectionClosed:
                return

    async def run() -> None:
        async with websockets.asyncio.server.serve(handle, "127.0.0.1", port, compression=None, max_size=None):
            print("ready", flush=True)
            await asyncio.get_running_loop().create_future()

    asyncio.run(run())


def serve_gr00t(port: int, fault_of, log, delay: float) -> None:
    import zmq

    def encode(value):
        if isinstance(value, np.ndarray):
            buffer = io.BytesIO()
            np.save(buffer, value)
            return {"__ndarray_class__": True, "as_npy": buffer.getvalue()}
        return value

    def decode(value):
        return np.load(io.BytesIO(value["as_npy"])) if "__ndarray_class__" in value else value

    sock = zmq.Context().socket(zmq.REP)
    sock.bind(f"tcp://127.0.0.1:{port}")
    print("ready", flush=True)
    while True:
        request = msgpack.unpackb(sock.recv(), object_hook=decode)
        if request.get("endpoint") == "ping":
            sock.send(msgpack.packb({"status": "ok", "server": "robolab_ms"}))
            continue
        data = request["data"]
        nested = isinstance(data.get("observation"), dict)  # N1.6: {"observation": ..., "options": ...}
        if nested:
            data = data["observation"]
        log.write(json.dumps(describe(data)) + "\n")
        log.flush()
        fault = fault_of(data.get("robolab.seed"))
        if fault == "error":
            reply = {"error": "the policy failed on purpose"}
        else:
            time.sleep(delay)
            chunk = chunk_for(fault, int(data.get("robolab.step", 0)))
            reply = {"action.joint_position": chunk[None, :, :-1], "action.gripper_position": chunk[None, :, -1:]}
            if fault == "missing":
                reply.pop("action.gripper_position")
            if nested:
                reply = [reply, {}]
        sock.send(msgpack.packb(reply, default=encode))


if __name__ == "__main__":
    main()
