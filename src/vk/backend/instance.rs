//! The headless Vulkan instance, the optional Khronos validation layer and the debug-utils
//! messenger.
//!
//! Invariants:
//! - The loader is loaded at run time (`ash::Entry::load`); a missing loader is
//!   [`VkError::NoDriver`], never a link error or a panic.
//! - The messenger's user data points into an `Arc<ValidationLog>` that this [`Instance`] owns, and
//!   the messenger is destroyed before that `Arc` is dropped and before the instance.
//! - The callback never unwinds into the driver: its body runs under `catch_unwind`.
use std::ffi::{CStr, c_void};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::error::{VkError, VkResult, call_err};

/// Name of the Khronos validation layer.
pub const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Environment variable that turns validation on (value `1`), as [`Validation::Required`].
pub const VALIDATION_ENV: &str = "CUBETRACE_VALIDATION";

/// Whether to run under the Khronos validation layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Validation {
    /// No layer (unless `CUBETRACE_VALIDATION=1`).
    #[default]
    Off,
    /// Use the layer when it is installed; proceed without it (with a log line) when not.
    IfAvailable,
    /// Fail with [`VkError::NoValidationLayer`] when the layer is not installed.
    Required,
}

/// Messages the validation layer (or driver) reported through debug utils.
///
/// Shared between the messenger callback and the context; outlives both so tests can read it
/// after the context is dropped (leak reports arrive at device destruction).
#[derive(Debug, Default)]
pub struct ValidationLog {
    errors: Mutex<Vec<String>>,
    warnings: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Every error message so far.
    pub fn errors(&self) -> Vec<String> {
        self.errors.lock().map(|v| v.clone()).unwrap_or_default()
    }

    /// Every warning message so far.
    pub fn warnings(&self) -> Vec<String> {
        self.warnings.lock().map(|v| v.clone()).unwrap_or_default()
    }

    fn push(list: &Mutex<Vec<String>>, msg: String) {
        if let Ok(mut v) = list.lock() {
            v.push(msg);
        }
    }
}

/// The debug-utils messenger and its instance-level function table.
struct Messenger {
    loader: ash::ext::debug_utils::Instance,
    raw: vk::DebugUtilsMessengerEXT,
}

/// A Vulkan instance. Dropped after every device made from it.
pub struct Instance {
    pub(crate) entry: ash::Entry,
    pub(crate) raw: ash::Instance,
    messenger: Option<Messenger>,
    /// Whether `VK_EXT_debug_utils` is enabled (labels and object names are then available).
    pub(crate) debug_utils: bool,
    /// Whether the validation layer is enabled.
    pub(crate) validation: bool,
    pub(crate) log: Arc<ValidationLog>,
}

impl Instance {
    /// Loads the Vulkan loader and creates a Vulkan 1.3 instance with no surface extensions.
    pub fn new(validation: Validation) -> VkResult<Self> {
        let validation = match std::env::var(VALIDATION_ENV).as_deref() {
            Ok("1") => Validation::Required,
            _ => validation,
        };
        // SAFETY: loading the system loader runs its initialisers; we trust the installed libvulkan.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| VkError::NoDriver {
            detail: format!("cannot load the Vulkan loader: {e}"),
        })?;

        // SAFETY: `entry` is a loaded loader; this enumerates global layers.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(call_err("vkEnumerateInstanceLayerProperties", "instance"))?;
        let layer_present = layers
            .iter()
            .any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
        let use_layer = match (validation, layer_present) {
            (Validation::Off, _) => false,
            (_, true) => true,
            (Validation::IfAvailable, false) => {
                log::info!(
                    "validation layer not installed (apt: vulkan-validationlayers); running without"
                );
                false
            }
            (Validation::Required, false) => {
                return Err(VkError::NoValidationLayer {
                    layer: VALIDATION_LAYER.to_string_lossy().into_owned(),
                });
            }
        };

        // SAFETY: `entry` is loaded; `None` asks for the loader's and implicit layers' extensions.
        let exts = unsafe { entry.enumerate_instance_extension_properties(None) }.map_err(
            call_err("vkEnumerateInstanceExtensionProperties", "instance"),
        )?;
        let debug_utils = exts
            .iter()
            .any(|e| e.extension_name_as_c_str() == Ok(ash::ext::debug_utils::NAME));

        let app = vk::ApplicationInfo::default()
            .application_name(c"cubetrace")
            .engine_name(c"cubetrace")
            .api_version(vk::API_VERSION_1_3);
        let layer_names: Vec<*const i8> = if use_layer {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };
        let ext_names: Vec<*const i8> = if debug_utils {
            vec![ash::ext::debug_utils::NAME.as_ptr()]
        } else {
            vec![]
        };
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&ext_names);
        // SAFETY: `info` and the name arrays it points to live until the call returns.
        let raw = unsafe { entry.create_instance(&info, None) }.map_err(|result| match result {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER | vk::Result::ERROR_INITIALIZATION_FAILED => {
                VkError::NoDriver {
                    detail: format!("vkCreateInstance: {result}"),
                }
            }
            result => VkError::Call {
                call: "vkCreateInstance",
                what: "instance".into(),
                result,
            },
        })?;

        let log = Arc::new(ValidationLog::default());
        let mut instance = Instance {
            entry,
            raw,
            messenger: None,
            debug_utils,
            validation: use_layer,
            log,
        };
        if debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&instance.entry, &instance.raw);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(Arc::as_ptr(&instance.log) as *mut c_void);
            // SAFETY: the user data (`Arc<ValidationLog>`) is owned by `instance` and outlives the
            // messenger, which `Drop` destroys first.
            let raw = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .map_err(call_err("vkCreateDebugUtilsMessengerEXT", "instance"))?;
            instance.messenger = Some(Messenger { loader, raw });
        }
        Ok(instance)
    }

    /// The shared log of validation messages.
    pub fn validation_log(&self) -> &Arc<ValidationLog> {
        &self.log
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        if let Some(m) = self.messenger.take() {
            // SAFETY: the messenger was created from this instance and is destroyed once.
            unsafe { m.loader.destroy_debug_utils_messenger(m.raw, None) };
        }
        // SAFETY: every child object (devices, messenger) is gone: devices hold an `Arc<Instance>`.
        unsafe { self.raw.destroy_instance(None) };
    }
}

