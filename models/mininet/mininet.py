"""MiniNet (Alonso, Riazuelo, Murillo, ICRA 2019), the layout of the 2019 code (not
the later network of its public repository, which has batch norm and ReLU): SELU separable convolutions, factorised dilated modules, six stride-2 downsamplings,
transposed-convolution upsampling with skip concatenations. Input BGR/255 - 0.5, H and W
multiples of 64; output: per-class logits at the input resolution.

Where the 2019 code and the paper differ we follow the code (up4 -> 32 and up5 -> 16 channels,
horizontal-only dilation). Not given by either: the alpha-dropout rate (0.1 here).
"""
import torch
import torch.nn as nn
import torch.nn.functional as F


class SeparableConv(nn.Module):
    """Depthwise kxk (no bias) then pointwise 1x1 (with bias)."""

    def __init__(self, cin, cout, kernel, stride=1, dilation=(1, 1)):
        super().__init__()
        kh, kw = kernel
        pad = ((kh - 1) // 2 * dilation[0], (kw - 1) // 2 * dilation[1])
        self.depthwise = nn.Conv2d(cin, cin, kernel, stride=stride, padding=pad,
                                   dilation=dilation, groups=cin, bias=False)
        self.pointwise = nn.Conv2d(cin, cout, 1, bias=True)

    def forward(self, x):
        return self.pointwise(self.depthwise(x))


class Down(nn.Module):
    def __init__(self, cin, cout):
        super().__init__()
        self.conv = SeparableConv(cin, cout, (3, 3), stride=2)

    def forward(self, x):
        return F.selu(self.conv(x))


class Up(nn.Module):
    """Transposed 3x3 convolution, stride 2, 'same' (doubles H and W), with bias.

    For training on a CPU it is computed exactly as pad -> 2x2 convolution -> pixel shuffle
    with the same weights (ConvTranspose backward is most of a step otherwise); export uses
    the native transposed convolution, which OpenCV's importer reads.
    """

    def __init__(self, cin, cout, activate=True):
        super().__init__()
        self.weight = nn.Parameter(torch.empty(cin, cout, 3, 3))
        self.bias = nn.Parameter(torch.zeros(cout))
        nn.init.kaiming_uniform_(self.weight, a=5 ** 0.5)
        self.activate = activate
        self.fast = True

    def subpixel_kernel(self):
        # Output (2i + a, 2j + b) takes input (i + dy, j + dx) through kernel tap (u, v):
        # a = 0: dy = 0 -> u = 1; a = 1: dy = 0 -> u = 2, dy = 1 -> u = 0 (likewise b, v).
        taps = {(0, 0): 1, (1, 0): 2, (1, 1): 0}
        cin, cout = self.weight.shape[:2]
        kernel = self.weight.new_zeros(cout, 4, cin, 2, 2)
        w = self.weight.permute(1, 0, 2, 3)  # cout, cin, 3, 3
        for a in (0, 1):
            for b in (0, 1):
                for dy in (0, 1):
                    for dx in (0, 1):
                        if (a, dy) in taps and (b, dx) in taps:
                            kernel[:, a * 2 + b, :, dy, dx] = w[:, :, taps[(a, dy)], taps[(b, dx)]]
        return kernel.reshape(cout * 4, cin, 2, 2)

    def forward(self, x):
        if self.fast:
            y = F.conv2d(F.pad(x, (0, 1, 0, 1)), self.subpixel_kernel(),
                         self.bias.repeat_interleave(4))
            y = F.pixel_shuffle(y, 2)
        else:
            y = F.conv_transpose2d(x, self.weight, self.bias, stride=2, padding=1,
                                   output_padding=1)
        return F.selu(y) if self.activate else y


class Module(nn.Module):
    """Factorised residual module: 1x3 / 3x1 separable convolutions, then dilated ones."""

    def __init__(self, cin, f, dilation=1, dropout=0.1):
        super().__init__()
        self.f = f
        self.sep1x3 = SeparableConv(cin, f, (1, 3))
        self.sep3x1 = SeparableConv(f, f, (3, 1))
        self.sep3x1_dil = SeparableConv(f, f, (3, 1), dilation=(1, dilation))
        self.sep1x3_dil = SeparableConv(f, f, (1, 3), dilation=(1, dilation))
        self.dropout = nn.AlphaDropout(dropout)

    def forward(self, x):
        a = F.selu(self.sep1x3(x))
        x2 = self.sep3x1(a)
        b = F.selu(self.sep3x1_dil(F.selu(x2)))
        c = self.sep1x3_dil(b)
        return F.selu(self.dropout(c + x2) + x[:, : self.f])


class MiniNet(nn.Module):
    """`width` scales every layer's channels (1.0: the 2019 code's; distill.py's smaller
    students use less); `classes` 1 gives one logit, a text probability through a sigmoid."""

    def __init__(self, classes=2, width=1.0):
        super().__init__()
        c = (lambda n: n) if width == 1.0 else (lambda n: max(4, int(round(n * width))))
        self.width = width
        self.d1, self.d2 = Down(3, c(12)), Down(c(12), c(24))
        self.d3, self.d4 = Down(c(24), c(48)), Down(c(48), c(96))
        self.branch1 = nn.Sequential(*[Module(c(96), c(96), d) for d in (1, 2, 4, 8)])
        self.d5 = nn.Sequential(Down(c(96), c(192)), Module(c(192), c(192)))
        self.d6 = nn.Sequential(Down(c(192), c(386)), Module(c(386), c(386)),
                                Module(c(386), c(386)))
        self.up1 = nn.Sequential(Up(c(386), c(192)), Module(c(192), c(192)))
        self.up2 = Up(2 * c(192), c(96))
        self.up3 = Up(3 * c(96), c(96))
        self.module_up = Module(c(96), c(48))
        self.up4 = Up(c(48) + c(48), c(32))
        self.up5 = Up(c(32) + c(24), c(16))
        self.output = Up(c(16) + c(12), classes, activate=False)

    def set_fast_upsampling(self, fast):
        for m in self.modules():
            if isinstance(m, Up):
                m.fast = fast

    def forward(self, x):
        d1 = self.d1(x)
        d2 = self.d2(d1)
        d3 = self.d3(d2)
        d4 = self.d4(d3)
        b1 = self.branch1(d4)
        d5 = self.d5(d4)
        d6 = self.d6(d5)
        u1 = self.up1(d6)
        u2 = self.up2(torch.cat([u1, d5], 1))
        u3 = self.up3(torch.cat([b1, u2, d4], 1))
        m = self.module_up(u3)
        u4 = self.up4(torch.cat([m, d3], 1))
        u5 = self.up5(torch.cat([u4, d2], 1))
        return self.output(torch.cat([u5, d1], 1))


def count_parameters(model):
    return sum(p.numel() for p in model.parameters())


def count_flops(model, height, width):
    """Multiply-adds x 2 of convolutions, as the paper counts GFLOPs."""
    flops = [0]

    def conv_hook(module, inputs, output):
        kernel = module.weight.shape[2] * module.weight.shape[3]
        cin_per_group = module.weight.shape[1]
        flops[0] += 2 * output.numel() * cin_per_group * kernel

    hooks = [m.register_forward_hook(conv_hook) for m in model.modules()
             if isinstance(m, nn.Conv2d)]
    model.eval()
    model.set_fast_upsampling(False)
    with torch.no_grad():
        x = torch.zeros(1, 3, height, width)
        # Transposed convolutions: counted by hand (2 x input pixels x cin x cout x 9).
        def up_hook(module, inputs, output):
            cin, cout = module.weight.shape[:2]
            flops[0] += 2 * inputs[0].shape[2] * inputs[0].shape[3] * cin * cout * 9
        hooks += [m.register_forward_hook(up_hook) for m in model.modules() if isinstance(m, Up)]
        model(x)
    for h in hooks:
        h.remove()
    model.set_fast_upsampling(True)
    return flops[0]


if __name__ == "__main__":
    net = MiniNet(2)
    print(f"parameters: {count_parameters(net) / 1e6:.3f} M")
    print(f"GFLOPs at 512x256: {count_flops(net, 256, 512) / 1e9:.3f}")
    x = torch.randn(2, 3, 128, 256)
    net.eval()
    with torch.no_grad():
        fast = net(x)
        net.set_fast_upsampling(False)
        slow = net(x)
    print(f"fast vs native transposed conv: max |diff| = {(fast - slow).abs().max():.2e}")
