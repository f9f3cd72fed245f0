#!/usr/bin/python3
"""MiniNet's training recipe, smoke-tested: the network's shape and cost, the exact fast
upsampling, the ICDAR 2015 loader (masks, don't-care, the validation split) and a short run on
generated pairs plus real photos that lowers the loss.

  test_mininet_training.py KEYFLEET_BINARY SCENARIO_YAML [DATA_DIR]

DATA_DIR (else $KEYFLEET_DATA, else ../shared/data beside the repository) holds icdar2015/train;
without it the real-photo parts skip and the run uses generated pairs only.
"""
import os
import random
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "models", "mininet"))

import numpy as np  # noqa: E402
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402

import data  # noqa: E402
import train  # noqa: E402
from mininet import MiniNet, count_flops, count_parameters  # noqa: E402

KEYFLEET, SCENARIO = sys.argv[1], sys.argv[2]
DATA = sys.argv[3] if len(sys.argv) > 3 else os.environ.get(
    "KEYFLEET_DATA", os.path.join(HERE, "..", "..", "..", "shared", "data"))
ICDAR_TRAIN = os.path.join(DATA, "icdar2015", "train")
HAVE_ICDAR = os.path.isdir(os.path.join(ICDAR_TRAIN, "images"))


class MiniNetTraining(unittest.TestCase):
    def test_size_and_cost_match_the_2019_network(self):
        net = MiniNet(2)
        self.assertAlmostEqual(count_parameters(net) / 1e6, 3.06, delta=0.01)
        self.assertAlmostEqual(count_flops(net, 256, 512) / 1e9, 1.05, delta=0.01)

    def test_fast_upsampling_equals_the_transposed_convolution(self):
        torch.manual_seed(0)
        net = MiniNet(2).eval()
        x = torch.randn(1, 3, 128, 256)
        with torch.no_grad():
            fast = net(x)
            net.set_fast_upsampling(False)
            native = net(x)
        self.assertLess(float((fast - native).abs().max()), 1e-4)

    @unittest.skipUnless(HAVE_ICDAR, f"no ICDAR 2015 training photos in {ICDAR_TRAIN}")
    def test_icdar_loader_split_and_dont_care(self):
        train_ids, val_ids = data.icdar_split(data.icdar_ids(ICDAR_TRAIN))
        self.assertEqual((len(train_ids), len(val_ids)), (900, 100))
        self.assertEqual(val_ids[:3], [10, 20, 30])
        self.assertFalse(set(train_ids) & set(val_ids))
        quads = data.read_quads(os.path.join(ICDAR_TRAIN, "gt", "gt_img_1.txt"))
        self.assertEqual(quads[0][0].tolist(), [[377, 117], [463, 117], [465, 130], [378, 130]])
        self.assertEqual([legible for _, legible in quads[:3]], [True, True, False])  # BOM, ###
        (image, mask), = data.load_icdar(ICDAR_TRAIN, [1])
        self.assertEqual(image.shape, (360, 640, 3))
        self.assertEqual(set(np.unique(mask).tolist()), {0, 1, data.IGNORE})
        img, msk = data.augment(image, mask, random.Random(3))
        self.assertEqual(img.shape, (3, data.TRAIN_H, data.TRAIN_W))
        self.assertTrue(set(np.unique(msk).tolist()) <= {0, 1, data.IGNORE})
        weights, freq = data.class_weights([([(image, mask)], 1)], 0.5)
        self.assertAlmostEqual(freq[1], (mask == 1).sum() / (mask != data.IGNORE).sum())

    def test_soft_iou_term_is_one_minus_the_iou_and_skips_dont_care(self):
        target = torch.tensor([[[1, 1, 0, 0, data.IGNORE, data.IGNORE]]])
        sure = torch.tensor([[[20.0, 20, -20, -20, 20, -20]]])
        logits = torch.stack([-sure, sure], 1)  # text where sure > 0
        self.assertAlmostEqual(float(train.soft_iou_loss(logits, target)), 0.0, places=5)
        logits[0, :, 0, 2] = torch.tensor([-20.0, 20])  # one false text pixel: IoU 2/3
        self.assertAlmostEqual(float(train.soft_iou_loss(logits, target)), 1 / 3, places=5)
        even = torch.zeros(1, 2, 1, 6)  # p = 0.5: overlap 2 x 0.5 over union 2 + 2 x 0.5
        self.assertAlmostEqual(float(train.soft_iou_loss(even, target)), 1 - 1 / 3, places=5)
        nothing = torch.full((1, 1, 6), data.IGNORE)
        self.assertEqual(float(train.soft_iou_loss(even, nothing)), 1.0)

    def test_a_step_batch_depends_on_the_seed_and_step_alone(self):
        rng = np.random.default_rng(0)
        pool = [(rng.integers(0, 255, (360, 640, 3), dtype=np.uint8),
                 (rng.random((360, 640)) < 0.05).astype(np.uint8)) for _ in range(3)]
        batches = train.StepBatches([pool, pool, []], [2, 1, 0], seed=4, crop=(128, 64))
        x, y = batches[7]
        self.assertEqual(tuple(x.shape), (3, 3, 64, 128))
        self.assertEqual(tuple(y.shape), (3, 64, 128))
        again_x, again_y = batches[7]
        self.assertTrue(torch.equal(x, again_x) and torch.equal(y, again_y))
        self.assertFalse(torch.equal(x, batches[8][0]))
        loader = torch.utils.data.DataLoader(batches, batch_size=None, sampler=range(6, 9),
                                             num_workers=2, worker_init_fn=train.one_thread_worker)
        from_workers = list(loader)
        self.assertTrue(torch.equal(from_workers[1][0], x))  # step 7, whichever worker drew it
        other_seed = train.StepBatches([pool, pool, []], [2, 1, 0], seed=5, crop=(128, 64))
        self.assertFalse(torch.equal(other_seed[7][0], x))

    def test_packed_sources_train_on_the_same_pairs(self):
        with tempfile.TemporaryDirectory() as work:
            pairs, packed = os.path.join(work, "pairs"), os.path.join(work, "packed")
            subprocess.run([KEYFLEET, "scenario", "training", SCENARIO, "--out", pairs,
                            "--count", "6"], check=True, stdout=subprocess.DEVNULL)
            subprocess.run([sys.executable, os.path.join(HERE, "..", "..", "models", "mininet",
                                                         "pack.py"),
                            "--data", pairs, "--out", packed, "--validation", "0.34",
                            "--parts", "2"], check=True, stdout=subprocess.DEVNULL)
            original = data.Sources(pairs, 0.34)
            again = data.Sources("", 0.34, packed=packed)
            self.assertEqual((len(original.generated), len(original.generated_val)), (4, 2))
            self.assertEqual(len(again.generated), 4)  # parts 1 and 2, two pairs each
            self.assertEqual(len(again.generated_val), 2)
            for (image, mask), k in zip(again.generated, (0, 2, 1, 3)):  # part k takes k::2
                self.assertTrue(np.array_equal(mask, original.generated[k][1]))
                diff = np.abs(image.astype(int) - original.generated[k][0].astype(int)).mean()
                self.assertLess(diff, 3.0)  # JPEG 90

    def test_a_short_run_lowers_the_loss(self):
        torch.set_num_threads(2)
        torch.manual_seed(1)
        with tempfile.TemporaryDirectory() as work:
            subprocess.run([KEYFLEET, "scenario", "training", SCENARIO, "--out", work,
                            "--count", "8"], check=True, stdout=subprocess.DEVNULL)
            pairs = data.load_pairs(work)
            groups = [(pairs, 2)]
            if HAVE_ICDAR:
                groups.append((data.load_icdar(ICDAR_TRAIN, [1, 2, 3, 4]), 2))
            weights, _ = data.class_weights(groups, 0.5)
            sources = [p for p, _ in groups]
            batch = [data.augment(*sources[i % len(sources)][i % 4], random.Random(i))
                     for i in range(4)]
            x = torch.from_numpy(np.stack([b[0] for b in batch]))
            y = torch.from_numpy(np.stack([b[1] for b in batch])).long()
            for bf16, iou_loss in ((False, 0.0), (True, 1.0)):  # plain; --bf16 --iou-loss 1
                torch.manual_seed(1)
                net = MiniNet(2)
                optimizer = torch.optim.Adam(net.parameters(), lr=1e-3)
                losses, iou_terms = [], []  # the cross-entropy; the soft-IoU term
                for _ in range(15):
                    with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
                        logits = net(x)
                    logits = logits.float()
                    loss = F.cross_entropy(logits, y, ignore_index=data.IGNORE,
                                           weight=torch.tensor(weights, dtype=torch.float32))
                    iou_term = train.soft_iou_loss(logits, y)
                    optimizer.zero_grad()
                    (loss + iou_loss * iou_term).backward()
                    optimizer.step()
                    losses.append(loss.item())
                    iou_terms.append(iou_term.item())
                views = [data.whole_view(i, m) for i, m in pairs[:2]]
                scores = train.evaluate(net, views)
                self.assertTrue(0 <= scores["iou"] <= 1)
                self.assertLess(losses[-1], 0.7 * losses[0], f"bf16 {bf16}: losses {losses}")
                if iou_loss:
                    self.assertLess(iou_terms[-1], iou_terms[0], f"soft-IoU terms {iou_terms}")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
