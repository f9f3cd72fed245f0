"""Packs MiniNet's training sources for a machine without the data: the pairs train.py would load
(generated, ICDAR 2015 train at ICDAR_SCALE, test_blurred img_201..500) at their training scale,
JPEG `--quality`, the held-out generated pairs, and the ICDAR validation photos as they are.

  /usr/bin/python3 models/mininet/pack.py --data PAIRS --icdar-train SHARED/icdar2015/train \
      --icdar SHARED --out DIR [--quality 90] [--parts 2]

train.py --packed DIR then trains on exactly these sources. With --parts K the training pairs are
spread over DIR/part1..partK (each a folder of the same layout, to move in pieces); train.py
reads every part it finds.
"""
import argparse
import os
import shutil

import data


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", required=True, help="generated pairs (images/, masks/)")
    ap.add_argument("--icdar-train", default="", help="ICDAR 2015 training folder")
    ap.add_argument("--icdar", default="", help="the shared data folder (test_blurred)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--validation", type=float, default=0.05, help="held-out generated fraction")
    ap.add_argument("--quality", type=int, default=90)
    ap.add_argument("--parts", type=int, default=1)
    args = ap.parse_args()

    sources = data.Sources(args.data, args.validation, args.icdar_train, args.icdar)
    for name in ("generated", "icdar_train", "blurred"):
        pairs = getattr(sources, name)
        for k in range(args.parts):
            data.save_pairs(os.path.join(args.out, f"part{k + 1}", name), pairs[k::args.parts],
                            args.quality)
    data.save_pairs(os.path.join(args.out, "generated_val"), sources.generated_val, 95)
    _, val_ids = data.icdar_split(data.icdar_ids(args.icdar_train)) if sources.real_val else ([], [])
    for sub, pattern in (("images", "img_{}.jpg"), ("gt", "gt_img_{}.txt")):
        os.makedirs(os.path.join(args.out, "icdar_val", sub), exist_ok=True)
        for i in val_ids:
            shutil.copy(os.path.join(args.icdar_train, sub, pattern.format(i)),
                        os.path.join(args.out, "icdar_val", sub))
    print(f"packed {len(sources.generated)} generated, {len(sources.icdar_train)} ICDAR train, "
          f"{len(sources.blurred)} test_blurred in {args.parts} part(s); "
          f"{len(sources.generated_val)} generated and {len(val_ids)} ICDAR validation into "
          f"{args.out}", flush=True)


if __name__ == "__main__":
    main()
