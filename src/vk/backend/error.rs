//! Errors at the Vulkan edge. Each variant carries the name of the resource or pass involved, so
//! a failure says *what* failed, not only the `VkResult`.
use ash::vk;

/// How to install a Vulkan driver; part of [`VkError::NoDriver`]'s message.
pub const INSTALL_HINT: &str = "install a Vulkan loader and driver, e.g. on Debian/Ubuntu: \
    `sudo apt-get install mesa-vulkan-drivers libvulkan1` (lavapipe, a CPU implementation, \
    is enough for the tests)";

/// An error from the Vulkan backend.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    /// The Vulkan loader library could not be loaded, or it found no driver / no device.
    #[error("no Vulkan loader or device available ({detail}); {hint}", hint = INSTALL_HINT)]
    NoDriver { detail: String },
    /// The chosen device lacks something cubetrace requires.
    #[error("Vulkan device `{device}` lacks required feature `{feature}`")]
    MissingFeature { device: String, feature: String },
    /// `--device N` named a device that does not exist.
    #[error("Vulkan device index {index} out of range: {count} device(s) present")]
    BadDeviceIndex { index: usize, count: usize },
    /// A Vulkan call failed.
    #[error("Vulkan call `{call}` failed for `{what}`: {result}")]
    Call {
        call: &'static str,
        what: String,
        result: vk::Result,
    },
    /// gpu-allocator failed to allocate or free memory. The allocator's error is part of the
    /// message, not a `source()`, so that a chain printer (`{:#}`) prints it once.
    #[error("memory allocation for `{what}` failed: {error}")]
    Alloc {
        what: String,
        error: gpu_allocator::AllocationError,
    },
    /// Validation was required (`--validate`, `CUBETRACE_VALIDATION=1`) but the layer is not
    /// installed.
    #[error(
        "validation was asked for (--validate or CUBETRACE_VALIDATION=1), but the Khronos \
         validation layer {layer} is not installed; install it (Debian/Ubuntu: \
         `sudo apt-get install vulkan-validationlayers`) or run without validation"
    )]
    NoValidationLayer { layer: String },
    /// A shader table entry could not be used (missing entry point, bad binding, …).
    #[error("shader pass `{pass}`: {detail}")]
    Shader { pass: String, detail: String },
    /// A resource exceeds a device limit (e.g. a cube size too large to bind on this device).
    #[error(
        "{what} exceeds the limit of {device} ({limit}); use a smaller --cube-size, fewer CMOs \
         or a smaller frame"
    )]
    Limit {
        device: String,
        what: String,
        limit: String,
    },
    /// A caller asked for something inconsistent (sizes, formats, …).
    #[error("`{what}`: {detail}")]
    Usage { what: String, detail: String },
}

/// Result alias for the Vulkan backend.
pub type VkResult<T> = Result<T, VkError>;

/// Builds a `map_err` closure naming the Vulkan call and the resource it was for.
pub(crate) fn call_err(
    call: &'static str,
    what: impl Into<String>,
) -> impl FnOnce(vk::Result) -> VkError {
    let what = what.into();
    move |result| VkError::Call { call, what, result }
}

/// Builds a `map_err` closure for allocator failures.
pub(crate) fn alloc_err(
    what: impl Into<String>,
) -> impl FnOnce(gpu_allocator::AllocationError) -> VkError {
    let what = what.into();
    move |error| VkError::Alloc { what, error }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_driver_message_says_how_to_install() {
        let e = VkError::NoDriver {
            detail: "libvulkan.so.1 not found".into(),
        };
        let msg = e.to_string();
        assert!(msg.contains("mesa-vulkan-drivers"), "{msg}");
        assert!(msg.contains("libvulkan.so.1 not found"), "{msg}");
    }

    #[test]
    fn missing_feature_names_the_feature() {
        let e = VkError::MissingFeature {
            device: "gpu".into(),
            feature: "synchronization2".into(),
        };
        assert!(e.to_string().contains("synchronization2"));
    }
}
