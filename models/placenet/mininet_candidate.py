"""Measures MiniNet's encoder as a place descriptor beside PlaceNet, on the validation streets.

  /usr/bin/python3 models/placenet/mininet_candidate.py --work WORK \
      [--mininet models/mininet/mininet_text.onnx] [--placenet WORK/best.pt]

The robot already runs MiniNet's encoder on the frames it scores, so its features would cost the
robot nothing more. Candidates (no training: the shipped text segmenter's weights): the deepest
encoder map (d6, 386 channels at 1/64 of the 320x256 input) averaged over the whole view or kept
on its 4x5 grid, and the 1/16 map (b1, 96 channels after the dilated modules) averaged on a 2x5
grid; each L2-normalised, cosine similarity. Prints recall@1 / @5 per candidate on the validation
streets (train.Validation: as rendered and blurred + darkened), and ms per view on one thread.
"""
import argparse
import importlib.util
import os
import sys
import time

import cv2
import numpy as np
import torch
import torch.nn.functional as F

import streets
import train
from placenet import PlaceNet

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "mininet"))
from mininet import MiniNet  # noqa: E402

MININET_INPUT = (320, 256)


def mininet_features(net, images):
    """(d6 mean, d6 grid, b1 on a 2x5 grid) per view, each L2-normalised."""
    x = np.stack([cv2.resize(i, MININET_INPUT, interpolation=cv2.INTER_LINEAR) for i in images])
    x = torch.from_numpy(x.astype(np.float32) / 255.0 - 0.5).permute(0, 3, 1, 2)
    with torch.no_grad():
        d4 = net.d4(net.d3(net.d2(net.d1(x))))
        b1 = net.branch1(d4)
        d6 = net.d6(net.d5(d4))
    flat = [d6.mean((2, 3)), torch.flatten(d6, 1),
            torch.flatten(F.adaptive_avg_pool2d(b1, (2, 5)), 1)]
    return [F.normalize(f, dim=1).numpy() for f in flat]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--mininet", default=os.path.join(HERE, "..", "mininet", "mininet_text.onnx"))
    ap.add_argument("--placenet", default="")
    args = ap.parse_args()
    torch.set_num_threads(1)
    cv2.setNumThreads(1)

    mininet = MiniNet(2)
    spec = importlib.util.spec_from_file_location("mininet_train",
                                                  os.path.join(HERE, "..", "mininet", "train.py"))
    mininet_train = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mininet_train)
    mininet_train.load_onnx_weights(mininet, args.mininet)
    mininet.eval()

    validation = train.Validation(sorted(streets.street_files(args.work, streets.VALIDATION_SEEDS)))
    names = ["MiniNet d6, mean", "MiniNet d6, 4x5 grid", "MiniNet b1, 2x5 grid"]
    results = {n: [] for n in names}
    start, views = time.time(), 0
    for street, db, queries, degraded in validation.sets:
        db_f = mininet_features(mininet, list(street.images[db]))
        q_f = mininet_features(mininet, list(street.images[queries]))
        d_f = mininet_features(mininet, degraded)
        views += len(db) + len(queries) + len(degraded)
        for k, name in enumerate(names):
            clean = train.recall(q_f[k], street.position[queries], db_f[k], street.position[db])
            dark = train.recall(d_f[k], street.position[queries], db_f[k], street.position[db])
            results[name].append(clean + dark)
    ms = 1000 * (time.time() - start) / views
    rows = [(n, np.mean(results[n], axis=0)) for n in names]
    if args.placenet:
        net = PlaceNet()
        net.load_state_dict(torch.load(args.placenet)["net"])
        scores = train.Validation.run(validation, net)
        rows.append(("PlaceNet", [scores["recall1"], scores["recall5"], scores["degraded_recall1"],
                                  scores["degraded_recall5"]]))
    print("| descriptor | recall@1 % | recall@5 % | blurred + dark recall@1 % | @5 % |")
    print("|---|---|---|---|---|")
    for name, r in rows:
        print(f"| {name} | {100 * r[0]:.1f} | {100 * r[1]:.1f} | {100 * r[2]:.1f} | "
              f"{100 * r[3]:.1f} |")
    print(f"MiniNet encoder (torch, one thread, 320x256): {ms:.1f} ms a view")


if __name__ == "__main__":
    main()
