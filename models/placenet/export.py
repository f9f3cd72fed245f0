"""Exports a trained PlaceNet checkpoint to ONNX for OpenCV DNN, checks it, describes it.

  /usr/bin/python3 models/placenet/export.py --checkpoint WORK/best.pt \
      --out models/placenet/placenet.onnx [--work WORK]

- exports in eval mode (batch norm folded into the convolutions), opset 11, dynamic batch, the
  graph ending at the projection (the station L2-normalises: OpenCV 4.6 lacks ReduceL2);
- folds the Identity(initializer) nodes torch 1.13 emits;
- runs OpenCV DNN and PyTorch on fixed inputs and fails if they differ by more than --tolerance;
- writes the JSON description beside the model (what the station's PlaceDescriber reads), with a
  reference the C++ tests recompute and, with --work, the training's validation figures.
"""
import argparse
import csv
import datetime
import json
import os
import sys

import cv2
import numpy as np
import onnx
import torch

from placenet import DIM, PlaceNet, count_macs, count_parameters

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from onnx_graph import fold_identities  # noqa: E402

WIDTH, HEIGHT = 160, 120


class Unnormalised(torch.nn.Module):
    def __init__(self, net):
        super().__init__()
        self.net = net

    def forward(self, x):
        return self.net(x, normalise=False)


def reference_pattern():
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH]
    return np.stack([(xs * 7 + ys * 13 + c * 50) % 256 for c in range(3)], axis=-1).astype(np.uint8)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--checkpoint", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--work", default="", help="training folder: its validation.csv is described")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    args = ap.parse_args()

    state = torch.load(args.checkpoint, map_location="cpu")
    net = PlaceNet()
    net.load_state_dict(state["net"])
    net.eval()
    wrapped = Unnormalised(net).eval()
    torch.onnx.export(wrapped, torch.zeros(1, 3, HEIGHT, WIDTH), args.out, opset_version=11,
                      input_names=["input"], output_names=["descriptor"],
                      dynamic_axes={"input": {0: "N"}, "descriptor": {0: "N"}})
    model = onnx.load(args.out)
    folded = fold_identities(model)
    onnx.save(model, args.out)

    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, size=(3, 3, HEIGHT, WIDTH)).astype(np.float32)
    with torch.no_grad():
        expected = wrapped(torch.from_numpy(x)).numpy()
    cv_net = cv2.dnn.readNetFromONNX(args.out)
    cv_net.setInput(x)
    worst = float(np.abs(cv_net.forward() - expected).max())
    print(f"folded {folded} Identity nodes; OpenCV vs PyTorch max |diff| = {worst:.2e}")
    if worst > args.tolerance:
        raise SystemExit(f"export.py: OpenCV output differs from PyTorch by {worst:.2e}")

    pattern = reference_pattern()
    x = torch.from_numpy((pattern.astype(np.float32) - 127.5) / 127.5).permute(2, 0, 1)[None]
    with torch.no_grad():
        descriptor = net(x)[0].numpy()
    reference = {"pattern": "pixel(x, y, c) = (7 x + 13 y + 50 c) mod 256, BGR, 160x120",
                 "first": [float(v) for v in descriptor[:8]],
                 "sum": float(descriptor.sum())}

    validation = []
    if args.work:
        with open(os.path.join(args.work, "validation.csv")) as f:
            validation = list(csv.DictReader(f))
    meta = {
        "format": "keyfleet-place-descriptor",
        "version": 1,
        "description": "PlaceNet: a holistic place descriptor trained by models/placenet/train.py "
                       "(multi-similarity loss) on generated two-day streets",
        "input_width": WIDTH,
        "input_height": HEIGHT,
        "scale": 1 / 127.5,
        "mean_bgr": [127.5, 127.5, 127.5],
        "dimensions": DIM,
        "output": "unnormalised: L2-normalise, then cosine similarity is a dot product",
        "parameters": count_parameters(net),
        "mmacs": round(count_macs(net) / 1e6, 1),
        "training": {"steps": state["step"], "validation": state.get("scores"),
                     "validation_rows": len(validation)},
        "opencv_max_abs_diff": worst,
        "reference": reference,
        "exported": datetime.date.today().isoformat(),
    }
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(meta, f, indent=1)
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.2f} MB) and its .json")


if __name__ == "__main__":
    main()
