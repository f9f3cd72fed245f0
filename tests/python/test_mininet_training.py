#!/usr/bin/python3
"""MiniNet's training recipe, smoke-tested: the network's shape and cost, the exact fast
upsampling, and a short run on generated pairs that lowers the loss.

  test_mininet_training.py KEYFLEET_BINARY SCENARIO_YAML
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

import train  # noqa: E402
from mininet import MiniNet, count_flops, count_parameters  # noqa: E402

KEYFLEET, SCENARIO = sys.argv[1], sys.argv[2]


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

    def test_a_short_run_on_generated_pairs_lowers_the_loss(self):
        torch.set_num_threads(2)
        torch.manual_seed(1)
        with tempfile.TemporaryDirectory() as work:
            subprocess.run([KEYFLEET, "scenario", "training", SCENARIO, "--out", work,
                            "--count", "8"], check=True, stdout=subprocess.DEVNULL)
            pairs = train.load_pairs(work)
            weights, _ = train.class_weights(pairs, 0.5)
            batch = [train.augment(*pairs[i % len(pairs)], random.Random(i)) for i in range(4)]
            x = torch.from_numpy(np.stack([b[0] for b in batch]))
            y = torch.from_numpy(np.stack([b[1] for b in batch])).long()
            net = MiniNet(2)
            optimizer = torch.optim.Adam(net.parameters(), lr=1e-3)
            losses = []
            for _ in range(15):
                loss = F.cross_entropy(net(x), y, weight=weights)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                losses.append(loss.item())
        self.assertLess(losses[-1], 0.7 * losses[0], f"losses {losses}")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
