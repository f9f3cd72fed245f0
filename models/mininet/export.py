"""Exports a trained MiniNet checkpoint to ONNX for OpenCV DNN, checks it, describes it.

  /usr/bin/python3 models/mininet/export.py --checkpoint WORK/best.pt --out models/mininet/mininet_text.onnx

- exports with dynamic batch, height and width (opset 11, native ConvTranspose);
- rewrites the Identity(initializer) nodes that Debian's torch 1.13 emits (OpenCV 4.6 rejects
  them) into plain initializers;
- rewrites the depthwise 1x3 and 3x1 convolutions as 3x3 ones with zero rows or columns (the same
  sums: OpenCV 4.6's own depthwise layer is faster on 3x3 kernels, and the whole forward pass takes
  about 0.85 times as long; the agent's stand-in depthwise layer skips the zero taps, so it gains
  little there; --plain-graph keeps them as exported);
- stores the weights as float16 when --fp16 (smaller, but OpenCV 4.6 refuses FLOAT16
  initialisers: the shipped model is float32);
- runs OpenCV DNN and PyTorch on fixed inputs and fails if they differ by more than --tolerance;
- writes the JSON description beside the model (what the agent's TextSegmenter reads).

A checkpoint of distill.py (one output, `width` in it) exports as a text-probability model: the
sigmoid is part of the graph, and the description says `"output": "text_probability"` with the
DB post-processing of the teacher it learnt from (PP-OCRv4's detector), so the agent fills its
boxes as it does the teacher's.
"""
import argparse
import datetime
import json
import os
import sys

import cv2
import numpy as np
import onnx
import torch
from onnx import numpy_helper

from mininet import MiniNet, count_flops, count_parameters

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from onnx_graph import fold_identities  # noqa: E402


def _attribute(node, name, default):
    for a in node.attribute:
        if a.name == name:
            return list(a.ints) if a.ints else a.i
    return default


def _set_attribute(node, name, value):
    for a in list(node.attribute):
        if a.name == name:
            node.attribute.remove(a)
    node.attribute.append(onnx.helper.make_attribute(name, value))


def square_depthwise(model):
    """Depthwise 1x3 / 3x1 convolutions -> 3x3 with the kernel in the middle row / column.

    The added taps are zeros, so each output is the same sum. A 3x1 kernel's horizontal dilation
    does nothing (MiniNet's modules dilate (1, d)), so it becomes dilation 1; a 1x3 kernel keeps
    its horizontal dilation and gets vertical dilation 1.
    """
    initializers = {t.name: t for t in model.graph.initializer}
    users = {}
    for node in model.graph.node:
        for name in node.input:
            users[name] = users.get(name, 0) + 1
    rewritten = 0
    for node in model.graph.node:
        if node.op_type != "Conv" or node.input[1] not in initializers or users[node.input[1]] != 1:
            continue
        w = numpy_helper.to_array(initializers[node.input[1]])
        if _attribute(node, "group", 1) != w.shape[0] or w.shape[1] != 1 or \
                tuple(w.shape[2:]) not in ((1, 3), (3, 1)):
            continue
        if _attribute(node, "strides", [1, 1]) != [1, 1]:
            continue
        dilation_w = _attribute(node, "dilations", [1, 1])[1]
        square = np.zeros((w.shape[0], 1, 3, 3), w.dtype)
        if w.shape[2] == 1:
            square[:, :, 1, :] = w[:, :, 0, :]
            dilations = [1, dilation_w]
        else:
            square[:, :, :, 1] = w[:, :, :, 0]
            dilations = [1, 1]
        initializers[node.input[1]].CopyFrom(numpy_helper.from_array(square, node.input[1]))
        _set_attribute(node, "kernel_shape", [3, 3])
        _set_attribute(node, "dilations", dilations)
        _set_attribute(node, "pads", dilations + dilations)
        rewritten += 1
    return rewritten


