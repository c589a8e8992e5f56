#!/usr/bin/env bash
# The GPU check of issue 44, for a machine with an NVIDIA GPU and PyTorch (the `device` tool's),
# run from the repository root with a release binary built elsewhere with the `wgpu` feature:
#
#   here:   CARGO_TARGET_DIR=target-gpu cargo build --release --features wgpu -p indoorloc
#           mkdir -p gpu-bin && cp target-gpu/release/indoorloc gpu-bin/ && strip gpu-bin/indoorloc
#   there:  bash scripts/gpu/check.sh gpu-bin/indoorloc      (carry: gpu-bin)
#
# It writes under $OUT (or ./gpu-check): the GPU and Vulkan driver found, `indoorloc bench train`
# and `bench infer` on the GPU for the small network and ResNet-34 (batch 32, 1x120x160 and
# 3x256x256), PyTorch's figures for the same work on the same GPU (scripts/gpu/torch_gpu.py),
# `demo --quick` trained on the GPU and on the CPU for each seed in $SEEDS, and summary.md with
# the ratios. Every step appends to its files as it ends, so a run cut short keeps what it did.
set -uo pipefail
bin=${1:-gpu-bin/indoorloc}
out=${OUT:-gpu-check}
seeds=${SEEDS:-"1 2"}
steps=${STEPS:-20}
mkdir -p "$out"
log() { echo "[$(date +%T)] $*" | tee -a "$out/log.txt"; }
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

log "gpu: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1)"
# wgpu reaches the GPU through Vulkan: NVIDIA's Vulkan driver lives in libGLX_nvidia.so.0. A
# container started with only the compute capability may have the library but no ICD file;
# write one then.
icd=$(ls /usr/share/vulkan/icd.d/nvidia_icd*.json /etc/vulkan/icd.d/nvidia_icd*.json 2>/dev/null | head -1)
if [ -z "$icd" ]; then
    glx=$(ldconfig -p 2>/dev/null | awk '/libGLX_nvidia.so.0/ {print $NF; exit}')
    if [ -n "$glx" ]; then
        icd="$out/nvidia_icd.json"
        printf '{"file_format_version":"1.0.0","ICD":{"library_path":"%s","api_version":"1.3"}}\n' "$glx" > "$icd"
        log "vulkan: no NVIDIA ICD file; wrote $icd for $glx"
    else
        log "vulkan: no NVIDIA ICD and no libGLX_nvidia.so.0: wgpu will find no GPU"
    fi
fi
[ -n "$icd" ] && export VK_ICD_FILENAMES=$icd
ldconfig -p 2>/dev/null | grep -q libvulkan.so.1 || log "vulkan: libvulkan.so.1 (the loader) is missing"
log "vulkan icd: ${VK_ICD_FILENAMES:-none}"

# Each network: indoorloc's bench on the GPU (the device's name comes with it), then PyTorch.
for arch in small resnet34; do
    log "bench train+infer $arch on wgpu"
    timeout 240 "$bin" bench train --device wgpu --arch "$arch" --train-steps "$steps" --json \
        > "$out/bench_train_$arch.json" 2>> "$out/log.txt" || log "bench train $arch failed ($?)"
    timeout 120 "$bin" bench infer --device wgpu --arch "$arch" --infer-runs 50 --json \
        > "$out/bench_infer_$arch.json" 2>> "$out/log.txt" || log "bench infer $arch failed ($?)"
    for input in "1 120 160" "3 256 256"; do
        set -- $input
        for bf16 in "" --bf16; do
            [ -n "$bf16" ] && [ "$arch" != resnet34 -o "$1" != 3 ] && continue
            timeout 120 python3 "$here/torch_gpu.py" --arch "$arch" --channels "$1" --height "$2" \
                --width "$3" --steps "$steps" $bf16 >> "$out/torch.jsonl" 2>> "$out/log.txt" \
                || log "torch $arch $input $bf16 failed ($?)"
        done
    done
done

# demo --quick trained on the GPU and on the CPU, one folder per device and seed.
for seed in $seeds; do
    for device in wgpu cpu; do
        log "demo --quick --seed $seed --device $device"
        start=$(date +%s)
        timeout 600 "$bin" demo --quick --seed "$seed" --device "$device" --out "$out/demo-$device-$seed" \
            --json > "$out/demo_${device}_$seed.json" 2>> "$out/log.txt" || log "demo $device $seed failed ($?)"
        log "demo $device seed $seed: $(( $(date +%s) - start )) s"
    done
done

python3 - "$out" <<'EOF'
import glob, json, os, sys
out = sys.argv[1]
lines = ["# GPU check (issue 44)", ""]
torch = [json.loads(l) for l in open(os.path.join(out, "torch.jsonl"))] if os.path.exists(os.path.join(out, "torch.jsonl")) else []
def peer(arch, shape, key, bf16=False):
    for t in torch:
        if t["arch"] == arch and t["input"] == shape and t["bf16"] == bf16:
            return t[key]
lines += ["| what | network | input | indoorloc ms | PyTorch ms | PyTorch / indoorloc |", "|---|---|---|---|---|---|"]
for path in sorted(glob.glob(os.path.join(out, "bench_*.json"))):
    try:
        rows = json.load(open(path))["learn"]
    except Exception as e:
        lines.append(f"| {os.path.basename(path)}: unreadable ({e}) |")
        continue
    for r in rows:
        key = "train_ms_per_step" if r["what"] == "train" else "infer_ms_per_image"
        p = peer(r["arch"], r["input"], key)
        ratio = f"{p / r['ms']:.2f}x" if p else "-"
        lines.append(f"| {r['what']} | {r['arch']} | {'x'.join(map(str, r['input']))} | {r['ms']:.2f} | {p and f'{p:.2f}' or '-'} | {ratio} |")
        device = r["device"]
lines += ["", f"device: {torch[0]['gpu'] if torch else '?'}; {torch[0]['peer'] if torch else ''}", ""]
for t in torch:
    if t["bf16"]:
        lines.append(f"PyTorch bf16 autocast {t['arch']} {t['input']}: {t['train_ms_per_step']:.2f} ms per step")
lines += ["", "| demo --quick | seed | median m | median ° | mean m | train s |", "|---|---|---|---|---|---|"]
for path in sorted(glob.glob(os.path.join(out, "demo_*.json"))):
    _, device, seed = os.path.basename(path)[:-5].split("_")
    try:
        d = json.load(open(path))
        lines.append(f"| {device} | {seed} | {d['median_pos_m']:.4f} | {d['median_rot_deg']:.3f} | {d['mean_pos_m']:.4f} | {d['seconds'].get('train', float('nan')):.1f} |")
    except Exception as e:
        lines.append(f"| {device} | {seed} | failed: {e} |")
open(os.path.join(out, "summary.md"), "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
EOF
