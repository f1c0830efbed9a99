"""Write a LeRobot checkpoint folder of a policy with random weights, as LeRobot's training saves one.

Run with the LeRobot environment's python (scripts/setup_lerobot_env.sh), not robolab_ms's:

    python tests/lerobot_checkpoint.py --policy-type act --out DIR --image-size 180,320 --stats stats.json \
        --set pretrained_backbone_weights=null

DIR then holds config.json, model.safetensors and the pre- and post-processors with their normalization statistics
(stats.json: {feature: {stat: [values]}}), which `lerobot_server --checkpoint DIR` loads.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.policies.factory import get_policy_class, make_policy_config, make_pre_post_processors


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--policy-type", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--image-size", default="224,224")
    parser.add_argument("--stats", required=True)
    parser.add_argument("--set", action="append", default=[])
    args = parser.parse_args()
    torch.manual_seed(0)
    settings = {key: json.loads(value) for key, _, value in (item.partition("=") for item in args.set)}
    config = make_policy_config(args.policy_type, device="cpu", **settings)
    height, width = (int(part) for part in args.image_size.split(","))
    image = PolicyFeature(type=FeatureType.VISUAL, shape=(3, height, width))
    config.input_features = {
        "observation.images.exterior_1_left": image,
        "observation.images.wrist_left": image,
        "observation.state": PolicyFeature(type=FeatureType.STATE, shape=(8,)),
    }
    config.output_features = {"action": PolicyFeature(type=FeatureType.ACTION, shape=(8,))}
    policy = get_policy_class(config.type)(config=config)
    stats = {
        name: {stat: np.asarray(values, np.float32) for stat, values in entry.items()}
        for name, entry in json.loads(Path(args.stats).read_text()).items()
    }
    preprocessor, postprocessor = make_pre_post_processors(config, dataset_stats=stats)
    for part in (policy, preprocessor, postprocessor):
        part.save_pretrained(args.out)


if __name__ == "__main__":
    main()