/// Debug-utils callback: logs through `log` and records errors and warnings in the
/// [`ValidationLog`] given as user data. Never unwinds.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // SAFETY: the driver passes a valid callback-data pointer (or null) for this call's duration.
        let data = unsafe { data.as_ref() };
        let message = data
            .filter(|d| !d.p_message.is_null())
            // SAFETY: `p_message` is a NUL-terminated string valid during the callback.
            .map(|d| {
                unsafe { CStr::from_ptr(d.p_message) }
                    .to_string_lossy()
                    .into_owned()
            })
            .unwrap_or_default();
        let text = format!("[{types:?}] {message}");
        // SAFETY: user data is `Arc::as_ptr` of the instance's log, alive while the messenger is.
        let log = unsafe { (user_data as *const ValidationLog).as_ref() };
        if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            log::error!(target: "vulkan", "{text}");
            if let Some(l) = log {
                ValidationLog::push(&l.errors, text);
            }
        } else {
            log::warn!(target: "vulkan", "{text}");
            if let Some(l) = log {
                ValidationLog::push(&l.warnings, text);
            }
        }
    }));
    vk::FALSE
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `CUBETRACE_VALIDATION=1` asks for the layer (CI does): then a missing loader,
    /// layer or debug utils fails these tests instead of skipping them.
    fn required() -> bool {
        std::env::var(VALIDATION_ENV).as_deref() == Ok("1")
    }

    /// An instance with the validation layer and its messenger, or `None` (with a note) where
    /// the loader, the layer or debug utils is missing and validation is not required.
    fn validated_instance() -> Option<Instance> {
        let missing = |why: String| {
            assert!(!required(), "{VALIDATION_ENV}=1: {why}");
            eprintln!("skipped: {why}");
            None
        };
        let instance = match Instance::new(Validation::IfAvailable) {
            Ok(i) => i,
            Err(e) => return missing(e.to_string()),
        };
        if !instance.validation {
            return missing("the validation layer is not installed".into());
        }
        if instance.messenger.is_none() {
            return missing("no VK_EXT_debug_utils".into());
        }
        Some(instance)
    }

    /// The messenger path records errors: inject one with vkSubmitDebugUtilsMessageEXT.
    #[test]
    fn messenger_records_injected_error() {
        let Some(instance) = validated_instance() else {
            return;
        };
        let Some(m) = &instance.messenger else {
            unreachable!("validated_instance checks the messenger")
        };
        assert!(instance.validation_log().errors().is_empty());
        let data =
            vk::DebugUtilsMessengerCallbackDataEXT::default().message(c"injected test error");
        // SAFETY: the instance and its messenger are alive; `data` outlives the call.
        unsafe {
            m.loader.submit_debug_utils_message(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                &data,
            )
        };
        let errors = instance.validation_log().errors();
        assert_eq!(errors.len(), 1, "{errors:?}");
        assert!(errors[0].contains("injected test error"));
    }

    /// A real misuse reaches the log: `vkGetPhysicalDeviceImageFormatProperties` with no usage
    /// bit breaks VUID-vkGetPhysicalDeviceImageFormatProperties-usage-requiredbitmask, which the
    /// layer's parameter validation reports. Negative: the same query with a usage bit is
    /// valid and records nothing, so the error is the misuse's, not noise.
    #[test]
    fn validation_layer_reports_a_real_misuse() {
        let Some(instance) = validated_instance() else {
            return;
        };
        // SAFETY: the instance is alive.
        let devices = unsafe { instance.raw.enumerate_physical_devices() }
            .expect("vkEnumeratePhysicalDevices");
        let Some(&device) = devices.first() else {
            assert!(!required(), "{VALIDATION_ENV}=1: no physical device");
            return eprintln!("skipped: no physical device");
        };
        let query = |usage: vk::ImageUsageFlags| {
            // SAFETY: `device` comes from this live instance; the layer checks the arguments
            // before the driver sees them (an empty usage is the misuse under test).
            let _ = unsafe {
                instance.raw.get_physical_device_image_format_properties(
                    device,
                    vk::Format::R8G8B8A8_UNORM,
                    vk::ImageType::TYPE_2D,
                    vk::ImageTiling::OPTIMAL,
                    usage,
                    vk::ImageCreateFlags::empty(),
                )
            };
            instance.validation_log().errors()
        };
        let valid = query(vk::ImageUsageFlags::SAMPLED);
        assert!(valid.is_empty(), "a valid query reported {valid:?}");
        let misuse = query(vk::ImageUsageFlags::empty());
        assert!(
            misuse
                .iter()
                .any(|e| e.contains("VUID-vkGetPhysicalDeviceImageFormatProperties-usage")),
            "the layer did not report an empty usage: {misuse:?}"
        );
    }
}
