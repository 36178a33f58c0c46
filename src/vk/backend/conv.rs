//! Pure, safe mappings between the reflected shader table and Vulkan enums.
use ash::vk;

use super::shaders::{BindingKind, Stage, TexelFormat};

/// Descriptor type for a reflected binding.
pub fn descriptor_type(kind: BindingKind) -> vk::DescriptorType {
    match kind {
        BindingKind::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
        BindingKind::StorageBuffer { .. } => vk::DescriptorType::STORAGE_BUFFER,
        BindingKind::SampledTexture { .. } => vk::DescriptorType::SAMPLED_IMAGE,
        BindingKind::StorageTexture { .. } => vk::DescriptorType::STORAGE_IMAGE,
        BindingKind::Sampler { .. } => vk::DescriptorType::SAMPLER,
    }
}

/// Shader stage flag for an entry point's stage.
pub fn shader_stage(stage: Stage) -> vk::ShaderStageFlags {
    match stage {
        Stage::Vertex => vk::ShaderStageFlags::VERTEX,
        Stage::Fragment => vk::ShaderStageFlags::FRAGMENT,
        Stage::Compute => vk::ShaderStageFlags::COMPUTE,
    }
}

/// Vulkan format of a WGSL storage texel format; `None` where cubetrace has no use for it.
pub fn texel_format(f: TexelFormat) -> Option<vk::Format> {
    Some(match f {
        TexelFormat::R32Float => vk::Format::R32_SFLOAT,
        TexelFormat::R32Uint => vk::Format::R32_UINT,
        TexelFormat::R32Sint => vk::Format::R32_SINT,
        TexelFormat::Rg32Float => vk::Format::R32G32_SFLOAT,
        TexelFormat::Rg32Uint => vk::Format::R32G32_UINT,
        TexelFormat::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
        TexelFormat::Rgba16Float => vk::Format::R16G16B16A16_SFLOAT,
        TexelFormat::Rgba32Float => vk::Format::R32G32B32A32_SFLOAT,
        TexelFormat::Rgba32Uint => vk::Format::R32G32B32A32_UINT,
        _ => return None,
    })
}

/// Bytes per texel of the colour formats cubetrace images use; `None` for others.
pub fn format_texel_size(format: vk::Format) -> Option<u32> {
    Some(match format {
        vk::Format::R32_SFLOAT | vk::Format::R32_UINT | vk::Format::R32_SINT => 4,
        vk::Format::R8G8B8A8_SRGB | vk::Format::R8G8B8A8_UNORM => 4,
        vk::Format::R32G32_SFLOAT | vk::Format::R32G32_UINT => 8,
        vk::Format::R16G16B16A16_SFLOAT => 8,
        vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
        vk::Format::D32_SFLOAT => 4,
        _ => return None,
    })
}

/// Human name of a physical device type.
pub fn device_type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

/// Names of the subgroup operation bits that are set.
pub fn subgroup_ops_names(ops: vk::SubgroupFeatureFlags) -> Vec<&'static str> {
    const NAMES: [(vk::SubgroupFeatureFlags, &str); 8] = [
        (vk::SubgroupFeatureFlags::BASIC, "basic"),
        (vk::SubgroupFeatureFlags::VOTE, "vote"),
        (vk::SubgroupFeatureFlags::ARITHMETIC, "arithmetic"),
        (vk::SubgroupFeatureFlags::BALLOT, "ballot"),
        (vk::SubgroupFeatureFlags::SHUFFLE, "shuffle"),
        (
            vk::SubgroupFeatureFlags::SHUFFLE_RELATIVE,
            "shuffle_relative",
        ),
        (vk::SubgroupFeatureFlags::CLUSTERED, "clustered"),
        (vk::SubgroupFeatureFlags::QUAD, "quad"),
    ];
    NAMES
        .iter()
        .filter(|(f, _)| ops.contains(*f))
        .map(|(_, n)| *n)
        .collect()
}

/// Names of the shader stage bits that are set (only the stages cubetrace uses).
pub fn stage_names(stages: vk::ShaderStageFlags) -> Vec<&'static str> {
    const NAMES: [(vk::ShaderStageFlags, &str); 3] = [
        (vk::ShaderStageFlags::VERTEX, "vertex"),
        (vk::ShaderStageFlags::FRAGMENT, "fragment"),
        (vk::ShaderStageFlags::COMPUTE, "compute"),
    ];
    NAMES
        .iter()
        .filter(|(f, _)| stages.contains(*f))
        .map(|(_, n)| *n)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_only_and_read_write_storage_are_both_storage_buffers() {
        for read_only in [true, false] {
            assert_eq!(
                descriptor_type(BindingKind::StorageBuffer { read_only }),
                vk::DescriptorType::STORAGE_BUFFER
            );
        }
        assert_eq!(
            descriptor_type(BindingKind::UniformBuffer),
            vk::DescriptorType::UNIFORM_BUFFER
        );
    }
}
