//! Where the networks run: the CPU (burn's `flex` backend, with this crate's hand-written
//! kernels for convolution and BatchNorm) or a GPU through burn's wgpu backend (WGSL kernels
//! that wgpu hands to Vulkan on Linux, Metal on macOS, DX12 on Windows: NVIDIA, AMD, Intel and
//! Apple GPUs alike), chosen once per process with [`select`].
//!
//! burn 0.22 picks the backend by device and every tensor carries its device, so the choice is
//! a [`burn::tensor::Device`] that training, inference and the benchmarks start from; the
//! kernels take only f32 tensors on `flex` (`kernels::supported`) and every other
//! device runs burn's own ops. Checkpoints hold plain f32 values, so a model trained on one
//! device loads on the other.
//!
//! The GPU backend is the cargo feature `wgpu` (off by default: it adds burn's cubecl stack,
//! minutes of build time the CPU build does not need). burn's CUDA backend is not offered:
//! cubecl-cuda 0.11 downloads an LLVM bundle from GitHub in its build script, which a build
//! that reaches only package registries cannot do; on NVIDIA GPUs Vulkan serves instead. Nor is
//! burn's SPIR-V compiler (its `vulkan` feature): Mesa's lavapipe, the Vulkan driver this was
//! tested on without a GPU, crashes compiling its matrix-product kernels, where the WGSL path
//! runs.

use std::fmt;
use std::panic::{self, AssertUnwindSafe};
use std::str::FromStr;
use std::sync::RwLock;

use burn::tensor::Device;

use crate::{LearnError, Result};

/// A device the networks can run on, as `--device` names it: `cpu`, `wgpu` (the best adapter
/// wgpu finds) or `wgpu:N` (the N-th discrete GPU).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ComputeDevice {
    /// burn's `flex` CPU backend with the hand-written kernels, threads from rayon's pool.
    #[default]
    Cpu,
    /// burn's wgpu backend: the default adapter (`None`) or the n-th discrete GPU.
    Wgpu(Option<usize>),
}

/// What [`select`] found: the device and its name as the driver gives it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Selected {
    /// The device chosen.
    pub device: ComputeDevice,
    /// Its name (`NVIDIA H100 80GB HBM3`, `llvmpipe (LLVM 15.0.6, 256 bits)`, `CPU`).
    pub name: String,
    /// Whether it is a graphics card rather than a CPU or a software rasterizer, which would
    /// run far slower than `cpu`.
    pub is_gpu: bool,
}

/// What a CPU device is called in [`Selected::name`].
const CPU_NAME: &str = "CPU";

/// The process-wide choice; the CPU until [`select`] says otherwise.
static SELECTED: RwLock<Option<Selected>> = RwLock::new(None);

impl ComputeDevice {
    /// Whether this build can run on this device (the `wgpu` feature for a GPU).
    pub fn is_built_in(self) -> bool {
        match self {
            ComputeDevice::Cpu => true,
            ComputeDevice::Wgpu(_) => cfg!(feature = "wgpu"),
        }
    }

    /// burn's device for inference; the feature is checked by [`select`], the only way a
    /// GPU becomes the process's choice.
    fn burn_device(self) -> Device {
        match self {
            ComputeDevice::Cpu => Device::flex(),
            #[cfg(feature = "wgpu")]
            ComputeDevice::Wgpu(index) => {
                use burn::tensor::DeviceKind;
                Device::wgpu(index.map_or(DeviceKind::DefaultDevice, DeviceKind::DiscreteGpu))
            }
            #[cfg(not(feature = "wgpu"))]
            ComputeDevice::Wgpu(_) => unreachable!("select refuses devices not built in"),
        }
    }
}

impl fmt::Display for ComputeDevice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ComputeDevice::Cpu => f.write_str("cpu"),
            ComputeDevice::Wgpu(None) => f.write_str("wgpu"),
            ComputeDevice::Wgpu(Some(i)) => write!(f, "wgpu:{i}"),
        }
    }
}

impl FromStr for ComputeDevice {
    type Err = LearnError;

    fn from_str(s: &str) -> Result<Self> {
        let (name, index) = match s.trim().split_once(':') {
            Some((name, index)) => (name, Some(index)),
            None => (s.trim(), None),
        };
        let index = index
            .map(|i| {
                i.parse::<usize>().map_err(|_| {
                    LearnError::Device(format!("`{s}`: the index after `:` must be a number"))
                })
            })
            .transpose()?;
        match (name.to_ascii_lowercase().as_str(), index) {
            ("cpu", None) => Ok(ComputeDevice::Cpu),
            ("wgpu" | "gpu" | "vulkan", index) => Ok(ComputeDevice::Wgpu(index)),
            ("cuda", _) => Err(LearnError::Device(format!(
                "`{s}`: indoorloc has no CUDA backend (burn's needs an LLVM download at build \
                 time); use `wgpu`, which reaches NVIDIA GPUs through Vulkan"
            ))),
            _ => Err(LearnError::Device(format!(
                "`{s}`: unknown device; use cpu, wgpu or wgpu:N"
            ))),
        }
    }
}

