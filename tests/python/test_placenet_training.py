#!/usr/bin/python3
"""PlaceNet's training recipe, smoke-tested: the network's size and cost, the loss on hand-made
embeddings, a street cached by streets.py from a real `keyfleet scenario generate`, a short run
on it that lowers the loss, and the export that OpenCV DNN reproduces.

  test_placenet_training.py KEYFLEET_BINARY
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "models", "placenet"))

import numpy as np  # noqa: E402
import torch  # noqa: E402

import streets  # noqa: E402
import train  # noqa: E402
from placenet import PlaceNet, count_macs, count_parameters  # noqa: E402

KEYFLEET = sys.argv[1]


class PlaceNetTraining(unittest.TestCase):
    def test_size_and_cost(self):
        net = PlaceNet()
        self.assertLess(count_parameters(net), 600_000)
        self.assertAlmostEqual(count_macs(net) / 1e6, 53.8, delta=0.5)
        out = net(torch.zeros(2, 3, 120, 160))
        self.assertEqual(tuple(out.shape), (2, 256))
        self.assertTrue(torch.allclose(out.norm(dim=1), torch.ones(2), atol=1e-5))

    def test_loss_is_low_when_places_separate_and_high_when_they_mix(self):
        streets_ids = np.array([0, 0, 0, 0])
        positions = np.array([10.0, 10.5, 40.0, 40.5])  # two places, two views each
        apart = torch.tensor([[1.0, 0], [1.0, 0], [0, 1.0], [0, 1.0]])
        mixed = torch.tensor([[1.0, 0], [0, 1.0], [1.0, 0], [0, 1.0]])
        low = train.multi_similarity_loss(apart, streets_ids, positions).item()
        high = train.multi_similarity_loss(mixed, streets_ids, positions).item()
        self.assertLess(low, 0.1)
        self.assertGreater(high, 0.5)

    def test_a_cached_street_trains_and_exports(self):
        with tempfile.TemporaryDirectory() as work:
            os.makedirs(os.path.join(work, "streets"))
            saved = dict(streets.KINDS)
            streets.KINDS["side"] = (streets.KINDS["side"][0], 90)
            try:
                npz = os.path.join(work, "streets", "side-1.npz")
                n = streets.cache_street(KEYFLEET, "side", 1, npz, os.path.join(work, "no-data"))
            finally:
                streets.KINDS.clear()
                streets.KINDS.update(saved)
            self.assertEqual(n, 4 * 90 // streets.KEEP_EVERY)
            street = train.Street(npz)
            self.assertEqual(street.images.shape[1:], (120, 160, 3))
            self.assertEqual(sorted(set(street.day.tolist())), [0, 1])

            torch.manual_seed(0)
            net = PlaceNet()
            opt = torch.optim.Adam(net.parameters(), lr=1e-3)
            saved_streets = train.STREETS_PER_BATCH
            train.STREETS_PER_BATCH = 1
            try:
                losses = []
                for step in range(24):
                    x, ids, positions = train.draw_batch([street], 1, step % 4)
                    loss = train.multi_similarity_loss(net(x), ids, positions)
                    opt.zero_grad()
                    loss.backward()
                    opt.step()
                    losses.append(loss.item())
            finally:
                train.STREETS_PER_BATCH = saved_streets
            self.assertLess(np.mean(losses[-4:]), np.mean(losses[:4]))

            checkpoint = os.path.join(work, "best.pt")
            torch.save({"net": net.state_dict(), "step": 24}, checkpoint)
            model = os.path.join(work, "placenet.onnx")
            subprocess.run([sys.executable, os.path.join(HERE, "..", "..", "models", "placenet",
                                                          "export.py"),
                            "--checkpoint", checkpoint, "--out", model], check=True,
                           stdout=subprocess.DEVNULL)
            self.assertTrue(os.path.exists(os.path.join(work, "placenet.json")))


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1])
