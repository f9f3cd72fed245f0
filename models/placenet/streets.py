"""Generated two-day streets for the place descriptor: renders them with `keyfleet scenario
generate` and caches every kept frame at the network's input size.

  /usr/bin/python3 models/placenet/streets.py --keyfleet build/bin/keyfleet --work DIR

Two street kinds, as keyfleet's evaluations fly them: side-looking (configs/scenario_selection.yaml,
cameras 80 degrees from the flight direction at 5 m/s) and forward-looking
(configs/scenario_small.yaml, 55 degrees at 2 m/s); each street has 4 drones, two a day, so every
place is seen by other drones on the same day and on the other day (other light, exposure, blur,
altitude and offset). Seeds: TRAIN_SEEDS train, VALIDATION_SEEDS choose the checkpoint; both stay
clear of the seeds keyfleet's evaluations use (7, 11-13, 21-23, and 22), which are held out.

WORK/streets/<kind>-<seed>.npz: images (N, H, W, 3) uint8 BGR at INPUT_SIZE (area-resized from
640x480), position (street metres the camera looks at), drone, day. The rendered frames are
deleted once cached; a street already cached is skipped (rerunnable).
"""
import argparse
import json
import os
import shutil
import subprocess
import tempfile

import cv2
import numpy as np
import yaml

INPUT_SIZE = (160, 120)  # width, height: what the exported model takes
KEEP_EVERY = 3           # frames kept per drone (consecutive frames are near copies)
TRAIN_SEEDS = list(range(301, 313))
VALIDATION_SEEDS = [391, 392]
KINDS = {
    # kind: (base scenario file, frames per drone)
    "side": ("configs/scenario_selection.yaml", 480),
    "forward": ("configs/scenario_small.yaml", 600),
}
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def scenario_yaml(kind, seed, data_root):
    base_file, frames = KINDS[kind]
    with open(os.path.join(REPO, base_file)) as f:
        config = yaml.safe_load(f)
    config["name"] = f"places_{kind}_{seed}"
    config["seed"] = seed
    config["frames_per_drone"] = frames
    config["drones"]["count"] = 4
    config["drones"]["days"] = 2
    folders = [os.path.join(data_root, "icdar2015", "train_sharp", "images")]
    config["textures"]["optional_photo_folders"] = folders
    return config


def read_truth(path):
    with open(path) as f:
        return [json.loads(line) for line in f]


def cache_street(keyfleet, kind, seed, out_npz, data_root):
    with tempfile.TemporaryDirectory(dir=os.path.dirname(out_npz)) as tmp:
        config_path = os.path.join(tmp, "scenario.yaml")
        with open(config_path, "w") as f:
            yaml.safe_dump(scenario_yaml(kind, seed, data_root), f)
        scenario = os.path.join(tmp, "scenario")
        subprocess.run([keyfleet, "scenario", "generate", config_path, "--out", scenario],
                       check=True, stdout=subprocess.DEVNULL)
        with open(os.path.join(scenario, "scenario.json")) as f:
            drones = json.load(f)["drones"]
        images, position, drone_ids, days = [], [], [], []
        for d, drone in enumerate(drones):
            folder = os.path.join(scenario, drone["folder"])
            truth = read_truth(os.path.join(folder, "truth.jsonl"))
            for t in truth[::KEEP_EVERY]:
                image = cv2.imread(os.path.join(folder, t["image"]), cv2.IMREAD_COLOR)
                if image is None:
                    raise SystemExit(f"streets.py: cannot read {t['image']} in {folder}")
                images.append(cv2.resize(image, INPUT_SIZE, interpolation=cv2.INTER_AREA))
                position.append(t["street_position_m"])
                drone_ids.append(d)
                days.append(drone["day"])
        tmp_npz = out_npz + ".part.npz"
        np.savez(tmp_npz, images=np.stack(images), position=np.array(position, np.float32),
                 drone=np.array(drone_ids, np.int16), day=np.array(days, np.int16))
        os.replace(tmp_npz, out_npz)
        shutil.rmtree(scenario)
    return len(images)


def street_files(work, seeds):
    return [os.path.join(work, "streets", f"{kind}-{seed}.npz") for seed in seeds for kind in KINDS]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--keyfleet", required=True, help="the keyfleet executable")
    ap.add_argument("--work", required=True)
    ap.add_argument("--data", default=os.environ.get("KEYFLEET_DATA",
                                                     os.path.join(REPO, "..", "shared", "data")))
    args = ap.parse_args()
    os.makedirs(os.path.join(args.work, "streets"), exist_ok=True)
    for seed in TRAIN_SEEDS + VALIDATION_SEEDS:
        for kind in KINDS:
            out = os.path.join(args.work, "streets", f"{kind}-{seed}.npz")
            if os.path.exists(out):
                continue
            n = cache_street(args.keyfleet, kind, seed, out, os.path.abspath(args.data))
            print(f"{kind} street {seed}: {n} frames cached in {out}", flush=True)


if __name__ == "__main__":
    main()
