#!/usr/bin/env python3
"""summary.md of a GPU check folder (scripts/gpu/check.sh): indoorloc's bench rows beside
PyTorch's figures for the same work on the same GPU, and `demo --quick` per device and seed.

Usage: summary.py DIR   (reads DIR/bench_*.json, DIR/torch.jsonl, DIR/demo_*_SEED.json)
"""

import glob
import json
import os
import sys


def read_jsonl(path):
    if not os.path.exists(path):
        return []
    return [json.loads(line) for line in open(path) if line.strip()]


def peer_ms(torch, arch, shape, key, bf16=False):
    for t in torch:
        if t["arch"] == arch and t["input"] == shape and t["bf16"] == bf16:
            return t[key]
    return None


def bench_lines(out, torch):
    lines = [
        "| what | network | input | indoorloc ms | PyTorch ms | PyTorch / indoorloc |",
        "|---|---|---|---|---|---|",
    ]
    devices = set()
    for path in sorted(glob.glob(os.path.join(out, "bench_*.json"))):
        try:
            rows = json.load(open(path))["learn"]
        except (OSError, ValueError, KeyError) as e:
            lines.append(f"| {os.path.basename(path)} | unreadable: {e} | | | | |")
            continue
        for r in rows:
            devices.add(r["device"])
            key = "train_ms_per_step" if r["what"] == "train" else "infer_ms_per_image"
            p = peer_ms(torch, r["arch"], r["input"], key)
            shape = "x".join(map(str, r["input"]))
            peer = f"{p:.2f}" if p else "-"
            ratio = f"{p / r['ms']:.2f}x" if p else "-"
            lines.append(f"| {r['what']} | {r['arch']} | {shape} | {r['ms']:.2f} | {peer} | {ratio} |")
    lines.append("")
    lines.append(f"indoorloc's device: {', '.join(sorted(devices)) or '?'}")
    if torch:
        lines.append(f"PyTorch: {torch[0]['peer']} on {torch[0]['gpu']}")
    for t in torch:
        if t["bf16"]:
            lines.append(
                f"PyTorch with bf16 autocast, {t['arch']} {'x'.join(map(str, t['input']))}: "
                f"{t['train_ms_per_step']:.2f} ms per step"
            )
    return lines


def demo_lines(out):
    lines = [
        "| demo --quick | seed | median m | median ° | mean m | train s | total s |",
        "|---|---|---|---|---|---|---|",
    ]
    for path in sorted(glob.glob(os.path.join(out, "demo_*_*.json"))):
        _, device, seed = os.path.basename(path)[: -len(".json")].split("_")
        try:
            d = json.load(open(path))
            s = d["seconds"]
            lines.append(
                f"| {device} | {seed} | {d['median_pos_m']:.4f} | {d['median_rot_deg']:.3f} | "
                f"{d['mean_pos_m']:.4f} | {s['train']:.1f} | {s['total']:.1f} |"
            )
        except (OSError, ValueError, KeyError) as e:
            lines.append(f"| {device} | {seed} | failed: {e} | | | | |")
    return lines


def main():
    out = sys.argv[1]
    torch = read_jsonl(os.path.join(out, "torch.jsonl"))
    lines = ["# GPU check (issue 44)", ""] + bench_lines(out, torch) + [""] + demo_lines(out)
    text = "\n".join(lines) + "\n"
    with open(os.path.join(out, "summary.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
