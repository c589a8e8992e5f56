#!/usr/bin/env python3
"""PyTorch beside `indoorloc bench train|infer --device wgpu` on the same GPU (issue 44).

The same work as ../shared/tools/peers/torch_apr.py (whose layer tables this follows), moved to
a CUDA device, with torchvision's ResNet-34 layout added: seeded N(0, 1) images, batch 32,
PoseNet loss (beta 1), Adam (lr 1e-3, eps 1e-8), float32 unless --bf16; a training step is
timed as a whole up to the loss read back, inference on one image in eval mode with BatchNorm
as is. Prints one JSON object: median ms per training step and per single-image inference.

A peer for benchmarks only (never a dependency of indoorloc): it needs torch with CUDA.
"""

import argparse
import json
import statistics
import time

import torch
import torch.nn as nn


def conv_bn(cin, cout, k, s, p, relu=True):
    layers = [nn.Conv2d(cin, cout, k, s, p, bias=False), nn.BatchNorm2d(cout)]
    if relu:
        layers.append(nn.ReLU(inplace=True))
    return layers


class BasicBlock(nn.Module):
    """torchvision's BasicBlock: two 3x3 conv-BN, a 1x1 conv-BN shortcut when the shape changes."""

    def __init__(self, cin, cout, stride):
        super().__init__()
        self.body = nn.Sequential(*conv_bn(cin, cout, 3, stride, 1), *conv_bn(cout, cout, 3, 1, 1, relu=False))
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(*conv_bn(cin, cout, 1, stride, 0, relu=False))
        self.relu = nn.ReLU(inplace=True)

    def forward(self, x):
        sc = x if self.down is None else self.down(x)
        return self.relu(self.body(x) + sc)


def resnet(channels, blocks):
    layers = [*conv_bn(channels, 64, 7, 2, 3), nn.MaxPool2d(3, 2, 1)]
    cin = 64
    for i, (cout, n) in enumerate(zip([64, 128, 256, 512], blocks)):
        for j in range(n):
            layers.append(BasicBlock(cin, cout, 2 if (j == 0 and i > 0) else 1))
            cin = cout
    return nn.Sequential(*layers, nn.AdaptiveAvgPool2d(1), nn.Flatten(), nn.Linear(512, 7))


def small(channels):
    layers, cin = [], channels
    for cout in [32, 64, 128, 256, 256]:
        layers += conv_bn(cin, cout, 3, 2, 1)
        cin = cout
    return nn.Sequential(*layers, nn.AdaptiveAvgPool2d(1), nn.Flatten(), nn.Linear(256, 7))


def build(arch, channels):
    if arch == "small":
        return small(channels)
    return resnet(channels, {"resnet18": [2, 2, 2, 2], "resnet34": [3, 4, 6, 3]}[arch])


def posenet_loss(out, p, q, beta):
    q_hat = out[:, 3:] / out[:, 3:].norm(dim=1, keepdim=True).clamp_min(1e-12)
    return (out[:, :3] - p).norm(dim=1).mean() + beta * (q_hat - q).norm(dim=1).mean()


def timed(fn, warmup, runs):
    for _ in range(warmup):
        fn()
    torch.cuda.synchronize()
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        torch.cuda.synchronize()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", choices=["small", "resnet18", "resnet34"], default="small")
    ap.add_argument("--channels", type=int, default=3)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--infer-runs", type=int, default=50)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--bf16", action="store_true", help="bf16 autocast for the training step")
    a = ap.parse_args()
    dev = torch.device("cuda")
    torch.manual_seed(0)
    model = build(a.arch, a.channels).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, eps=1e-8)
    x = torch.randn(a.batch, a.channels, a.height, a.width, device=dev)
    p = torch.randn(a.batch, 3, device=dev)
    q = torch.nn.functional.normalize(torch.randn(a.batch, 4, device=dev), dim=1).abs()

    def step():
        opt.zero_grad(set_to_none=True)
        with torch.autocast("cuda", dtype=torch.bfloat16, enabled=a.bf16):
            loss = posenet_loss(model(x).float(), p, q, 1.0)
        loss.backward()
        opt.step()
        loss.item()

    model.train()
    train_ms = timed(step, a.warmup, a.steps)
    model.eval()
    one = x[:1].clone()

    def infer():
        with torch.inference_mode():
            model(one).cpu()

    infer_ms = timed(infer, a.warmup, a.infer_runs)
    print(json.dumps({
        "peer": "PyTorch " + torch.__version__,
        "gpu": torch.cuda.get_device_name(0),
        "arch": a.arch,
        "input": [a.channels, a.height, a.width],
        "batch": a.batch,
        "bf16": a.bf16,
        "train_ms_per_step": train_ms,
        "infer_ms_per_image": infer_ms,
    }))


if __name__ == "__main__":
    main()