/// Makes `device` the process's device for training, inference and benchmarks, after checking
/// that this build has it and that a GPU answers (one small computation read back; the CPU
/// always does, so every command's start-up skips it). An error names what is missing: the
/// cargo feature, or a driver that finds no adapter.
pub fn select(device: ComputeDevice) -> Result<Selected> {
    if !device.is_built_in() {
        return Err(LearnError::Device(format!(
            "`{device}`: this indoorloc was built without GPU support; rebuild it with \
             `cargo build --release --features wgpu` (README, \"On a GPU\")"
        )));
    }
    let selected = match device {
        ComputeDevice::Cpu => Selected {
            device,
            name: CPU_NAME.into(),
            is_gpu: false,
        },
        ComputeDevice::Wgpu(_) => probe(device)?,
    };
    *SELECTED.write().unwrap_or_else(|e| e.into_inner()) = Some(selected.clone());
    Ok(selected)
}

/// The device [`select`] chose (`cpu` by default).
pub fn selected() -> ComputeDevice {
    SELECTED
        .read()
        .unwrap_or_else(|e| e.into_inner())
        .as_ref()
        .map_or(ComputeDevice::Cpu, |s| s.device)
}

/// The device [`select`] chose as reports name it: `cpu`, or `wgpu: ` and the driver's name.
pub fn describe() -> String {
    match &*SELECTED.read().unwrap_or_else(|e| e.into_inner()) {
        Some(s) if s.device != ComputeDevice::Cpu => format!("{}: {}", s.device, s.name),
        _ => "cpu".into(),
    }
}

/// burn's device for inference on the selected device.
pub(crate) fn inference() -> Device {
    selected().burn_device()
}

/// burn's device for training (autodiff) on the selected device.
pub(crate) fn training() -> Device {
    inference().autodiff()
}

/// Runs a sum on `device` and reads it back. burn's GPU runtimes panic when no adapter or
/// driver is found, so the panic is caught here (its message kept, the default hook's print
/// held back) and turned into an error.
fn probe(device: ComputeDevice) -> Result<Selected> {
    let run = || {
        let dev = device.burn_device();
        let t = burn::tensor::Tensor::<1>::from_floats([1.0, 2.0, 3.0], &dev);
        let sum = t.sum().into_scalar::<f32>();
        (sum, identity(&dev))
    };
    let hook = panic::take_hook();
    panic::set_hook(Box::new(|_| {}));
    let result = panic::catch_unwind(AssertUnwindSafe(run));
    panic::set_hook(hook);
    match result {
        Ok((sum, _)) if sum != 6.0 => Err(LearnError::Device(format!(
            "`{device}`: a test sum came back as {sum}, not 6"
        ))),
        Ok((_, (name, is_gpu))) => Ok(Selected {
            device,
            name,
            is_gpu,
        }),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "the runtime gave no reason".into());
            Err(LearnError::Device(format!(
                "`{device}`: no usable device ({}); a GPU needs its Vulkan driver on the host \
                 (Debian: libvulkan1 and the vendor's ICD, e.g. NVIDIA's driver with its \
                 graphics part)",
                msg.lines().next().unwrap_or_default()
            )))
        }
    }
}

/// The device's name and whether it is a card.
fn identity(device: &Device) -> (String, bool) {
    #[cfg(feature = "wgpu")]
    if let Some(id) = device.identity() {
        return (id.name, id.physical.is_some());
    }
    let _ = device;
    (CPU_NAME.into(), false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_print_back() {
        for (text, device) in [
            ("cpu", ComputeDevice::Cpu),
            ("wgpu", ComputeDevice::Wgpu(None)),
            ("wgpu:1", ComputeDevice::Wgpu(Some(1))),
        ] {
            assert_eq!(text.parse::<ComputeDevice>().unwrap(), device);
            assert_eq!(device.to_string(), text);
        }
        assert_eq!(
            "GPU".parse::<ComputeDevice>().unwrap(),
            ComputeDevice::Wgpu(None)
        );
    }

    #[test]
    fn unknown_and_cuda_are_refused_with_the_reason() {
        let err = "tpu".parse::<ComputeDevice>().unwrap_err().to_string();
        assert!(err.contains("cpu, wgpu or wgpu:N"), "{err}");
        let err = "cuda:0".parse::<ComputeDevice>().unwrap_err().to_string();
        assert!(err.contains("Vulkan"), "{err}");
        let err = "wgpu:x".parse::<ComputeDevice>().unwrap_err().to_string();
        assert!(err.contains("number"), "{err}");
    }

    #[test]
    fn the_cpu_answers() {
        let cpu = probe(ComputeDevice::Cpu).unwrap();
        assert!(!cpu.is_gpu);
        assert_eq!(select(ComputeDevice::Cpu).unwrap(), cpu);
    }

    #[cfg(not(feature = "wgpu"))]
    #[test]
    fn a_gpu_without_the_feature_names_the_feature() {
        let err = select(ComputeDevice::Wgpu(None)).unwrap_err().to_string();
        assert!(err.contains("--features wgpu"), "{err}");
        assert_eq!(selected(), ComputeDevice::Cpu);
    }
}
