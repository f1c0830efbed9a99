"""Check that SAPIEN can render here: `python -m robolab_ms.render_check [--quiet]` (exit 0 when it can)."""

from __future__ import annotations

import argparse
import sys

NO_DEVICE_HELP = (
    "SAPIEN renders through Vulkan. On a GPU machine install the NVIDIA driver with its Vulkan ICD; on a CPU-only "
    "machine install Mesa's lavapipe (packages mesa-vulkan-drivers and libvulkan1, Mesa 24 or newer; on Debian "
    "bookworm take them from bookworm-backports, which `make setup` does for you)."
)


def rendering_device() -> str | None:
    """The name of a Vulkan device SAPIEN can render with, or None."""
    import sapien

    try:
        sapien.render.RenderSystem()
    except RuntimeError:
        return None
    for line in sapien.render.get_device_summary().splitlines():
        if line.strip() and not line.startswith(" "):
            return line.strip()
    return "unknown device"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robolab_ms.render_check", description=__doc__)
    parser.add_argument("--quiet", action="store_true", help="print nothing when a device is found")
    args = parser.parse_args(argv)
    device = rendering_device()
    if device is None:
        if not args.quiet:
            print(f"No rendering device. {NO_DEVICE_HELP}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"Rendering device: {device}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
