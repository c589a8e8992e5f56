//! `--device`: where the networks of every command run (`train`, `localize`, `demo`, `study`,
//! `bench train|infer`, `serve`, `explain`), chosen once for the process before the command
//! starts. The choice itself, and what each backend needs, is `learn::device`.

use crate::{Result, progress};
pub use learn::ComputeDevice;

/// Makes `device` the process's device for every network, after checking that this build
/// has it and that it answers; says which device answered, and warns when wgpu found no
/// graphics card (a software rasterizer runs far slower than `cpu`).
pub fn select(device: ComputeDevice) -> Result<()> {
    let selected = learn::device::select(device)?;
    if device != ComputeDevice::Cpu {
        progress::note(&format!("device: {device} ({})", selected.name));
        if !selected.is_gpu {
            progress::note(&format!(
                "warning: `{device}` is {}, not a graphics card: expect it to be slower than \
                 `--device cpu`",
                selected.name
            ));
        }
    }
    Ok(())
}