def to_fp16(model):
    for tensor in model.graph.initializer:
        if tensor.data_type == onnx.TensorProto.FLOAT:
            array = numpy_helper.to_array(tensor).astype(np.float16)
            tensor.CopyFrom(numpy_helper.from_array(array, tensor.name))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoint", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--input-width", type=int, default=512)
    ap.add_argument("--input-height", type=int, default=384)
    ap.add_argument("--fp16", action="store_true")
    ap.add_argument("--plain-graph", action="store_true",
                    help="keep the depthwise 1x3/3x1 convolutions as exported (for comparisons)")
    ap.add_argument("--tolerance", type=float, default=1e-3)
    ap.add_argument("--training-data", default="", help="described in the JSON")
    args = ap.parse_args()

    state = torch.load(args.checkpoint, map_location="cpu")
    classes, width = state.get("classes", 2), state.get("width", 1.0)
    distilled = classes == 1
    net = MiniNet(classes, width)
    net.load_state_dict(state["net"])
    net.eval()
    net.set_fast_upsampling(False)  # the native transposed convolution for OpenCV
    if distilled:
        net = torch.nn.Sequential(net, torch.nn.Sigmoid()).eval()

    dummy = torch.zeros(1, 3, 256, 512)
    output_name = "text_probability" if distilled else "logits"
    torch.onnx.export(net, dummy, args.out, opset_version=11, input_names=["input"],
                      output_names=[output_name],
                      dynamic_axes={"input": {0: "N", 2: "H", 3: "W"},
                                    output_name: {0: "N", 2: "H", 3: "W"}})
    net.eval()  # the exporter restores the mode it found, and a fresh Sequential's is training
    model = onnx.load(args.out)
    folded = fold_identities(model)
    squared = 0 if args.plain_graph else square_depthwise(model)
    if args.fp16:
        to_fp16(model)
    onnx.save(model, args.out)

    # OpenCV DNN against PyTorch on fixed inputs, at two sizes, batch of two.
    rng = np.random.default_rng(0)
    worst = 0.0
    cv_net = cv2.dnn.readNetFromONNX(args.out)
    for h, w in ((256, 512), (args.input_height, args.input_width)):
        x = rng.uniform(-0.5, 0.5, size=(2, 3, h, w)).astype(np.float32)
        with torch.no_grad():
            expected = net(torch.from_numpy(x)).numpy()
        cv_net.setInput(x)
        got = cv_net.forward()
        worst = max(worst, float(np.abs(got - expected).max()))
    print(f"folded {folded} Identity nodes, {squared} depthwise convolutions made 3x3; "
          f"OpenCV vs PyTorch max |diff| = {worst:.2e}")
    if worst > args.tolerance:
        raise SystemExit(f"export.py: OpenCV output differs from PyTorch by {worst:.2e}")

    # A reference the C++ tests recompute: a fixed 8-bit pattern through the whole pipeline.
    h, w = args.input_height, args.input_width
    ys, xs = np.mgrid[0:h, 0:w]
    pattern = np.stack([(xs * 7 + ys * 13 + c * 50) % 256 for c in range(3)], axis=0)
    x = (pattern.astype(np.float32) / 255.0 - 0.5)[None]
    with torch.no_grad():
        logits = net(torch.from_numpy(x)).numpy()[0]
    if distilled:
        reference = {"pattern": "pixel(c, y, x) = (7 x + 13 y + 50 c) mod 256, BGR, at the input "
                                "size", "mean_probability": float(logits[0].mean())}
    else:
        reference = {"pattern": "pixel(c, y, x) = (7 x + 13 y + 50 c) mod 256, BGR, at the input "
                                "size", "text_pixels": int((logits[1] > logits[0]).sum()),
                     "mean_logits": [float(logits[0].mean()), float(logits[1].mean())]}
    mini = net[0] if distilled else net

    meta = {
        "format": "keyfleet-segmenter",
        "version": 1,
        "description": (f"MiniNet (ICRA 2019 layout, channels x {width}) distilled by "
                        "models/mininet/distill.py from PP-OCRv4's detector: its text "
                        "probability, DB boxes filled as the text mask" if distilled else
                        "MiniNet (ICRA 2019 layout) trained by models/mininet/train.py for text "
                        "segmentation (data: training.data)"),
        "input_width": args.input_width,
        "input_height": args.input_height,
        "size_multiple": 64,
        "scale": 1 / 255.0,
        "mean_bgr": [127.5, 127.5, 127.5],
        "classes": ["text"] if distilled else ["background", "text"],
        "target_classes": ["text"],
        "parameters": count_parameters(mini),
        "gflops_512x256": round(count_flops(mini, 256, 512) / 1e9, 3),
        "weights": "float16" if args.fp16 else "float32",
        "graph": "as exported" if args.plain_graph else
                 "depthwise 1x3 and 3x1 convolutions as 3x3 (zero rows/columns)",
        "training": {"steps": state["step"], "class_weights": state.get("class_weights"),
                     "data": args.training_data, "recipe": state.get("recipe"),
                     "validation": {k: v for k, v in (state.get("validation") or {}).items()
                                    if isinstance(v, (int, float)) and np.isfinite(v)}},
        "opencv_max_abs_diff": worst,
        "reference": reference,
        "exported": datetime.date.today().isoformat(),
    }
    if distilled:  # PP-OCR's DB post-processing, as the teacher's description has it
        meta["output"] = "text_probability"
        meta["width_multiplier"] = width
        meta["db"] = {"binary_threshold": 0.3, "box_threshold": 0.6, "unclip_ratio": 1.5,
                      "min_size": 3}
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(meta, f, indent=1, allow_nan=False)
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.1f} MB) and its .json")


if __name__ == "__main__":
    main()
