"""Packs distill.py's sources into one small folder, for a machine without the data (a lent GPU).

  /usr/bin/python3 models/mininet/distill_pack.py --data SHARED --generated PAIRS \
      --heldout HELDOUT --out DIR [--quality 70] [--width 640]

Training sources, each a folder of WebP images at most --width px wide (aspect kept):
  icdar_train  ICDAR 2015 train photos whose id is not a multiple of 10 (900)
  blurred      ICDAR 2015 test_blurred img_201..500 (the evaluation's are img_101..200)
  generated    `keyfleet scenario training` frames (PAIRS/images; masks unused)
  frames       unlabelled real frames: KITTI sequences, TUM freiburg, every 8th frame of the
               OpenCV sample videos
Validation (never trained on; each image with its truth mask, 0 / 1 / 255 = `###`, beside it):
  icdar_val    ICDAR 2015 train ids divisible by 10 (the split train.py validates on)
  generated_val  HELDOUT pairs (other streets, another seed)
The test sets of the evaluation (test_clean, test_blurred 1..200) are never packed. The teacher's
maps are not packed: distill.py computes them on the fly on each augmented view.
"""
import argparse
import glob
import os

import cv2
import numpy as np

import data


def shrink(image, width, interpolation=cv2.INTER_AREA):
    if image.shape[1] <= width:
        return image
    height = int(round(image.shape[0] * width / image.shape[1]))
    return cv2.resize(image, (width, height), interpolation=interpolation)


def write(folder, name, image, quality, mask=None):
    os.makedirs(folder, exist_ok=True)
    if not cv2.imwrite(os.path.join(folder, name + ".webp"), image,
                       [cv2.IMWRITE_WEBP_QUALITY, quality]):
        raise SystemExit(f"distill_pack.py: could not write {folder}/{name}.webp")
    if mask is not None:
        cv2.imwrite(os.path.join(folder, name + ".png"), mask)


def read(path):
    image = cv2.imread(path, cv2.IMREAD_COLOR)
    if image is None:
        raise SystemExit(f"distill_pack.py: unreadable image {path}")
    return image


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", required=True, help="the shared data folder")
    ap.add_argument("--generated", required=True, help="keyfleet scenario training output")
    ap.add_argument("--heldout", required=True, help="held-out generated pairs (another seed)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--quality", type=int, default=70)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--val-quality", type=int, default=85)
    ap.add_argument("--max-generated", type=int, default=400)
    ap.add_argument("--max-heldout", type=int, default=60)
    args = ap.parse_args()
    counts = {}

    icdar = os.path.join(args.data, "icdar2015", "train")
    train_ids, val_ids = data.icdar_split(data.icdar_ids(icdar))
    for i in train_ids:
        write(os.path.join(args.out, "icdar_train"), f"img_{i}",
              shrink(read(os.path.join(icdar, "images", f"img_{i}.jpg")), args.width), args.quality)
    counts["icdar_train"] = len(train_ids)
    for i in val_ids:
        image = read(os.path.join(icdar, "images", f"img_{i}.jpg"))
        mask = data.icdar_mask(image.shape, data.read_quads(os.path.join(icdar, "gt", f"gt_img_{i}.txt")))
        small = shrink(image, args.width)
        write(os.path.join(args.out, "icdar_val"), f"img_{i}", small, args.val_quality,
              cv2.resize(mask, small.shape[1::-1], interpolation=cv2.INTER_NEAREST))
    counts["icdar_val"] = len(val_ids)

    blurred = os.path.join(args.data, "icdar2015", "test_blurred")
    ids = [i for i in data.icdar_ids(blurred) if i > 100 + data.BLURRED_HELD_OUT]
    for i in ids:
        write(os.path.join(args.out, "blurred"), f"img_{i}",
              shrink(read(os.path.join(blurred, "images", f"img_{i}.jpg")), args.width), args.quality)
    counts["blurred"] = len(ids)

    images = sorted(glob.glob(os.path.join(args.generated, "images", "*.jpg")))[:args.max_generated]
    for path in images:
        write(os.path.join(args.out, "generated"), os.path.basename(path)[:-4],
              shrink(read(path), args.width), args.quality)
    counts["generated"] = len(images)
    held = sorted(glob.glob(os.path.join(args.heldout, "images", "*.jpg")))[:args.max_heldout]
    for path in held:
        name = os.path.basename(path)[:-4]
        mask = cv2.imread(os.path.join(args.heldout, "masks", name + ".png"), cv2.IMREAD_GRAYSCALE)
        small = shrink(read(path), args.width)
        write(os.path.join(args.out, "generated_val"), name, small, args.val_quality,
              cv2.resize((mask > 127).astype(np.uint8), small.shape[1::-1],
                         interpolation=cv2.INTER_NEAREST))
    counts["generated_val"] = len(held)

    frames = []
    for pattern in ("kitti/*/image_l/*.png", "tum_freiburg/*.png", "tum_freiburg/*.jpg"):
        frames += sorted(glob.glob(os.path.join(args.data, pattern)))
    n = 0
    for k, path in enumerate(frames):
        write(os.path.join(args.out, "frames"), f"still_{k:04d}", shrink(read(path), args.width),
              args.quality)
        n += 1
    for video in sorted(glob.glob(os.path.join(args.data, "opencv_samples", "video", "*.mp4"))):
        capture = cv2.VideoCapture(video)
        index = 0
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            if index % 8 == 0:
                write(os.path.join(args.out, "frames"),
                      f"{os.path.basename(video)[:-4]}_{index:04d}", shrink(frame, args.width),
                      args.quality)
                n += 1
            index += 1
    counts["frames"] = n
    size = sum(os.path.getsize(p) for p in glob.glob(os.path.join(args.out, "*", "*")))
    print(f"packed {counts} into {args.out} ({size / 1e6:.1f} MB)", flush=True)


if __name__ == "__main__":
    main()
