"""A local Ray instance for the tests: `python ray_head.py [CPUS]` starts one on 127.0.0.1, prints its address
(host:port) on one line, and shuts it down when its standard input closes."""

from __future__ import annotations

import os
import sys

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # this machine only: Ray talks over 127.0.0.1
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

import ray  # noqa: E402

if __name__ == "__main__":
    cpus = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    context = ray.init(num_cpus=cpus, include_dashboard=False, configure_logging=False)
    print(f"ray-address {context.address_info['gcs_address']}", flush=True)
    sys.stdin.read()
    ray.shutdown()
