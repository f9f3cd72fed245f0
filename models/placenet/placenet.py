"""PlaceNet: a small holistic place descriptor for a robot's or the station's CPU.

Input: a 160x120 BGR view scaled to [-1, 1]. Seven 3x3 convolutions (batch norm folded at export,
ReLU) bring it to 128 channels on an 8x10 map; a 1x1 convolution reduces them to 64; the map is
averaged on a 2x5 grid (4x2 cells: the layout of a facade matters, which colour is left, what is
above) and a linear layer maps the 640 values to DIM, L2-normalised: cosine similarity is a dot
product. About 54 M multiply-adds a view. The exported graph stops before the normalisation
(OpenCV 4.6 lacks some of the ONNX operators it becomes); its users normalise.
"""
import torch
import torch.nn as nn
import torch.nn.functional as F

DIM = 256
GRID = (2, 5)  # rows, columns of the pooled map (cells of 4x2 on the 8x10 map)
CHANNELS = [(3, 16, 2), (16, 32, 2), (32, 32, 1), (32, 64, 2), (64, 64, 1), (64, 128, 2),
            (128, 128, 1)]


class PlaceNet(nn.Module):
    def __init__(self, dim=DIM):
        super().__init__()
        layers = []
        for cin, cout, stride in CHANNELS:
            layers += [nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout),
                       nn.ReLU(inplace=True)]
        self.features = nn.Sequential(*layers)
        self.reduce = nn.Conv2d(CHANNELS[-1][1], 64, 1)
        self.pool = nn.AvgPool2d((4, 2))
        self.project = nn.Linear(64 * GRID[0] * GRID[1], dim)

    def forward(self, x, normalise=True):
        x = self.pool(F.relu(self.reduce(self.features(x))))
        x = self.project(torch.flatten(x, 1))
        return F.normalize(x, dim=1) if normalise else x


def count_parameters(net):
    return sum(p.numel() for p in net.parameters())


def count_macs(net, width=160, height=120):
    """Multiply-adds of one view, convolutions and the linear layer."""
    macs = 0

    def conv_hook(module, _inputs, output):
        nonlocal macs
        k = module.kernel_size[0] * module.kernel_size[1] * module.in_channels // module.groups
        macs += output.numel() * k

    def linear_hook(module, _inputs, output):
        nonlocal macs
        macs += output.numel() * module.in_features

    hooks = [m.register_forward_hook(conv_hook) for m in net.modules() if isinstance(m, nn.Conv2d)]
    hooks += [m.register_forward_hook(linear_hook) for m in net.modules()
              if isinstance(m, nn.Linear)]
    was_training = net.training
    net.eval()
    with torch.no_grad():
        net(torch.zeros(1, 3, height, width))
    net.train(was_training)
    for h in hooks:
        h.remove()
    return macs
