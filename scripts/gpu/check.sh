#!/usr/bin/env bash
# The GPU check of issue 44, for a machine with an NVIDIA GPU and PyTorch (the `device` tool's),
# run from the repository root with a release binary built elsewhere with the `wgpu` feature:
#
#   here:   CARGO_TARGET_DIR=target-gpu cargo build --release --features wgpu -p indoorloc
#           mkdir -p gpu-bin && strip -o gpu-bin/indoorloc target-gpu/release/indoorloc
#           xz -T2 -6 -f gpu-bin/indoorloc        # 95 MB stripped, ~20 MB packed: carry takes 64 MiB
#   there:  bash scripts/gpu/check.sh gpu-bin/indoorloc.xz   (carry: gpu-bin)
#
# It writes under $OUT (or ./gpu-check): the GPU and Vulkan driver found, `indoorloc bench train`
# and `bench infer` on the GPU for the small network and ResNet-34 (batch 32, 1x120x160 and
# 3x256x256), PyTorch's figures for the same work on the same GPU (scripts/gpu/torch_gpu.py),
# `demo --quick` trained on the GPU and on the CPU for each seed in $SEEDS, and summary.md with
# the ratios ($ARCHS, $SEEDS and $STEPS narrow it: ARCHS="" SEEDS="" checks only the set-up).
# Every step appends to its files as it ends, so a run cut short keeps what it did.
set -uo pipefail
bin=${1:-gpu-bin/indoorloc.xz}
out=${OUT:-gpu-check}
seeds=${SEEDS-"1 2"}
steps=${STEPS:-20}
archs=${ARCHS-"small resnet34"}
mkdir -p "$out"
log() { echo "[$(date +%T)] $*" | tee -a "$out/log.txt"; }
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [[ $bin == *.xz ]]; then
    unpacked=$(mktemp -d)/indoorloc
    xz -dc "$bin" > "$unpacked" 2>/dev/null \
        || python3 -c 'import lzma, sys, shutil; shutil.copyfileobj(lzma.open(sys.argv[1]), open(sys.argv[2], "wb"))' "$bin" "$unpacked"
    chmod +x "$unpacked"
    bin=$unpacked
fi
log "indoorloc: $("$bin" --version 2>&1)"

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
for arch in $archs; do
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

python3 "$here/summary.py" "$out"
