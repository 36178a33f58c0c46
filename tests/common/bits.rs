//! Values as their bits, for the suites' bit-for-bit comparisons (`==` on floats would take
//! `-0.0` for `0.0` and never equal a NaN).

use cubetrace::vk::frame::GpuFrame;
use glam::Vec3;

/// Each cell of a GPU buffer (a cube texel's channels, a pyramid's `[min, max]`) as its bits.
pub fn cell_bits<const N: usize>(cells: &[[f32; N]]) -> Vec<[u32; N]> {
    cells.iter().map(|c| c.map(f32::to_bits)).collect()
}

/// `Err` with the first differing cell when `gpu` and `cpu` differ in any bit.
pub fn compare_cells<const N: usize>(gpu: &[[f32; N]], cpu: &[[f32; N]]) -> Result<(), String> {
    if gpu.len() != cpu.len() {
        return Err(format!("length: GPU {}, CPU {}", gpu.len(), cpu.len()));
    }
    match cell_bits(gpu)
        .iter()
        .zip(cell_bits(cpu))
        .position(|(g, c)| *g != c)
    {
        None => Ok(()),
        Some(i) => Err(format!("cell {i}: GPU {:?}, CPU {:?}", gpu[i], cpu[i])),
    }
}

/// `v`'s components in order, as bits.
pub fn vec3_bits(v: &[Vec3]) -> Vec<u32> {
    v.iter()
        .flat_map(|c| c.to_array().map(f32::to_bits))
        .collect()
}

/// Everything of a GPU frame the outputs read, as bits: per pixel the colour, the mask, the
/// primary position where `positions` is set, and a mirror pixel's record (no pass writes the
/// others').
pub fn frame_bits(f: &GpuFrame, positions: bool) -> Vec<u32> {
    let mut out = Vec::new();
    for k in 0..f.colour.len() {
        out.extend(f.colour[k].to_array().map(f32::to_bits));
        out.push(u32::from(f.mask[k]));
        if positions {
            out.extend(f.surface_position[k].to_array().map(f32::to_bits));
        }
        if f.mask[k] != 0 {
            out.extend_from_slice(bytemuck::cast_slice(&[f.records[k]]));
        }
    }
    out
}
