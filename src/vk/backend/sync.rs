//! Named `(stage, access)` pairs for barriers (synchronization2), so that a barrier reads as
//! "after X, before Y".
use ash::vk;

/// A `(stages, access)` pair, one side of a barrier.
pub type Access = (vk::PipelineStageFlags2, vk::AccessFlags2);

/// Transfer writes (copies, clears by transfer).
pub const TRANSFER_WRITE: Access = (
    vk::PipelineStageFlags2::ALL_TRANSFER,
    vk::AccessFlags2::TRANSFER_WRITE,
);
/// Transfer reads.
pub const TRANSFER_READ: Access = (
    vk::PipelineStageFlags2::ALL_TRANSFER,
    vk::AccessFlags2::TRANSFER_READ,
);
/// Everything, both ways: the heavy hammer for one-shot uploads and readbacks.
pub const ALL: Access = (
    vk::PipelineStageFlags2::ALL_COMMANDS,
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::MEMORY_READ.as_raw() | vk::AccessFlags2::MEMORY_WRITE.as_raw(),
    ),
);
/// Any later read (shaders, transfers, indirect arguments).
pub const ALL_READS: Access = (
    vk::PipelineStageFlags2::ALL_COMMANDS,
    vk::AccessFlags2::MEMORY_READ,
);
/// Colour attachment writes (including clears by load op).
pub const COLOUR_WRITE: Access = (
    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw(),
    ),
);
/// Depth tests and writes (including clears by load op).
pub const DEPTH_WRITE: Access = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw(),
    ),
);
/// Storage writes by compute or fragment shaders.
pub const SHADER_WRITE: Access = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
            | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw(),
    ),
    vk::AccessFlags2::SHADER_STORAGE_WRITE,
);
/// Shader reads (sampled, storage, uniform) by compute or fragment shaders.
pub const SHADER_READ: Access = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
            | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw()
            | vk::PipelineStageFlags2::VERTEX_SHADER.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::SHADER_READ.as_raw() | vk::AccessFlags2::UNIFORM_READ.as_raw(),
    ),
);
/// Storage writes of a compute dispatch ...
pub const COMPUTE_WRITE: Access = (
    vk::PipelineStageFlags2::COMPUTE_SHADER,
    vk::AccessFlags2::SHADER_STORAGE_WRITE,
);
/// ... made visible to storage reads of the next one.
pub const COMPUTE_READ: Access = (
    vk::PipelineStageFlags2::COMPUTE_SHADER,
    vk::AccessFlags2::SHADER_STORAGE_READ,
);

/// Storage reads and writes of the compute and fragment stages (ray queues and their counters).
pub const STORAGE_RW: Access = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
            | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::SHADER_STORAGE_READ.as_raw()
            | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw(),
    ),
);

/// The indirect command read of `vkCmdDispatchIndirect`, plus the kernel's storage reads and
/// writes.
pub const INDIRECT_READ: Access = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::DRAW_INDIRECT.as_raw()
            | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::INDIRECT_COMMAND_READ.as_raw()
            | vk::AccessFlags2::SHADER_STORAGE_READ.as_raw()
            | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw(),
    ),
);
